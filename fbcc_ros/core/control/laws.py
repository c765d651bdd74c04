"""FBCC (eq. 26-30, Algorithm 1) and the admittance baseline it is compared with.

Both laws share the second-order compliance filter of eq. (27), one per feature, with the
diagonal gains of eq. (30), and the insertion reference for the depth l. They differ in exactly
the two points the paper claims matter:

* **FBCC** drives the filter with ``A(l) F_ext`` (the direction matrix of eq. 28, from the
  boundary mapping) and integrates its output: ``x_c = x_rfr - ∫ x_d dt`` (eq. 27).
* **Admittance** drives it with the raw wrench (A = I: My drives theta_y in N·m) and adds its
  output as a displacement: ``x_c = x_rfr - x_d``.

Reading of the integrator (DESIGN §5 and ``docs/reproduction.md``). Algorithm 1 writes
``x_rfr(i) = x_rfr(i-1) - x_d(i)``, a sum per control step, and the paper gives no control
period. A per-step sum makes the gains depend on the rate (the same Table I values would be
1000 times more aggressive at 1 kHz than at 1 Hz); we read x_d as an adjustment *rate*
[m/s, rad/s] and integrate it, ``x_rfr(i) = x_rfr(i-1) - x_d(i) dt``, so the behaviour is the
same at any rate fast enough for the filter. The dead band ``x_d_limit`` then is a rate too.

All arrays are batched: one row per trial, shape (N, 5), in the feature order
(dx, dy, l, theta_x, theta_y); a single vector of shape (5,) works as well. One compiled step
(:func:`_law_rows`, numba) serves both: the simulator's thousands of trials and the 1 kHz
controller's single row, where numpy's per-call overhead alone came to ~35 µs a period.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numba
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from fbcc_ros.core.contact.model import FloatArray, PegHole, as_rows
from fbcc_ros.core.contact.segmentation import direct_row
from fbcc_ros.core.control.axis_insertion import AxisInsertion
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.errors import ConfigError, InputError, require_number
from fbcc_ros.core.filters import second_order_row

#: Table I of the paper: (M_dp, K_dp, M_do, K_do, M_dl, K_dl) per label; D_d = sqrt(M_d K_d).
TABLE_I: dict[int, tuple[float, float, float, float, float, float]] = {
    1: (1e5, 1e7, 1e1, 1e3, 1e10, 1e12),
    2: (1e4, 1e6, 1e0, 1e2, 1e10, 1e12),
    3: (1e4, 1e6, 1e1, 1e3, 1e10, 1e12),
    4: (1e4, 1e6, 1e2, 1e4, 1e10, 1e12),
    5: (1e3, 1e5, 1e-1, 1e1, 1e10, 1e12),
}

#: The fastest mode of every filter must satisfy |s| dt <= this (at least ~6 samples per
#: time constant or natural period / 2 pi), so that the sampled loop follows the continuous law.
MAX_POLE_DT = 1.0


@dataclasses.dataclass(frozen=True)
class ComplianceParams:
    """Gains of eq. (30) and the limits of Algorithm 1. Defaults: Table I, label 3.

    The suffixes follow the paper: ``p`` the offsets (dx, dy), ``o`` the tilts (theta_x,
    theta_y), ``l`` the depth. Units are those that make ``M x'' + D x' + K x = A F`` hold with
    A F in N: for FBCC x_d is a rate, so K_dp is in N·s/m, K_do in N·s/rad; for admittance x_d is
    a displacement and K_dp is in N/m, K_do in N/rad.

    Attributes:
        M_dp, D_dp, K_dp: offsets. M_do, D_do, K_do: tilts. M_dl, D_dl, K_dl: depth.
        x_d_limit_p: Dead band on |x_d| of the offsets [m/s] (FBCC only); 0 disables it.
        x_d_limit_o: Dead band on |x_d| of the tilts [rad/s] (FBCC only); 0 disables it.
        F_ext_limit: Force limit [N] on |(Fx, Fy, Fz)|: above it the insertion stops and the
            command is held (Algorithm 1's loop condition). The paper gives no value; 300 N is
            about twice the largest peak of FBCC over 2000 random trials of the paper's pairs
            (docs/reproduction.md) and within what an iiwa 14 can push.
    """

    M_dp: float = 1e4
    K_dp: float = 1e6
    D_dp: float = 1e5
    M_do: float = 1e1
    K_do: float = 1e3
    D_do: float = 1e2
    M_dl: float = 1e10
    K_dl: float = 1e12
    D_dl: float = 1e11
    x_d_limit_p: float = 0.0
    x_d_limit_o: float = 0.0
    F_ext_limit: float = 300.0

    NAMES: ClassVar[tuple[str, ...]] = (
        "M_dp", "K_dp", "D_dp", "M_do", "K_do", "D_do", "M_dl", "K_dl", "D_dl",
        "x_d_limit_p", "x_d_limit_o", "F_ext_limit",
    )  # fmt: skip

    def __post_init__(self) -> None:
        for name in self.NAMES:
            require_number(name, getattr(self, name))
        for name in ("M_dp", "K_dp", "M_do", "K_do", "M_dl", "K_dl", "F_ext_limit"):
            if getattr(self, name) <= 0:
                raise ConfigError(name, getattr(self, name), "> 0")
        for name in ("D_dp", "D_do", "D_dl", "x_d_limit_p", "x_d_limit_o"):
            if getattr(self, name) < 0:
                raise ConfigError(name, getattr(self, name), ">= 0")

    @classmethod
    def table_i(cls, label: int, **changes: float) -> ComplianceParams:
        """Table I, label 1-5, with D_d = sqrt(M_d K_d) as the table says; ``changes`` override."""
        if label not in TABLE_I:
            raise ConfigError("label", label, f"a Table I label, one of {sorted(TABLE_I)}")
        m_p, k_p, m_o, k_o, m_l, k_l = TABLE_I[label]
        gains = {
            "M_dp": m_p, "K_dp": k_p, "D_dp": math.sqrt(m_p * k_p),
            "M_do": m_o, "K_do": k_o, "D_do": math.sqrt(m_o * k_o),
            "M_dl": m_l, "K_dl": k_l, "D_dl": math.sqrt(m_l * k_l),
        }  # fmt: skip
        return cls(**{**gains, **changes})

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], field: str = "params") -> ComplianceParams:
        """From a YAML mapping: ``label`` (default 3) picks the Table I row, other keys override.

        A D that is not given follows its M and K (sqrt(M K)) when either was overridden.
        """
        unknown = sorted(set(values) - {*cls.NAMES, "label"})
        if unknown:
            raise ConfigError(f"{field}.{unknown[0]}", values[unknown[0]],
                              f"one of label, {', '.join(cls.NAMES)}")  # fmt: skip
        label = values.get("label", 3)
        if isinstance(label, bool) or label not in TABLE_I:
            raise ConfigError(
                f"{field}.label", label, f"a Table I label, one of {sorted(TABLE_I)}"
            )
        base = cls.table_i(label)
        changes = {k: v for k, v in values.items() if k != "label"}
        for suffix in ("p", "o", "l"):
            d, m, k = f"D_d{suffix}", f"M_d{suffix}", f"K_d{suffix}"
            if d not in changes and (m in changes or k in changes):
                m_v, k_v = changes.get(m, getattr(base, m)), changes.get(k, getattr(base, k))
                numbers = all(isinstance(v, (int, float)) for v in (m_v, k_v))
                if numbers and m_v * k_v > 0:  # otherwise __post_init__ names the bad value
                    changes[d] = math.sqrt(m_v * k_v)
        try:
            return cls.table_i(label, **changes)
        except ConfigError as exc:
            raise ConfigError(f"{field}.{exc.field}", exc.value, exc.allowed) from None

    def diagonal(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """M_d, D_d, K_d of eq. (30) as vectors in feature order (dx, dy, l, theta_x, theta_y)."""
        m = np.array([self.M_dp, self.M_dp, self.M_dl, self.M_do, self.M_do])
        d = np.array([self.D_dp, self.D_dp, self.D_dl, self.D_do, self.D_do])
        k = np.array([self.K_dp, self.K_dp, self.K_dl, self.K_do, self.K_do])
        return m, d, k


class ComplianceFilter:
    """``M_d x_d'' + D_d x_d' + K_d x_d = u`` (eq. 27 and 30), one filter per feature.

    Discretised exactly for a zero-order hold on u (the matrix exponential of each 2×2 system),
    so any positive M, K and D >= 0 stay stable at any period. What we do check is that the
    period resolves the filter: the fastest mode s of ``M s² + D s + K`` must satisfy
    ``|s| dt <= MAX_POLE_DT``; otherwise the sampled loop no longer behaves like the law.
    """

    def __init__(self, params: ComplianceParams) -> None:
        self.params = params
        self._m, self._d, self._k = params.diagonal()
        self._coeffs: dict[float, FloatArray] = {}
        self._x = np.zeros((1, 5))
        self._v = np.zeros((1, 5))

    def reset(self, n: int) -> None:
        """Zero state (Algorithm 1: x_d(0) = x_d(-1) = 0) for n trials."""
        self._x = np.zeros((n, 5))
        self._v = np.zeros((n, 5))

    @property
    def output(self) -> FloatArray:
        """x_d, shape (N, 5)."""
        return self._x

    def step(self, u: FloatArray, dt: float) -> FloatArray:
        """Advance by dt with the input u (N, 5) held; returns x_d (N, 5)."""
        c = self.coefficients(dt)
        x, v = self._x.copy(), self._v.copy()
        u = np.ascontiguousarray(u, dtype=float)
        for i in range(len(x)):
            second_order_row(c, x[i], v[i], u[i])
        self._x, self._v = x, v
        return x

    def coefficients(self, dt: float) -> FloatArray:
        """:meth:`discretise`'s, from the cache after the first call."""
        c = self._coeffs.get(dt)
        return self.discretise(dt) if c is None else c

    def state(self) -> tuple[FloatArray, FloatArray]:
        """x_d and its rate, (N, 5) each: the arrays the law's compiled step advances."""
        return self._x, self._v

    def max_period(self) -> float:
        """The longest period dt [s] that still resolves every filter (see the class doc)."""
        poles = [np.roots([m, d, k]) for m, d, k in zip(self._m, self._d, self._k, strict=True)]
        return MAX_POLE_DT / max(float(np.max(np.abs(p))) for p in poles)

    def discretise(self, dt: float) -> FloatArray:
        """The coefficients at period dt, (6, 5): rows Phi00, Phi01, Phi10, Phi11, Gamma0,
        Gamma1 per feature (cached); refuses a period too long for the gains."""
        if not (math.isfinite(dt) and dt > 0):
            raise InputError("dt", dt, "a control period > 0 in s")
        longest = self.max_period()
        if dt > longest * (1 + 1e-12):
            raise ConfigError(
                "dt", dt, f"<= {longest:.3g} s (a rate >= {1 / longest:.3g} Hz): the fastest "
                f"compliance mode |s| of M s^2 + D s + K needs |s| dt <= {MAX_POLE_DT}",
            )  # fmt: skip
        phi = np.empty((4, 5))
        gam = np.empty((2, 5))
        for i, (m, d, k) in enumerate(zip(self._m, self._d, self._k, strict=True)):
            # augmented [[A, B], [0, 0]] with A = [[0, 1], [-K/M, -D/M]], B = [0, 1/M]
            aug = np.array([[0.0, 1.0, 0.0], [-k / m, -d / m, 1.0 / m], [0.0, 0.0, 0.0]])
            e = scipy.linalg.expm(aug * dt)
            phi[:, i] = e[0, 0], e[0, 1], e[1, 0], e[1, 1]
            gam[:, i] = e[0, 2], e[1, 2]
        coeffs = np.vstack((phi, gam))
        self._coeffs[dt] = coeffs
        return coeffs


@dataclasses.dataclass(frozen=True)
class Insertion:
    """The reference of the depth: a ramp at ``speed`` to the final depth (Algorithm 1's L).

    Attributes:
        depth: Final insertion depth [m], > 0.
        speed: Ramp speed [m/s], > 0.
    """

    depth: float = 10e-3
    speed: float = 5e-3

    def __post_init__(self) -> None:
        for name in ("depth", "speed"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"insertion.{name}", value, "a finite number > 0 (m, m/s)")


#: Phase codes of each trial, as returned by :attr:`ComplianceLaw.phase`.
PHASES = ("inserting", "inserted", "force_limit")


class ComplianceLaw:
    """What FBCC and admittance share: the filter, the depth ramp, the force limit.

    Use ``reset(features)`` with the measured features at the start (the reference starts
    there, l ramps from the measured depth), then ``step(response, depth, dt)`` once per control
    period; it returns the command features x_c.
    """

    #: The law's code in the compiled step (:func:`_law_rows`).
    CODE: ClassVar[int]

    def __init__(
        self,
        nominal: PegHole,
        params: ComplianceParams | None = None,
        insertion: Insertion | None = None,
    ) -> None:
        self.nominal = nominal
        self._lever = nominal.lever_terms()
        self.params = params or ComplianceParams()
        self.insertion = insertion or Insertion()
        self.filter = ComplianceFilter(self.params)
        limits = (self.params.x_d_limit_p, self.params.x_d_limit_p, 0.0,
                  self.params.x_d_limit_o, self.params.x_d_limit_o)  # fmt: skip
        self._dead_band = np.array(limits)
        self._single = True
        self.axis = AxisInsertion(nominal.peg_radius)
        self.reset(np.zeros(5))
        _load_step()

    def reset(self, features: ArrayLike) -> None:
        """Start an insertion from the measured features, shape (5,) or (N, 5)."""
        rows, self._single = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        rows = self.axis.reset(rows)  # the law runs along the peg's axis
        n = len(rows)
        self.filter.reset(n)
        self._x_rfr = rows.copy()  # reference feature vector; l is replaced by the ramp
        self._l0 = rows[:, 2].copy()
        self._elapsed = np.zeros(n)  # ramp time per trial; frozen once stopped
        self._sum = np.zeros((n, 5))  # ∑ x_d dt (FBCC)
        self._stopped = np.zeros(n, dtype=bool)
        self._command = rows.copy()

    @property
    def phase(self) -> list[str]:
        """Per trial: ``inserting``, ``inserted`` (the ramp reached the depth) or
        ``force_limit`` (stopped, command held)."""
        return [self.phase_of(i) for i in range(len(self._command))]

    def phase_of(self, trial: int) -> str:
        """One trial's :attr:`phase` (the controller's, each period: no arrays built)."""
        if self._stopped[trial]:
            return PHASES[2]
        ramp = self.insertion
        done = self._l0[trial] + ramp.speed * self._elapsed[trial] >= ramp.depth
        return PHASES[1] if done else PHASES[0]

    @property
    def stopped(self) -> FloatArray:
        """Per trial, whether the force limit stopped it (bool array)."""
        return self._stopped

    @property
    def trips(self) -> FloatArray:
        """Oscillation-guard trips per trial: Table I's laws have no guard."""
        return np.zeros(len(self._command))

    def prepare(self, dt: float) -> None:
        """Refuse a period too long for the gains, and discretise the filter for it now (the
        matrix exponentials cost ~1.5 ms: not in the loop)."""
        self.filter.discretise(dt)

    def max_period(self) -> float:
        """The longest period [s] the law resolves (:meth:`ComplianceFilter.max_period`)."""
        return self.filter.max_period()

    def step(self, response: ArrayLike, features: ArrayLike, dt: float) -> FloatArray:
        """One control period: compensated response F_ext (5,) or (N, 5) in {H}, measured
        features (5,) or (N, 5) (this law uses their depth l [m]), period dt [s]. Returns the
        command features x_c."""
        w, _ = as_rows(response, "response", "(Fx, Fy, Fz, Mx, My) in N, N·m")
        x, _ = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        n = len(self._command)
        if len(w) != n or len(x) != n:
            raise InputError("response", f"{len(w)} rows", f"{n} rows, as reset")
        # the axis depth (contiguous, as _load_step loaded it)
        depth_arr = np.ascontiguousarray(self.axis.measured(x, dt)[:, 2])
        c = self.filter.coefficients(dt)
        x_d, v_d = self.filter.state()
        base, per_depth = self._lever
        _law_rows(self.CODE, np.ascontiguousarray(w), depth_arr, dt, c, base, per_depth,
                  self.nominal.hole_depth, self.nominal.hole_radius, self._dead_band,
                  self.params.F_ext_limit**2, self.insertion.speed, self.insertion.depth,
                  x_d, v_d, self._x_rfr, self._l0, self._elapsed, self._sum, self._stopped,
                  self._command)  # fmt: skip
        command = self.axis.command(self._command)
        return command[0] if self._single else command


#: Codes of the laws in the compiled step.
_FBCC, _ADMITTANCE, _NONE = 0, 1, 2


@numba.njit(cache=True)  # type: ignore[misc]
def _law_rows(
    law: int,
    w: FloatArray,
    depth: FloatArray,
    dt: float,
    c: FloatArray,
    base: float,
    per_depth: float,
    hole_depth: float,
    hole_radius: float,
    dead_band: FloatArray,
    force_limit2: float,
    speed: float,
    final_depth: float,
    x_d: FloatArray,
    v_d: FloatArray,
    x_rfr: FloatArray,
    l0: FloatArray,
    elapsed: FloatArray,
    total: FloatArray,
    stopped: FloatArray,
    command: FloatArray,
) -> None:
    """One control period of every trial (row), the state arrays advanced in place."""
    u = np.zeros(5)
    for i in range(w.shape[0]):
        # Algorithm 1 runs while |F_ext| <= F_ext_limit; past it the insertion stops for good.
        if w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1] + w[i, 2] * w[i, 2] > force_limit2:
            stopped[i] = True
        running = not stopped[i]
        if law == _FBCC:  # A(l) F_ext, eq. (28) with gamma(l) of eq. (29)
            direct_row(w[i], depth[i], base, per_depth, hole_depth, hole_radius, u)
        elif law == _ADMITTANCE:  # the raw wrench, A = I: My drives theta_y
            u[:] = w[i]
        second_order_row(c, x_d[i], v_d[i], u)  # eq. (27): M x_d'' + D x_d' + K x_d = u
        if running:
            elapsed[i] += dt
        # l_rfr: a ramp at the insertion speed to the final depth L
        x_rfr[i, 2] = min(l0[i] + speed * elapsed[i], final_depth)
        if not running:
            continue  # the command is held
        for j in range(5):
            if law == _FBCC:
                # dead band (Algorithm 1): adjust only the features whose |x_d| exceeds it;
                # eq. (27): x_c = x_rfr - ∫ x_d dt
                if abs(x_d[i, j]) > dead_band[j]:
                    total[i, j] += x_d[i, j] * dt
                command[i, j] = x_rfr[i, j] - total[i, j]
            elif law == _ADMITTANCE:
                # x_c = x_rfr - x_d: a displacement, it lasts only while the force does
                command[i, j] = x_rfr[i, j] - x_d[i, j]
            else:  # position control only: the reference
                command[i, j] = x_rfr[i, j]


def _load_step() -> None:
    """Loads the compiled step for the controller's argument types now (from numba's cache, or
    compiled on a machine's first run): on the first call it cost the 1 kHz loop ~8 ms. No
    rows, so nothing is stepped."""
    rows, row, none = np.zeros((0, 5)), np.zeros(0), np.zeros(0, dtype=bool)
    _law_rows(_FBCC, rows, row, 1e-3, np.zeros((6, 5)), 0.0, 0.0, 1.0, 1.0, np.zeros(5), 1.0,
              1.0, 1.0, rows, rows, rows, row, row, rows, none, rows)  # fmt: skip


class FbccController(ComplianceLaw):
    """Feature-based compliance control (eq. 26-30, Algorithm 1): the filter driven by
    ``A(l) F_ext``, its output integrated, ``x_c = x_rfr - ∫ x_d dt`` with the dead band."""

    CODE = _FBCC


class AdmittanceController(ComplianceLaw):
    """The baseline: the same filter on the raw wrench, no direction matrix, no integrator,
    ``x_c = x_rfr - x_d``."""

    CODE = _ADMITTANCE


class NoFeedback(ComplianceLaw):
    """Position control only: the reference ramp, the force ignored (the paper's "no force
    feedback" runs, Fig. 13). The force limit still stops it."""

    CODE = _NONE


#: A control law: Table I's (ComplianceLaw) or the stiffness-robust FBCC.
Law = ComplianceLaw | RobustFbcc
#: Gains of either kind: Table I's or the robust configuration.
Params = ComplianceParams | RobustParams

#: The control laws by the name used in scenarios and parameters.
LAWS: dict[str, type[ComplianceLaw]] = {
    "fbcc": FbccController,
    "admittance": AdmittanceController,
    "none": NoFeedback,
}


def make_law(
    name: str,
    nominal: PegHole,
    params: Params | None = None,
    insertion: Insertion | None = None,
) -> Law:
    """The law called ``name``: ``fbcc``, ``admittance`` or ``none``.

    With the robust configuration (the default, ``params`` None or :class:`RobustParams`),
    ``fbcc`` is the stiffness-robust law of :mod:`fbcc_ros.core.control.robust`; the baselines have
    no robust form and run with their shipped gains, Table I label 3 (keeping its force limit).
    """
    if name not in LAWS:
        raise ConfigError("controller.type", name, f"one of {sorted(LAWS)}")
    if params is None or isinstance(params, RobustParams):
        robust = params or RobustParams()
        if name == "fbcc":
            return RobustFbcc(nominal, robust, insertion)
        params = ComplianceParams(F_ext_limit=robust.F_ext_limit)
    return LAWS[name](nominal, params, insertion)


def params_from_mapping(values: Mapping[str, Any], field: str = "params") -> Params:
    """``controller.params`` of a scenario: Table I's gains when ``label`` or a Table I gain
    is given (:meth:`ComplianceParams.from_mapping`), else the robust configuration
    (:meth:`RobustParams.from_mapping`)."""
    table_i = set(ComplianceParams.NAMES) - {"F_ext_limit"}
    if "label" in values or table_i & set(values):
        return ComplianceParams.from_mapping(values, field)
    return RobustParams.from_mapping(values, field)
