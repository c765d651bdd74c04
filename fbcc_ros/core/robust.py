"""Stiffness-robust FBCC: one configuration from soft plastic to steel (DESIGN §6).

Table I's gains fix the loop's crossover to ``k_c / K`` for a contact stiffness k_c, so one
label is stable only below one stiffness (``docs/reproduction.md``). This law keeps FBCC's
structure — the direction rows ``u = A(l) F`` of eq. 28, a second-order filter (eq. 27), an
integrator (Algorithm 1) — and schedules the integrators' gains by the identified stiffness of
each plane (:mod:`fbcc_ros.core.identification`), so that every lateral loop crosses over at the
same ``bandwidth`` whatever the part. Per plane (offset d, tilt θ):

.. math::
    \\bar u = H_f(s)\\,u,\\qquad
    \\begin{bmatrix}\\dot x_{c,d} \\\\ \\dot x_{c,\\theta}\\end{bmatrix}
    = -\\omega_c\\,\\hat J^{-1}\\,\\mathrm{dz}(\\bar u),\\qquad
    H_f(s) = \\frac{\\omega_f^2}{s^2 + 2\\zeta\\omega_f s + \\omega_f^2},

with Ĵ the plane's identified 2×2 stiffness (diagonal bounded and released as the
identification's doc says; the coupling inverted up to ``coupling_limit``): where A(l) leaves
the rows coupled (a two-point contact, where an offset step moves the tilt row as much as a tilt
step does) Ĵ⁻¹ finishes the decoupling; with no coupling it is ``ω_c / k̂_j`` per row; and
``dz`` a dead zone of ``dead_band`` noise deviations (so the integrators do not random-walk on
sensor noise, which the paper's ``x_d_limit`` is for). With ``Ĵ = J`` each decoupled loop is
``L(s) = ω_c H_f(s) G_robot(s) / s``, with the margins :func:`loop_margins` computes; an error
``k_j / k̂_j = ρ`` scales the loop gain by ρ, so the gain margin is the largest stiffness
underestimate the loop survives. The identification errs stiff (floor, slow release) and the
oscillation guard (:mod:`fbcc_ros.core.guard`) backs a row's gain off by ``guard_backoff`` (the
stiffness in use, at once, whatever the fit says) when its filtered response oscillates without
decaying (a growing oscillation, or a limit cycle such as a delay the margins did not budget for
makes), and holds the depth for ``guard_hold``. The tilt
integrators wait until the peg is ``tilt_depth`` in: at the entry a tilt row's lever arms are too
short to tell a tilt from an offset. The law runs in the coordinates of
:mod:`fbcc_ros.core.axis_insertion` (depth along the peg's axis, in the hole's estimated frame).

**Coupled tilt row.** In a tight stiff fit a tilt step moves the plane's offset row far more
than its own: the tilt row's identified slope is noise about zero while ∂u_d/∂θ is 1e4 N/rad, so
at the floor's gain the tilt integrates at tens of degrees a second and wedges the peg. The tilt
row's stiffness in Ĵ is therefore at least ``|∂u_d/∂θ| U_θ / U_d`` (the fitted coupling, ``U`` as
under Depth): a tilt step then moves the offset row's effort ``u_d / U_d`` no faster than
``ω_c`` times the tilt row's own effort.

**Excitation.** A dither per row, at its own frequency, of ``dither_force`` / k̂ (offsets) and
``dither_effort`` / k̂ (tilts), capped at ``dither_max_offset`` / ``dither_max_tilt``, keeps the
identification excited; it is on only in contact and while inserting. Its amplitude follows that
on/off target through a first-order lag of one period of the slowest dither, so switching it
never steps the command: cut at an arbitrary phase, a tilt dither of ``dither_max_tilt`` (1 µm
at the rim) pushes a tight stiff fit into hundreds of newtons. Once the depth is reached the
peg is left still and the estimate is no longer released (the fit may still raise it): with
nothing exciting the fit its slopes drift with the noise, and a released estimate is a raised
gain, which rang stiff parts' lateral loops into 100-N oscillations at the depth.

**Depth.** The insertion advances at ``insertion.speed`` while the lateral loops are settled and
slows, holds or backs off while they are not: with the lateral effort
``e = max_j |ū_j| / U_j`` (``U`` = ``offset_force`` for dx, dy and ``tilt_effort`` for the tilts)
and its identified depth sensitivity ``∂e/∂l`` (the RLS's ``b_j``), the depth rate is

.. math::
    \\dot l_c = \\mathrm{clip}\\left(\\omega_l \\frac{1 - e}{\\partial e / \\partial l},
    -v, v\\right)\\ \\text{in contact},\\qquad \\dot l_c = v\\ \\text{otherwise},

a depth loop that holds ``e`` at 1 with the bandwidth ``depth_bandwidth``, whatever the
stiffness; the command never leads the measured depth by more than ``v * depth_lead``, so a hold
takes effect within a sample. An axial force above ``fz_back_off`` backs off.

State per trial lives in one float array (columns below), stepped by one compiled kernel for the
simulator's batch and the controller's single row alike.
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

from fbcc_ros.core import guard as guard_mod
from fbcc_ros.core import identification as ident
from fbcc_ros.core.axis_insertion import AxisInsertion
from fbcc_ros.core.contact import FloatArray, PegHole, as_rows
from fbcc_ros.core.errors import ConfigError, InputError, require_number
from fbcc_ros.core.filters import second_order_row
from fbcc_ros.core.segmentation import direct_row

#: Dither frequencies of the rows dx, dy, theta_x, theta_y as fractions of the control rate
#: (61, 53, 47 and 41 Hz at 1 kHz): distinct, not harmonics of each other, >= 16 samples a period.
DITHER_FRACTIONS = (0.061, 0.053, 0.047, 0.041)
#: Default sensor noise the law assumes (standard deviations of Fx, Fy, Fz, Mx, My) [N, N·m].
DEFAULT_SENSOR_NOISE = (0.05, 0.05, 0.05, 0.002, 0.002)


@dataclasses.dataclass(frozen=True)
class RobustParams:
    """The robust configuration (the default of ``controller.params``). SI units.

    Attributes:
        bandwidth: Largest ω_c, the crossover of every lateral loop [rad/s]; the law runs with
            less when ``loop_delay`` leaves less than ``phase_margin`` (:func:`design`).
        loop_delay: The cell's delay from a command to its effect in the measured features
            and wrench [s]: the robot's servo and drivers, the nodes' queues; the margins budget
            for it. A lateral loop of a cell with more oscillates, which the guard catches; the
            depth loop is not guarded, and the approach into a stiff contact is not slowed for
            it (docs/reproduction.md).
        phase_margin: The phase margin every loop keeps with ``loop_delay`` [rad].
        filter_frequency: ω_f of the response filter H_f [rad/s].
        filter_damping: ζ of H_f.
        dead_band: Dead zone of the filtered rows, in filtered-noise standard deviations.
        sensor_noise: Standard deviations the law assumes for (Fx, Fy, Fz, Mx, My) [N, N·m].
        identification_window: Memory of the RLS [s].
        stiffness_min: The softest contact to expect, eq. 8's k [Pa]: the floor of the
            identified stiffness (the highest gain the law will use).
        release: Time constant with which a used stiffness may fall [s].
        dither_force: Dither amplitude of the offset rows, as a force [N].
        dither_effort: Dither amplitude of the tilt rows, in units of A(l) F [N].
        dither_max_offset: Cap of the offset dither [m].
        dither_max_tilt: Cap of the tilt dither [rad].
        offset_force: U of the offset rows: the lateral force at which the insertion holds [N].
        tilt_effort: U of the tilt rows [N, units of A(l) F].
        depth_bandwidth: Largest ω_l of the depth loop [rad/s] (:func:`design`).
        depth_lead: Longest lead of the depth command over the measured depth, beyond
            ``loop_delay``, in seconds of insertion speed [s].
        fz_back_off: Axial force above which the insertion backs off [N]: above the largest
            push-in the law is asked to make (the studies admit 2/3 of ``F_ext_limit``, 200 N;
            backing off at 200 N itself left such parts hovering short of the depth).
        guard_growth, guard_cycles: :class:`fbcc_ros.core.guard.GuardParams`; the guard's
            minimum amplitude is ``guard_amplitude`` times the row's filtered noise.
        guard_amplitude: See above (dimensionless).
        guard_backoff: Factor by which a tripped row's gain falls (> 1).
        guard_hold: How long the depth holds after a trip [s].
        coupling_limit: How much of a plane's identified coupling the law inverts:
            |J01 J10| <= coupling_limit J00 J11 (0: the rows alone, as FBCC's A(l)).
        plane_gate: A plane whose two rows are both inside their dead band holds (nothing to
            sense); one that is not integrates both rows whole, so that a weak tilt row is not
            eaten by its dead band while its plane is in contact.
        lateral_lead, tilt_lead: The most an offset [m] or tilt [rad] command may lead the
            measured pose: a contact's stiffness is unknown until the motion into it is seen,
            a ``loop_delay`` later, and an underestimate must not integrate far meanwhile.
        tilt_depth: The depth [m] above which the tilt rows do not integrate. At the entry
            their lever arms are too short to tell a tilt from an offset: on a hole whose top
            face is tilted, the rim contact turned the peg the wrong way by degrees and it
            jammed (docs/reproduction.md). The offsets, and the depth, still move there.
        offset_resolution, tilt_resolution: The smallest offset [m] and tilt [rad] the law
            resolves: each row's stiffness is at least its filtered noise over this, so noise
            alone cannot drive a row by more.
        F_ext_limit: Force limit [N] on |(Fx, Fy, Fz)|: the insertion stops for good above it
            (Algorithm 1's loop condition), as in :class:`fbcc_ros.core.control.ComplianceParams`.
    """

    bandwidth: float = 30.0
    loop_delay: float = 0.01
    phase_margin: float = math.radians(50.0)
    filter_frequency: float = 150.0
    filter_damping: float = 0.7
    dead_band: float = 3.0
    sensor_noise: tuple[float, float, float, float, float] = DEFAULT_SENSOR_NOISE
    identification_window: float = 0.1
    stiffness_min: float = 1e8
    release: float = 0.3
    dither_force: float = 0.3
    dither_effort: float = 2.0
    dither_max_offset: float = 2e-6
    dither_max_tilt: float = 2e-4
    offset_force: float = 40.0
    tilt_effort: float = 3.0
    depth_bandwidth: float = 50.0
    depth_lead: float = 0.01
    fz_back_off: float = 250.0
    guard_growth: float = 0.9
    guard_cycles: int = 8
    guard_amplitude: float = 40.0
    guard_backoff: float = 4.0
    guard_hold: float = 0.2
    coupling_limit: float = 0.0
    plane_gate: bool = True
    offset_resolution: float = 1e-6
    tilt_resolution: float = 2e-4
    lateral_lead: float = 2e-5
    tilt_lead: float = 2e-3
    tilt_depth: float = 2e-4
    F_ext_limit: float = 300.0

    POSITIVE: ClassVar[tuple[str, ...]] = (
        "bandwidth", "filter_frequency", "filter_damping", "dead_band", "identification_window",
        "stiffness_min", "release", "dither_force", "dither_effort", "dither_max_offset",
        "dither_max_tilt", "offset_force", "tilt_effort", "depth_bandwidth", "depth_lead",
        "fz_back_off", "guard_amplitude", "guard_backoff", "guard_hold", "F_ext_limit",
        "offset_resolution", "tilt_resolution", "phase_margin", "lateral_lead", "tilt_lead",
    )  # fmt: skip

    def __post_init__(self) -> None:
        for name in self.POSITIVE:
            require_number(name, getattr(self, name), positive=True)
        noise = self.sensor_noise
        if not (
            isinstance(noise, (tuple, list))
            and len(noise) == 5
            and all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in noise)
        ):
            raise ConfigError("sensor_noise", noise, "five standard deviations > 0 [N, N·m]")
        d = self.loop_delay
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not 0.0 <= d <= 1.0:
            raise ConfigError("loop_delay", d, "a delay in [0, 1] s")
        if not self.phase_margin < math.pi / 2:
            raise ConfigError("phase_margin", self.phase_margin, "< pi/2 rad (90°)")
        if not isinstance(self.plane_gate, bool):
            raise ConfigError("plane_gate", self.plane_gate, "true or false")
        c = self.coupling_limit
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not 0.0 <= c < 1.0:
            raise ConfigError("coupling_limit", c, "a number in [0, 1): 0 ignores the coupling")
        t = self.tilt_depth
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0.0 <= t <= 5e-3:
            raise ConfigError("tilt_depth", t, "a depth in [0, 0.005] m")
        if self.guard_backoff <= 1.0:
            raise ConfigError("guard_backoff", self.guard_backoff, "a factor > 1")
        guard_mod.GuardParams(self.guard_growth, self.guard_cycles, 1.0)  # checks those two
        if self.fz_back_off >= self.F_ext_limit:
            raise ConfigError(
                "fz_back_off", self.fz_back_off, f"< F_ext_limit = {self.F_ext_limit} N"
            )

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], field: str = "params") -> RobustParams:
        """From a YAML mapping (no ``label``): every key a field of this class."""
        unknown = sorted(set(values) - set(cls.names()))
        if unknown:
            raise ConfigError(
                f"{field}.{unknown[0]}", values[unknown[0]],
                f"a robust-law parameter ({', '.join(cls.names())}), or label: N with Table I "
                "gains (M_dp, K_dp, D_dp, M_do, K_do, D_do, ...)",
            )  # fmt: skip
        changes = dict(values)
        if isinstance(changes.get("sensor_noise"), list):
            changes["sensor_noise"] = tuple(changes["sensor_noise"])
        try:
            return cls(**changes)
        except ConfigError as exc:
            raise ConfigError(f"{field}.{exc.field}", exc.value, exc.allowed) from None

    def filter_coefficients(self, dt: float) -> FloatArray:
        """H_f discretised exactly for a zero-order hold at period dt: rows Phi00, Phi01,
        Phi10, Phi11, Gamma0, Gamma1 (the layout of ``filters.second_order_row``), all 5 columns
        alike."""
        w, z = self.filter_frequency, self.filter_damping
        aug = np.array([[0.0, 1.0, 0.0], [-w * w, -2 * z * w, w * w], [0.0, 0.0, 0.0]])
        e = scipy.linalg.expm(aug * dt)
        col = np.array([e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[0, 2], e[1, 2]])
        return np.repeat(col[:, None], 5, axis=1)

    def check_rate(self, dt: float) -> None:
        """Refuse a period that does not resolve the filter, the loops or the dither."""
        if not (math.isfinite(dt) and dt > 0):
            raise InputError("dt", dt, "a control period > 0 in s")
        fastest = max(self.filter_frequency, self.bandwidth, self.depth_bandwidth)
        if fastest * dt > 1.0:
            raise ConfigError(
                "dt", dt, f"<= {1.0 / fastest:.3g} s (a rate >= {fastest:.3g} Hz): the robust "
                "law's fastest rate (filter_frequency, bandwidth, depth_bandwidth) needs "
                "|s| dt <= 1",
            )  # fmt: skip


# Columns of the per-trial state of the robust kernel (besides the identifier's and guard's).
_C_X = 0  # filtered rows ū (5, depth unused)
_C_V = 5  # their rates
_C_INT = 10  # integrators ∫ x_d dt (5; depth unused)
_C_RFR = 15  # the reference x_rfr (the features at the start)
_C_PREV_X = 20  # measured features of the previous sample
_C_PREV_U = 25  # direction rows of the previous sample
_C_LCMD = 30  # depth command
_C_T = 31  # time since the start [s] (dither phase)
_C_HOLD = 32  # time until which the depth holds (guard) [s]
_C_MU = 33  # friction estimate
_C_CONTACT = 34  # 1 when the last sample was contact
_C_HAVE_PREV = 35  # 1 once a previous sample exists
_C_BACKOFF = 36  # gain back-off factors of the 4 rows (>= 1)
_C_TRIPS = 40  # guard trips so far
_C_STOPPED = 41  # 1 once the force limit stopped the insertion
_C_ELAPSED = 42  # insertion time while not stopped
_C_DITHER = 43  # dither amplitudes of the 4 rows, as faded in and out
_C_REACHED = 47  # 1 once the depth command has reached the depth
_N_MAIN = 48

# Indices into the parameter vector of the kernel.
(_P_WC, _P_DB_X, _P_DB_Y, _P_DB_TX, _P_DB_TY, _P_FORGET, _P_KMIN, _P_RELEASE, _P_DITH_F,
 _P_DITH_E, _P_DITH_MAX_X, _P_DITH_MAX_T, _P_U_X, _P_U_T, _P_WL, _P_LEAD, _P_FZ_BACK,
 _P_G_GROWTH, _P_G_CYCLES, _P_G_AMP, _P_G_BACKOFF, _P_G_HOLD, _P_FLIM2, _P_SPEED, _P_DEPTH,
 _P_NOISE_FZ, _P_BASE, _P_PER_DEPTH, _P_HOLE_DEPTH, _P_HOLE_RADIUS, _P_DT, _P_F0, _P_F1, _P_F2,
 _P_F3, _P_SU_X, _P_SU_Y, _P_SU_TX, _P_SU_TY, _P_MU0, _P_COUPLING, _P_GATE, _P_NFLOOR_X,
 _P_NFLOOR_Y, _P_NFLOOR_TX, _P_NFLOOR_TY, _P_G_MIN_X, _P_G_MIN_Y, _P_G_MIN_TX,
 _P_G_MIN_TY, _P_LEAD_X, _P_LEAD_T, _P_TILT_DEPTH, _P_DITH_FADE) = range(54)  # fmt: skip
_N_PARAMS = 54


class RobustFbcc:
    """The stiffness-robust FBCC law (module doc), with the interface of
    :class:`fbcc_ros.core.control.ComplianceLaw`: ``reset(features)``, then
    ``step(response, features, dt)`` once per period returns the command features x_c.

    ``features`` are the measured ones (the robot's feature solution); the identification needs
    all five, not only the depth.
    """

    CODE: ClassVar[int] = -1  # not a code of control._law_rows

    def __init__(self, nominal: PegHole, params: RobustParams | None = None,
                 insertion: Any = None) -> None:  # fmt: skip
        from fbcc_ros.core.control import Insertion  # control imports this module

        self.nominal = nominal
        self.params = params or RobustParams()
        self.insertion = insertion or Insertion()
        self._coeffs: dict[float, FloatArray] = {}
        self._prm: dict[float, FloatArray] = {}
        self._single = True
        self.axis = AxisInsertion(nominal.peg_radius)
        self.reset(np.zeros(5))
        _load_step()

    # -- the ComplianceLaw interface ----------------------------------------------------------
    def prepare(self, dt: float) -> None:
        """Check the rate and compute the period's coefficients now (not in the loop)."""
        self._coefficients(dt)
        self._parameters(dt)

    def max_period(self) -> float:
        """The longest period [s] the law resolves (:meth:`RobustParams.check_rate`)."""
        p = self.params
        return 1.0 / max(p.filter_frequency, p.bandwidth, p.depth_bandwidth)

    def reset(self, features: ArrayLike) -> None:
        """Start an insertion from the measured features, shape (5,) or (N, 5)."""
        rows, self._single = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        rows = self.axis.reset(rows)  # the law runs along the peg's axis
        n = len(rows)
        self._main = np.zeros((n, _N_MAIN))
        self._main[:, _C_RFR : _C_RFR + 5] = rows
        self._main[:, _C_LCMD] = rows[:, 2]
        self._main[:, _C_MU] = self.nominal.friction
        self._main[:, _C_BACKOFF : _C_BACKOFF + 4] = 1.0
        self._ident = np.zeros((n, 2, ident.N_STATE))
        floor = np.zeros(4)
        ident.floor_row(0.0, self.params.stiffness_min, floor)
        ident.reset_planes(self._ident, floor)
        self._guard = np.zeros((n, 4, guard_mod.N_STATE))
        self._command = rows.copy()

    def step(self, response: ArrayLike, features: ArrayLike, dt: float) -> FloatArray:
        """One control period: compensated response (5,) or (N, 5) in {H}, measured features
        (5,) or (N, 5), period dt [s]. Returns the command features x_c."""
        w, _ = as_rows(response, "response", "(Fx, Fy, Fz, Mx, My) in N, N·m")
        x, _ = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        n = len(self._command)
        if len(w) != n or len(x) != n:
            raise InputError("response", f"{len(w)} rows", f"{n} rows, as reset")
        _robust_rows(np.ascontiguousarray(w), self.axis.measured(x, dt), self._parameters(dt),
                     self._coefficients(dt), self._main, self._ident, self._guard,
                     self._command)  # fmt: skip
        command = self.axis.command(self._command)
        return command[0] if self._single else command

    def phase_of(self, trial: int) -> str:
        """``inserting``, ``inserted`` (the depth command reached the depth) or
        ``force_limit``."""
        m = self._main[trial]
        if m[_C_STOPPED]:
            return "force_limit"
        return "inserted" if m[_C_LCMD] >= self.insertion.depth else "inserting"

    @property
    def phase(self) -> list[str]:
        return [self.phase_of(i) for i in range(len(self._command))]

    @property
    def stopped(self) -> np.ndarray:
        """Per trial, whether the force limit stopped it (bool array)."""
        return self._main[:, _C_STOPPED] > 0

    # -- what this law adds -------------------------------------------------------------------
    def estimate(self, trial: int = 0) -> ident.ContactEstimate:
        """The contact identification of one trial now."""
        m = self._main[trial]
        return ident.estimate_of(self._ident[trial], m[_C_MU], m[_C_CONTACT] > 0)

    def guard_trips(self, trial: int = 0) -> int:
        """How often the oscillation guard tripped in this insertion."""
        return int(self._main[trial, _C_TRIPS])

    @property
    def trips(self) -> FloatArray:
        """Guard trips per trial."""
        return self._main[:, _C_TRIPS].copy()

    def _coefficients(self, dt: float) -> FloatArray:
        c = self._coeffs.get(dt)
        if c is None:
            self.params.check_rate(dt)
            c = self._coeffs[dt] = self.params.filter_coefficients(dt)
        return c

    def _parameters(self, dt: float) -> FloatArray:
        prm = self._prm.get(dt)
        if prm is not None:
            return prm
        p, ins, nom = self.params, self.insertion, self.nominal
        noise = np.asarray(p.sensor_noise, dtype=float)
        # noise of the rows u = A F: offsets Fx, Fy; tilts dominated by M / R (eq. 28)
        su = np.array([noise[0], noise[1], noise[3] / nom.hole_radius,
                       noise[4] / nom.hole_radius])  # fmt: skip
        # the filter passes about w_f dt / (4 zeta) of white noise's variance
        filtered = su * math.sqrt(min(1.0, p.filter_frequency * dt / (4 * p.filter_damping)))
        base, per_depth = nom.lever_terms()
        prm = np.zeros(_N_PARAMS)
        chosen = design(p, dt)
        prm[_P_WC] = chosen.bandwidth
        prm[_P_DB_X : _P_DB_TY + 1] = p.dead_band * filtered
        prm[_P_FORGET] = ident.forgetting(p.identification_window, dt)
        prm[_P_KMIN] = p.stiffness_min
        prm[_P_RELEASE] = math.exp(-dt / p.release)
        prm[_P_DITH_F], prm[_P_DITH_E] = p.dither_force, p.dither_effort
        prm[_P_DITH_MAX_X], prm[_P_DITH_MAX_T] = p.dither_max_offset, p.dither_max_tilt
        prm[_P_U_X], prm[_P_U_T] = p.offset_force, p.tilt_effort
        prm[_P_WL], prm[_P_FZ_BACK] = chosen.depth_bandwidth, p.fz_back_off
        prm[_P_LEAD] = p.depth_lead + p.loop_delay  # the measured depth lags by the delay
        prm[_P_G_GROWTH], prm[_P_G_CYCLES] = p.guard_growth, p.guard_cycles
        prm[_P_G_AMP], prm[_P_G_BACKOFF], prm[_P_G_HOLD] = (
            p.guard_amplitude, p.guard_backoff, p.guard_hold)  # fmt: skip
        prm[_P_FLIM2] = p.F_ext_limit**2
        prm[_P_SPEED], prm[_P_DEPTH] = ins.speed, ins.depth
        prm[_P_NOISE_FZ] = noise[2]
        prm[_P_BASE], prm[_P_PER_DEPTH] = base, per_depth
        prm[_P_HOLE_DEPTH], prm[_P_HOLE_RADIUS] = nom.hole_depth, nom.hole_radius
        prm[_P_DT] = dt
        prm[_P_F0 : _P_F3 + 1] = 2 * math.pi * np.array(DITHER_FRACTIONS) / dt  # [rad/s]
        prm[_P_SU_X : _P_SU_TY + 1] = su
        prm[_P_MU0] = nom.friction
        prm[_P_COUPLING] = p.coupling_limit
        prm[_P_GATE] = 1.0 if p.plane_gate else 0.0
        # noise floor of each row: the filtered noise over the resolution [N/m, N/rad]
        resolution = np.array([p.offset_resolution] * 2 + [p.tilt_resolution] * 2)
        prm[_P_NFLOOR_X : _P_NFLOOR_TY + 1] = filtered / resolution
        prm[_P_G_MIN_X : _P_G_MIN_TY + 1] = p.guard_amplitude * filtered
        prm[_P_LEAD_X], prm[_P_LEAD_T] = p.lateral_lead, p.tilt_lead
        prm[_P_TILT_DEPTH] = p.tilt_depth
        # fade of the dither: a first-order lag of one period of the slowest dither
        prm[_P_DITH_FADE] = 1.0 - math.exp(-min(DITHER_FRACTIONS))
        self._prm[dt] = prm
        return prm


@numba.njit(cache=True)  # type: ignore[misc]
def _robust_rows(
    w: FloatArray,
    x: FloatArray,
    prm: FloatArray,
    c: FloatArray,
    main: FloatArray,
    idn: FloatArray,
    grd: FloatArray,
    command: FloatArray,
) -> None:
    """One control period of every trial (row); state arrays advanced in place."""
    dt = prm[_P_DT]
    u = np.zeros(5)
    d_rows = np.zeros(4)
    d_u = np.zeros(4)
    floor = np.zeros(4)
    backoff = np.ones(4)
    excess = np.zeros(4)
    jac = np.zeros(4)
    fitted = np.zeros(4)  # the plane's Jacobian with its fitted coupling, not shrunk
    k_row = np.zeros(4)
    for i in range(w.shape[0]):
        m = main[i]
        # Algorithm 1 runs while |F_ext| <= F_ext_limit; past it the insertion stops for good.
        if w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1] + w[i, 2] * w[i, 2] > prm[_P_FLIM2]:
            m[_C_STOPPED] = 1.0
        depth = max(x[i, 2], 0.0)
        direct_row(w[i], depth, prm[_P_BASE], prm[_P_PER_DEPTH], prm[_P_HOLE_DEPTH],
                   prm[_P_HOLE_RADIUS], u)  # u = A(l) F, eq. (28)  # fmt: skip
        u[2] = 0.0  # the depth is not filtered: it has its own loop
        # contact: Fz or a row above its noise
        contact = w[i, 2] > 3.0 * prm[_P_NOISE_FZ]
        for j in range(4):
            contact = contact or abs(u[ident.ROWS[j]]) > 4.0 * prm[_P_SU_X + j]
        m[_C_CONTACT] = 1.0 if contact else 0.0
        # identification of each row's stiffness from the increments
        for j in range(4):
            f = ident.ROWS[j]
            d_rows[j] = x[i, f] - m[_C_PREV_X + f]
            d_u[j] = u[f] - m[_C_PREV_U + f]
            backoff[j] = m[_C_BACKOFF + j]
        ident.floor_row(depth, prm[_P_KMIN], floor)
        for j in range(4):  # the noise floor: no gain that noise alone could drive further
            floor[j] = max(floor[j], prm[_P_NFLOOR_X + j])
        if m[_C_LCMD] >= prm[_P_DEPTH]:
            m[_C_REACHED] = 1.0
        # at the depth nothing excites the fit: it may raise the estimate, not release it
        release = prm[_P_RELEASE] if m[_C_REACHED] == 0.0 else 1.0
        identify = contact and m[_C_HAVE_PREV] > 0.0
        ident.identify_planes(idn[i], d_rows, x[i, 2] - m[_C_PREV_X + 2], d_u, identify,
                              prm[_P_FORGET], floor, release, backoff)  # fmt: skip
        for f in range(5):
            m[_C_PREV_X + f] = x[i, f]
            m[_C_PREV_U + f] = u[f]
        m[_C_HAVE_PREV] = 1.0
        f_lat = math.sqrt(w[i, 0] * w[i, 0] + w[i, 1] * w[i, 1])
        m[_C_MU] = ident.friction_update(m[_C_MU], w[i, 2], f_lat, 5.0 * prm[_P_SU_X], dt)
        # H_f: the filtered rows ū (eq. 27 with unit DC gain)
        xf = m[_C_X : _C_X + 5]
        vf = m[_C_V : _C_V + 5]
        second_order_row(c, xf, vf, u)
        # oscillation guard on each filtered row: a trip backs that row's gain off, holds depth
        effort = 0.0
        j_max = 0
        for j in range(4):
            f = ident.ROWS[j]
            scale = prm[_P_U_X] if j < 2 else prm[_P_U_T]
            if guard_mod.guard_step(grd[i, j], xf[f], prm[_P_G_GROWTH], int(prm[_P_G_CYCLES]),
                                    prm[_P_G_MIN_X + j]):  # fmt: skip
                m[_C_BACKOFF + j] *= prm[_P_G_BACKOFF]
                ident.back_off(idn[i], j, prm[_P_G_BACKOFF])
                m[_C_TRIPS] += 1.0
                m[_C_HOLD] = m[_C_T] + prm[_P_G_HOLD]
            if abs(xf[f]) / scale > effort:
                effort, j_max = abs(xf[f]) / scale, j
        running = m[_C_STOPPED] == 0.0
        m[_C_T] += dt
        if running:
            m[_C_ELAPSED] += dt
        if not running:
            continue  # the command is held
        # scheduled integrators, per plane: x_c = x_rfr - ∫ ω_c Ĵ⁻¹ dz(ū) dt
        for j in range(4):
            f = ident.ROWS[j]
            excess[j] = max(abs(xf[f]) - prm[_P_DB_X + j], 0.0)
            if xf[f] < 0.0:
                excess[j] = -excess[j]
        for plane in range(2):
            r_d, r_t = ident.PLANES[plane]
            ident.used_matrix(idn[i, plane], plane, math.inf, fitted)
            ident.used_matrix(idn[i, plane], plane, prm[_P_COUPLING], jac)
            # k_θ >= |∂u_d/∂θ| U_θ / U_d: a tilt step then moves the offset row's effort no
            # faster than ω_c times the tilt's own (module doc, coupled tilt row)
            jac[3] = max(jac[3], abs(fitted[1]) * prm[_P_U_T] / prm[_P_U_X])
            k_row[r_d], k_row[r_t] = jac[0], jac[3]
            if prm[_P_GATE] > 0.0:
                # plane gate: a plane whose rows are both inside the dead band is not in
                # contact (nothing to sense, Remark 2) and holds; one that is integrates both
                # rows whole, so a weak row is not eaten by its dead band
                if excess[r_d] == 0.0 and excess[r_t] == 0.0:
                    continue
                excess[r_d], excess[r_t] = xf[ident.ROWS[r_d]], xf[ident.ROWS[r_t]]
            det = jac[0] * jac[3] - jac[1] * jac[2]
            v_d = (jac[3] * excess[r_d] - jac[1] * excess[r_t]) / det
            v_t = (jac[0] * excess[r_t] - jac[2] * excess[r_d]) / det
            m[_C_INT + ident.ROWS[r_d]] += prm[_P_WC] * v_d * dt
            if depth >= prm[_P_TILT_DEPTH]:  # at the entry a tilt row cannot tell tilt
                m[_C_INT + ident.ROWS[r_t]] += prm[_P_WC] * v_t * dt
        for j in range(4):
            f = ident.ROWS[j]
            k_used = k_row[j]
            amp = 0.0
            if contact and m[_C_LCMD] < prm[_P_DEPTH]:  # dither while inserting: sized, capped
                cap = prm[_P_DITH_MAX_X] if j < 2 else prm[_P_DITH_MAX_T]
                size = prm[_P_DITH_F] if j < 2 else prm[_P_DITH_E]
                amp = min(size / k_used, cap)
            # faded in and out over about a dither period: switched at an arbitrary phase, it
            # would step the command by up to its amplitude (a tight stiff fit at the depth)
            m[_C_DITHER + j] += prm[_P_DITH_FADE] * (amp - m[_C_DITHER + j])
            dither = m[_C_DITHER + j] * math.sin(prm[_P_F0 + j] * m[_C_T])
            # the command leads the measured pose by at most the lateral lead: what a contact
            # of unknown stiffness may be pushed before its force is seen (loop_delay later)
            lead = prm[_P_LEAD_X] if j < 2 else prm[_P_LEAD_T]
            target = m[_C_RFR + f] - m[_C_INT + f]
            if target > x[i, f] + lead:
                m[_C_INT + f] = m[_C_RFR + f] - (x[i, f] + lead)
            elif target < x[i, f] - lead:
                m[_C_INT + f] = m[_C_RFR + f] - (x[i, f] - lead)
            command[i, f] = m[_C_RFR + f] - m[_C_INT + f] + dither
        # depth: hold the lateral effort at 1 with the depth loop (module doc)
        v = prm[_P_SPEED]
        rate = v
        if contact:
            scale = prm[_P_U_X] if j_max < 2 else prm[_P_U_T]
            slope = abs(ident.plane_depth_gain(idn[i], j_max)) / scale  # ∂e/∂l [1/m]
            rate = prm[_P_WL] * (1.0 - effort) / max(slope, 1e-9)
            rate = min(max(rate, -v), v)
        if m[_C_T] < m[_C_HOLD]:
            rate = min(rate, 0.0)
        if w[i, 2] > prm[_P_FZ_BACK]:
            rate = -v
        lc = m[_C_LCMD] + rate * dt
        lc = min(lc, x[i, 2] + v * prm[_P_LEAD], prm[_P_DEPTH])
        m[_C_LCMD] = lc
        command[i, 2] = lc


def _load_step() -> None:
    """Load the compiled kernel for the controller's argument types now (numba's cache, or
    compiled on a machine's first run), not on the first period. No rows: nothing is stepped."""
    rows = np.zeros((0, 5))
    _robust_rows(rows, rows, np.zeros(_N_PARAMS), np.zeros((6, 5)), np.zeros((0, _N_MAIN)),
                 np.zeros((0, 2, ident.N_STATE)), np.zeros((0, 4, guard_mod.N_STATE)),
                 rows)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Margins:
    """Stability margins of one linearised lateral loop (see :func:`loop_margins`).

    Attributes:
        phase_margin: [rad] at the crossover with k̂ = k.
        crossover: The crossover frequency [rad/s].
        gain_margin: The largest factor k / k̂ with which the loop stays stable.
    """

    phase_margin: float
    crossover: float
    gain_margin: float


def loop_transfer(
    params: RobustParams,
    dt: float,
    lag: float,
    z: ArrayLike,
    *,
    delay: float = 0.0,
    bandwidth: float | None = None,
) -> np.ndarray:
    """The sampled loop of one lateral row at z (scalar or array), with k̂ = k (module doc):
    integrator ω_c dt / (z - 1), the filter H_f (ZOH), the robot's first-order lag of time
    constant ``lag`` (ZOH; 0: none), one period from the sample to the command, and ``delay``
    [s] more, in whole periods. ``bandwidth`` overrides ω_c."""
    z = np.asarray(z, dtype=complex)
    c = params.filter_coefficients(dt)[:, 0]
    # first component of (z I - Phi)^-1 Gamma, the 2x2 inverse written out
    det = (z - c[0]) * (z - c[3]) - c[1] * c[2]
    h_f = ((z - c[3]) * c[4] + c[1] * c[5]) / det
    a = math.exp(-dt / lag) if lag > 0 else 0.0
    robot = (1 - a) / (z - a)
    w_c = params.bandwidth if bandwidth is None else bandwidth
    periods = 1 + round(delay / dt)
    return w_c * dt / (z - 1) * h_f * robot / z**periods  # type: ignore[no-any-return]


def loop_margins(
    params: RobustParams,
    dt: float,
    lag: float = 0.005,
    *,
    delay: float = 0.0,
    bandwidth: float | None = None,
) -> Margins:
    """Phase margin, crossover and gain margin of the linearised lateral loop (frequency sweep
    of :func:`loop_transfer` on the unit circle)."""
    omegas = np.geomspace(1e-2, math.pi / dt, 4000)
    l_values = loop_transfer(params, dt, lag, np.exp(1j * omegas * dt), delay=delay,
                             bandwidth=bandwidth)  # fmt: skip
    mag, ph = np.abs(l_values), np.unwrap(np.angle(l_values))
    i_c = int(np.argmax(mag < 1.0))
    crossover = float(omegas[i_c])
    phase_margin = float(math.pi + ph[i_c])
    below = np.flatnonzero(ph < -math.pi)
    gain_margin = float(1.0 / mag[below[0]]) if below.size else math.inf
    return Margins(phase_margin, crossover, gain_margin)


@dataclasses.dataclass(frozen=True)
class Design:
    """The bandwidths the law runs with at one period (see :func:`design`).

    Attributes:
        bandwidth: ω_c of the lateral loops [rad/s].
        depth_bandwidth: ω_l of the depth loop [rad/s].
        margins: Of the lateral loop with ``loop_delay`` (and no robot lag beyond it).
    """

    bandwidth: float
    depth_bandwidth: float
    margins: Margins


def design(params: RobustParams, dt: float) -> Design:
    """The largest lateral crossover up to ``bandwidth`` whose sampled loop, delayed by
    ``loop_delay``, keeps ``phase_margin`` (bisection on :func:`loop_margins`), and the depth
    loop's: an integrator behind the same delay has the phase margin
    ``π/2 - ω_l (loop_delay + dt)``, so ``ω_l <= (π/2 - margin) / (loop_delay + dt)``."""
    delay, want = params.loop_delay, params.phase_margin

    def margin(w: float) -> float:
        return loop_margins(params, dt, 0.0, delay=delay, bandwidth=w).phase_margin

    low, high = 0.0, params.bandwidth
    if margin(high) < want:
        for _ in range(40):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if margin(mid) >= want else (low, mid)
        w_c = low
    else:
        w_c = high
    w_l = min(params.depth_bandwidth, (math.pi / 2 - want) / (delay + dt))
    return Design(w_c, w_l, loop_margins(params, dt, 0.0, delay=delay, bandwidth=w_c))
