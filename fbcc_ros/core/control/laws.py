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
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole, as_rows
from fbcc_ros.core.contact.segmentation import direct_row
from fbcc_ros.core.control.axis_insertion import AxisInsertion
from fbcc_ros.core.control.compliance import ComplianceFilter, ComplianceParams
from fbcc_ros.core.control.phase import LAW_PHASES, Phase
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.filters import second_order_row


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
        self.params = params or ComplianceParams()
        self.insertion = insertion or Insertion()
        self.filter = ComplianceFilter(self.params)
        self._single = True
        self.axis = AxisInsertion(nominal.peg_radius)
        self.reset(np.zeros(5))
        dead_band = (self.params.x_d_limit_p, self.params.x_d_limit_p, 0.0,
                     self.params.x_d_limit_o, self.params.x_d_limit_o)  # fmt: skip
        base, per_depth = nominal.lever_terms()
        self._prm = np.array([0.0, base, per_depth, nominal.hole_depth, nominal.hole_radius,
                              self.params.F_ext_limit**2, self.insertion.speed,
                              self.insertion.depth, *dead_band])  # fmt: skip

    @staticmethod
    def preload() -> None:
        """Load the compiled step for the controller's argument types now (from numba's cache,
        or compiled on a machine's first run): on the first call it cost the 1 kHz loop ~8 ms.
        No rows, so nothing is stepped."""
        rows, none = np.zeros((0, 5)), np.zeros(0)
        _law_rows(_FBCC, np.zeros(N_PRM), rows, none, np.zeros((6, 5)), rows, rows,
                  np.zeros((0, N_STATE)), rows)  # fmt: skip

    def reset(self, features: ArrayLike) -> None:
        """Start an insertion from the measured features, shape (5,) or (N, 5)."""
        rows, self._single = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        rows = self.axis.reset(rows)  # the law runs along the peg's axis
        n = len(rows)
        self.filter.reset(n)
        self._state = np.zeros((n, N_STATE))  # per trial, columns S_*
        self._state[:, S_RFR : S_RFR + 5] = rows  # the reference; l is replaced by the ramp
        self._state[:, S_L0] = rows[:, 2]
        self._command = rows.copy()

    @property
    def phase(self) -> list[Phase]:
        """Per trial: ``inserting``, ``inserted`` (the ramp reached the depth) or
        ``force_limit`` (stopped, command held)."""
        return [self.phase_of(i) for i in range(len(self._command))]

    def phase_of(self, trial: int) -> Phase:
        """One trial's :attr:`phase` (the controller's, each period: no arrays built)."""
        row = self._state[trial]
        if row[S_STOPPED]:
            return LAW_PHASES[2]
        ramp = self.insertion
        done = row[S_L0] + ramp.speed * row[S_ELAPSED] >= ramp.depth
        return LAW_PHASES[1] if done else LAW_PHASES[0]

    @property
    def stopped(self) -> FloatArray:
        """Per trial, whether the force limit stopped it (bool array)."""
        return self._state[:, S_STOPPED] != 0.0

    @property
    def trips(self) -> FloatArray:
        """Oscillation-guard trips per trial: Table I's laws have no guard."""
        return np.zeros(len(self._command))

    @property
    def lever_frictions(self) -> FloatArray:
        """The friction eq. 24's lever measured, per trial: Table I's laws measure none
        (NaN)."""
        return np.full(len(self._command), np.nan)

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
        # the axis depth (contiguous, as preload loaded it)
        depth = np.ascontiguousarray(self.axis.measured(x, dt)[:, 2])
        self._prm[P_DT] = dt
        x_d, v_d = self.filter.state()
        _law_rows(self.CODE, self._prm, np.ascontiguousarray(w), depth,
                  self.filter.coefficients(dt), x_d, v_d, self._state, self._command)  # fmt: skip
        command = self.axis.command(self._command)
        return command[0] if self._single else command


#: Codes of the laws in the compiled step.
_FBCC, _ADMITTANCE, _NONE = 0, 1, 2
#: The step's parameters: period [s], the lever terms of eq. (29) (base, per depth), hole depth
#: and radius [m], F_ext_limit² [N²], ramp speed [m/s] and final depth [m], then the dead band.
P_DT, P_BASE, P_PER_DEPTH, P_HOLE_DEPTH, P_HOLE_RADIUS, P_FORCE2, P_SPEED, P_FINAL = range(8)
P_BAND = 8  # the five of the dead band from here
N_PRM = 13
#: The per-trial state's columns: the reference x_rfr, the depth at reset, the ramp time
#: (frozen once stopped), ∑ x_d dt (FBCC), and 1.0 once the force limit stopped the trial.
S_RFR, S_L0, S_ELAPSED, S_SUM, S_STOPPED = 0, 5, 6, 7, 12  # x_rfr and the sum: five columns
N_STATE = 13


@numba.njit(cache=True)  # type: ignore[misc]
def _law_rows(
    law: int,
    prm: FloatArray,
    w: FloatArray,
    depth: FloatArray,
    c: FloatArray,
    x_d: FloatArray,
    v_d: FloatArray,
    state: FloatArray,
    command: FloatArray,
) -> None:
    """One control period of every trial (row): the filter's x_d, v_d and the state (columns
    S_*) advanced in place, the command written. ``prm`` holds the P_* parameters."""
    dt = prm[P_DT]
    u = np.zeros(5)
    for i in range(w.shape[0]):
        s = state[i]
        # Algorithm 1 runs while |F_ext| <= F_ext_limit; past it the insertion stops for good.
        if w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1] + w[i, 2] * w[i, 2] > prm[P_FORCE2]:
            s[S_STOPPED] = 1.0
        running = s[S_STOPPED] == 0.0
        if law == _FBCC:  # A(l) F_ext, eq. (28) with gamma(l) of eq. (29)
            direct_row(w[i], depth[i], prm[P_BASE], prm[P_PER_DEPTH], prm[P_HOLE_DEPTH],
                       prm[P_HOLE_RADIUS], u)  # fmt: skip
        elif law == _ADMITTANCE:  # the raw wrench, A = I: My drives theta_y
            u[:] = w[i]
        second_order_row(c, x_d[i], v_d[i], u)  # eq. (27): M x_d'' + D x_d' + K x_d = u
        if running:
            s[S_ELAPSED] += dt
        # l_rfr: a ramp at the insertion speed to the final depth L
        s[S_RFR + 2] = min(s[S_L0] + prm[P_SPEED] * s[S_ELAPSED], prm[P_FINAL])
        if not running:
            continue  # the command is held
        for j in range(5):
            x_rfr = s[S_RFR + j]
            if law == _FBCC:
                # dead band (Algorithm 1): adjust only the features whose |x_d| exceeds it;
                # eq. (27): x_c = x_rfr - ∫ x_d dt
                if abs(x_d[i, j]) > prm[P_BAND + j]:
                    s[S_SUM + j] += x_d[i, j] * dt
                command[i, j] = x_rfr - s[S_SUM + j]
            elif law == _ADMITTANCE:
                # x_c = x_rfr - x_d: a displacement, it lasts only while the force does
                command[i, j] = x_rfr - x_d[i, j]
            else:  # position control only: the reference
                command[i, j] = x_rfr


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

    The laws model the contact by eq. 5-13's wall alone: a pair's rim
    (:attr:`~fbcc_ros.core.contact.model.PegHole.rim`) is the plant's, not theirs.

    With the robust configuration (the default, ``params`` None or :class:`RobustParams`),
    ``fbcc`` is the stiffness-robust law of :mod:`fbcc_ros.core.control.robust`; the baselines have
    no robust form and run with their shipped gains, Table I label 3 (keeping its force limit).
    """
    if name not in LAWS:
        raise ConfigError("controller.type", name, f"one of {sorted(LAWS)}")
    # every law's own contact model is eq. 5-13's wall; the rim is the plant's
    nominal = nominal.replace(rim=False, chamfer=0.0)
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
