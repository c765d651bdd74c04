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
``L(s) = ω_c H_f(s) G_robot(s) / s``, with the margins
:func:`~fbcc_ros.core.loop_design.loop_margins` computes; an error ``k_j / k̂_j = ρ`` scales the
loop gain by ρ, so the gain margin is the largest stiffness underestimate the loop survives. The
identification is meant to err stiff (floor, slow release; on stiff interference contacts it
errs soft instead, ρ up to ~5.5: ``docs/reproduction.md``) and the
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
at the rim) pushes a tight stiff fit into hundreds of newtons. Its response is the law's own
excitation, not a load: each filtered row passes notches at its plane's two dither frequencies
(a tilt dither moves the plane's offset row too; ``NOTCH_QUALITY``) before the guard and the
depth loop see it. Without it, a row whose
stiffness the fit underestimates by ρ answers the dither with ρ times its designed size (2/3 of
``tilt_effort`` for the tilts): at ρ ≈ 2 the tilt dither alone read as an effort of 3 and backed
a 20 GPa part off from 9.9 mm, and it reads as a sustained oscillation to the guard.

**At the depth.** Once the depth is reached the peg is left still: the dither fades out, the
estimate is no longer released (the fit may still raise it: with nothing exciting the fit its
slopes drift with the noise, and a released estimate is a raised gain, which rang stiff parts'
lateral loops into 100-N oscillations there), and a row moves the peg only beyond
``settle_force``, the residual lateral force the law accepts. Integrating noise-level rows at
the floor's gain drifts the peg by up to the resolutions, more than a sub-µm clearance: a
46 GPa part with 0.14 µm of clearance was tilted into its hole's wall at 200 N, 1 s after it
had arrived.

**Depth.** The insertion advances at ``insertion.speed`` while the lateral loops are settled and
slows, holds or backs off while they are not: with the lateral effort
``e = max_j |u'_j| / U_j`` (u' the rows as the depth loop sees them, below; ``U`` =
``offset_force`` for dx, dy and ``tilt_effort`` for the tilts)
and its identified depth sensitivity ``∂e/∂l`` (the RLS's ``b_j``), the depth rate is

.. math::
    \\dot l_c = \\mathrm{clip}\\left(\\omega_l \\frac{1 - e}{\\partial e / \\partial l},
    -v, v\\right)\\ \\text{in contact},\\qquad \\dot l_c = v\\ \\text{otherwise},

a depth loop that holds ``e`` at 1 with the bandwidth ``depth_bandwidth``, whatever the
stiffness, or less: :func:`~fbcc_ros.core.loop_design.design` keeps its phase margin too, with
what is in it (39.5 rad/s at the defaults). The depth loop sees the rows through its own
low-pass (``depth_filter_frequency``), not H_f, whose lag would hold it to 29.5 rad/s, and past
the dither notches. The command never leads the measured depth by more than
``v * depth_lead``, so a hold takes effect within a sample. An axial force above
``fz_back_off`` backs off.

State per trial lives in one float array (columns below), stepped by one compiled kernel for the
simulator's batch and the controller's single row alike.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numba
import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core import guard as guard_mod
from fbcc_ros.core import identification as ident
from fbcc_ros.core.axis_insertion import AxisInsertion
from fbcc_ros.core.contact import FloatArray, PegHole, as_rows
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.filters import (
    notch_coefficients,
    notch_step,
    second_order_coefficients,
    second_order_row,
    second_order_step,
)
from fbcc_ros.core.loop_design import design
from fbcc_ros.core.robust_params import DITHER_FRACTIONS, NOTCH_QUALITY, RobustParams
from fbcc_ros.core.segmentation import direct_row

#: Per row j (dx, dy, theta_x, theta_y): the other row of its plane (identification.PLANES).
_PARTNER = (3, 2, 1, 0)

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
_C_NOTCH = 48  # the guard's notches: each row's 2 at its plane's dither frequencies (2 each)
_C_DEPTH_F = 64  # the depth loop's low-pass of each row (x, v)
_C_DNOTCH = 72  # the depth loop's notches, as _C_NOTCH
_N_MAIN = 88

# Indices into the parameter vector of the kernel.
(_P_WC, _P_DB_X, _P_DB_Y, _P_DB_TX, _P_DB_TY, _P_FORGET, _P_KMIN, _P_RELEASE, _P_DITH_F,
 _P_DITH_E, _P_DITH_MAX_X, _P_DITH_MAX_T, _P_U_X, _P_U_T, _P_WL, _P_LEAD, _P_FZ_BACK,
 _P_G_GROWTH, _P_G_CYCLES, _P_G_AMP, _P_G_BACKOFF, _P_G_HOLD, _P_FLIM2, _P_SPEED, _P_DEPTH,
 _P_NOISE_FZ, _P_BASE, _P_PER_DEPTH, _P_HOLE_DEPTH, _P_HOLE_RADIUS, _P_DT, _P_F0, _P_F1, _P_F2,
 _P_F3, _P_SU_X, _P_SU_Y, _P_SU_TX, _P_SU_TY, _P_MU0, _P_COUPLING, _P_GATE, _P_NFLOOR_X,
 _P_NFLOOR_Y, _P_NFLOOR_TX, _P_NFLOOR_TY, _P_G_MIN_X, _P_G_MIN_Y, _P_G_MIN_TX,
 _P_G_MIN_TY, _P_LEAD_X, _P_LEAD_T, _P_TILT_DEPTH, _P_DITH_FADE, _P_NOTCH) = range(55)  # fmt: skip
_P_NOTCH_END = _P_NOTCH + 24  # (b0, b1, a2) of each row's 2 notches
_P_SETTLE = _P_NOTCH_END  # the band of every row once the depth is reached
_P_DEPTH_F = _P_NOTCH_END + 1  # the depth loop's low-pass (filters.second_order_coefficients)
_N_PARAMS = _P_DEPTH_F + 6


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
        for j in range(4):  # each row: its own dither's frequency, then its plane partner's
            for n, row in enumerate((j, _PARTNER[j])):
                prm[_P_NOTCH + 6 * j + 3 * n : _P_NOTCH + 6 * j + 3 * n + 3] = (
                    notch_coefficients(prm[_P_F0 + row], NOTCH_QUALITY, dt))
        prm[_P_SETTLE] = p.settle_force
        prm[_P_DEPTH_F : _P_DEPTH_F + 6] = second_order_coefficients(
            p.depth_filter_frequency, p.filter_damping, dt)  # fmt: skip
        self._prm[dt] = prm
        return prm


@numba.njit(cache=True)  # type: ignore[misc]
def _without_dither(prm: FloatArray, bank: FloatArray, j: int, value: float) -> float:
    """Row j's value past the notches at its plane's two dither frequencies (module doc,
    excitation); advances their state in ``bank`` (16 columns: 4 per row)."""
    for n in range(2):
        value = notch_step(prm[_P_NOTCH + 6 * j + 3 * n : _P_NOTCH + 6 * j + 3 * n + 3],
                           bank[4 * j + 2 * n : 4 * j + 2 * n + 2], value)  # fmt: skip
    return value  # type: ignore[no-any-return]


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
            quiet = _without_dither(prm, m[_C_NOTCH : _C_NOTCH + 16], j, xf[f])
            # what the depth loop sees: the row through its own, faster low-pass (module doc)
            fast = second_order_step(prm[_P_DEPTH_F : _P_DEPTH_F + 6],
                                     m[_C_DEPTH_F + 2 * j : _C_DEPTH_F + 2 * j + 2], u[f])
            fast = _without_dither(prm, m[_C_DNOTCH : _C_DNOTCH + 16], j, fast)  # fmt: skip
            if guard_mod.guard_step(grd[i, j], quiet, prm[_P_G_GROWTH], int(prm[_P_G_CYCLES]),
                                    prm[_P_G_MIN_X + j]):  # fmt: skip
                m[_C_BACKOFF + j] *= prm[_P_G_BACKOFF]
                ident.back_off(idn[i], j, prm[_P_G_BACKOFF])
                m[_C_TRIPS] += 1.0
                m[_C_HOLD] = m[_C_T] + prm[_P_G_HOLD]
            if abs(fast) / scale > effort:
                effort, j_max = abs(fast) / scale, j
        running = m[_C_STOPPED] == 0.0
        m[_C_T] += dt
        if running:
            m[_C_ELAPSED] += dt
        if not running:
            continue  # the command is held
        # scheduled integrators, per plane: x_c = x_rfr - ∫ ω_c Ĵ⁻¹ dz(ū) dt
        for j in range(4):
            f = ident.ROWS[j]
            band = prm[_P_DB_X + j]
            if m[_C_REACHED] > 0.0:  # at the depth only a settle_force moves the peg
                band = max(band, prm[_P_SETTLE])
            excess[j] = max(abs(xf[f]) - band, 0.0)
            if xf[f] < 0.0:
                excess[j] = -excess[j]
        for plane in range(2):
            r_d, r_t = ident.PLANES[plane]
            coupling = ident.used_matrix(idn[i, plane], plane, prm[_P_COUPLING], jac)
            # k_θ >= |∂u_d/∂θ| U_θ / U_d: a tilt step then moves the offset row's effort no
            # faster than ω_c times the tilt's own (module doc, coupled tilt row)
            jac[3] = max(jac[3], abs(coupling) * prm[_P_U_T] / prm[_P_U_X])
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
