"""FBCC (eq. 26-30, Algorithm 1) and the admittance baseline it is compared with.

Both laws share the second-order compliance filter of eq. (27), one per feature, with the
diagonal gains of eq. (30), and the insertion reference for the depth l. They differ in exactly
the two points the paper claims matter:

* **FBCC** drives the filter with ``A(l) F_ext`` (the direction matrix of eq. 28, from the
  boundary mapping) and integrates its output: ``x_c = x_rfr - ∫ x_d dt`` (eq. 27).
* **Admittance** drives it with the raw wrench, moments divided by the nominal radius R so that
  both laws use Table I's gains in the same units (N), and adds its output as a displacement:
  ``x_c = x_rfr - x_d``. Its matrix is eq. (28) at gamma = 0: diag(1, 1, 1, 1/R, 1/R).

Reading of the integrator (DESIGN §5 and ``docs/reproduction.md``). Algorithm 1 writes
``x_rfr(i) = x_rfr(i-1) - x_d(i)``, a sum per control step, and the paper gives no control
period. A per-step sum makes the gains depend on the rate (the same Table I values would be
1000 times more aggressive at 1 kHz than at 1 Hz); we read x_d as an adjustment *rate*
[m/s, rad/s] and integrate it, ``x_rfr(i) = x_rfr(i-1) - x_d(i) dt``, so the behaviour is the
same at any rate fast enough for the filter. The dead band ``x_d_limit`` then is a rate too.

All arrays are batched: one row per trial, shape (N, 5), in the feature order
(dx, dy, l, theta_x, theta_y); a single vector of shape (5,) works as well.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from fbcc_ros.core.contact import FloatArray, PegHole, as_rows
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.segmentation import apply_direction

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
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(name, value, "a number")
            if not math.isfinite(value):
                raise ConfigError(name, value, "a finite number")
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
        self._coeffs: dict[float, tuple[FloatArray, ...]] = {}
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
        c = self._coeffs.get(dt) or self._discretise(dt)
        x, v = self._x, self._v
        # [x, v](k+1) = Phi [x, v](k) + Gamma u(k)
        self._x = c[0] * x + c[1] * v + c[4] * u
        self._v = c[2] * x + c[3] * v + c[5] * u
        return self._x

    def max_period(self) -> float:
        """The longest period dt [s] that still resolves every filter (see the class doc)."""
        poles = [np.roots([m, d, k]) for m, d, k in zip(self._m, self._d, self._k, strict=True)]
        return MAX_POLE_DT / max(float(np.max(np.abs(p))) for p in poles)

    def _discretise(self, dt: float) -> tuple[FloatArray, ...]:
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
        coeffs = (*phi, *gam)
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

    def __init__(
        self,
        nominal: PegHole,
        params: ComplianceParams | None = None,
        insertion: Insertion | None = None,
    ) -> None:
        self.nominal = nominal
        self.params = params or ComplianceParams()
        self.insertion = insertion or Insertion()
        self.filter = ComplianceFilter(self.params)
        limits = (self.params.x_d_limit_p, self.params.x_d_limit_p, 0.0,
                  self.params.x_d_limit_o, self.params.x_d_limit_o)  # fmt: skip
        self._dead_band = np.array(limits)
        self._single = True
        self.reset(np.zeros(5))

    def reset(self, features: ArrayLike) -> None:
        """Start an insertion from the measured features, shape (5,) or (N, 5)."""
        rows, self._single = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
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
        done = self._l0 + self.insertion.speed * self._elapsed >= self.insertion.depth
        codes = np.where(self._stopped, 2, np.where(done, 1, 0))
        return [PHASES[c] for c in codes]

    @property
    def stopped(self) -> FloatArray:
        """Per trial, whether the force limit stopped it (bool array)."""
        return self._stopped

    def direction(self, response: FloatArray, depth: FloatArray) -> FloatArray:
        """The filter input ``A F`` for responses (N, 5) at depths (N,)."""
        raise NotImplementedError

    def step(self, response: ArrayLike, depth: ArrayLike, dt: float) -> FloatArray:
        """One control period: compensated response F_ext (5,) or (N, 5) in {H}, measured depth
        l [m] (scalar or (N,)), period dt [s]. Returns the command features x_c."""
        w, _ = as_rows(response, "response", "(Fx, Fy, Fz, Mx, My) in N, N·m")
        if len(w) != len(self._command):
            raise InputError("response", f"{len(w)} rows", f"{len(self._command)} rows, as reset")
        depth_arr = np.asarray(depth, dtype=float)
        if depth_arr.shape != (len(w),):
            depth_arr = np.full(len(w), depth_arr)
        # Algorithm 1 runs while |F_ext| <= F_ext_limit; past it the insertion stops for good.
        force2 = w[:, 0] * w[:, 0] + w[:, 1] * w[:, 1] + w[:, 2] * w[:, 2]
        self._stopped |= force2 > self.params.F_ext_limit**2
        running = ~self._stopped
        x_d = self.filter.step(self.direction(w, depth_arr), dt)  # eq. (27)
        self._elapsed += np.where(running, dt, 0.0)
        # l_rfr: a ramp at the insertion speed to the final depth L
        self._x_rfr[:, 2] = np.minimum(
            self._l0 + self.insertion.speed * self._elapsed, self.insertion.depth
        )
        command = self._command_from(x_d, dt)
        self._command = np.where(running[:, None], command, self._command)
        return (self._command[0] if self._single else self._command).copy()

    def _command_from(self, x_d: FloatArray, dt: float) -> FloatArray:
        raise NotImplementedError


class FbccController(ComplianceLaw):
    """Feature-based compliance control (eq. 26-30, Algorithm 1)."""

    def direction(self, response: FloatArray, depth: FloatArray) -> FloatArray:
        # A(l) F_ext, eq. (28) with gamma(l) of eq. (29)
        return apply_direction(response, depth, self.nominal)

    def _command_from(self, x_d: FloatArray, dt: float) -> FloatArray:
        # dead band (Algorithm 1): adjust only the features whose |x_d| exceeds x_d_limit
        active = (np.abs(x_d) > self._dead_band) & ~self._stopped[:, None]
        self._sum += np.where(active, x_d, 0.0) * dt
        # eq. (27): x_c = x_rfr - ∫ x_d dt
        return self._x_rfr - self._sum


class AdmittanceController(ComplianceLaw):
    """The baseline: the same filter on the raw wrench, no direction matrix, no integrator."""

    def direction(self, response: FloatArray, depth: FloatArray) -> FloatArray:
        # the raw wrench, A = I: each feature is driven by its own response (My drives theta_y)
        return response

    def _command_from(self, x_d: FloatArray, dt: float) -> FloatArray:
        # x_c = x_rfr - x_d: the adjustment is a displacement, it lasts only while the force does
        return self._x_rfr - x_d


class NoFeedback(ComplianceLaw):
    """Position control only: the reference ramp, the force ignored (the paper's "no force
    feedback" runs, Fig. 13). The force limit still stops it."""

    def direction(self, response: FloatArray, depth: FloatArray) -> FloatArray:
        return np.zeros_like(response)

    def _command_from(self, x_d: FloatArray, dt: float) -> FloatArray:
        return self._x_rfr.copy()


#: The control laws by the name used in scenarios and parameters.
LAWS: dict[str, type[ComplianceLaw]] = {
    "fbcc": FbccController,
    "admittance": AdmittanceController,
    "none": NoFeedback,
}


def make_law(
    name: str,
    nominal: PegHole,
    params: ComplianceParams | None = None,
    insertion: Insertion | None = None,
) -> ComplianceLaw:
    """The law called ``name``: ``fbcc``, ``admittance`` or ``none``."""
    if name not in LAWS:
        raise ConfigError("controller.type", name, f"one of {sorted(LAWS)}")
    return LAWS[name](nominal, params, insertion)
