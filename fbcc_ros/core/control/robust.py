"""Stiffness-robust FBCC: one configuration from soft plastic to steel (DESIGN §6).

Table I's gains fix the loop's crossover to ``k_c / K`` for a contact stiffness k_c, so one
label is stable only below one stiffness (``docs/reproduction.md``). This law keeps FBCC's
structure — the direction rows ``u = A(l) F`` of eq. 28, a second-order filter (eq. 27), an
integrator (Algorithm 1) — and schedules the integrators' gains by the identified stiffness of
each plane (:mod:`fbcc_ros.core.control.identification`), so that every lateral loop crosses over
at the same ``bandwidth`` whatever the part. Per plane (offset d, tilt θ):

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
:func:`~fbcc_ros.core.control.loop_design.loop_margins` computes; an error ``k_j / k̂_j = ρ``
scales the loop gain by ρ, so the gain margin is the largest stiffness underestimate the loop
survives. The identification is meant to err stiff (floor, slow release; on stiff interference
contacts it errs soft instead, ρ up to ~5.5: ``docs/reproduction.md``) and the
oscillation guard (:mod:`fbcc_ros.core.control.guard`) backs a row's gain off by ``guard_backoff``
(the stiffness in use, at once, whatever the fit says) when its filtered response oscillates
without decaying (a growing oscillation, or a limit cycle such as a delay the margins did not
budget for makes), and holds the depth for ``guard_hold``. The tilt
integrators wait until the peg is ``tilt_depth`` in: at the entry a tilt row's lever arms are too
short to tell a tilt from an offset. The law runs in the coordinates of
:mod:`fbcc_ros.core.control.axis_insertion` (depth along the peg's axis, in the hole's estimated
frame).

**Coupled tilt row.** In a tight stiff fit a tilt step moves the plane's offset row far more
than its own: the tilt row's identified slope is noise about zero while ∂u_d/∂θ is 1e4 N/rad, so
at the floor's gain the tilt integrates at tens of degrees a second and wedges the peg. The tilt
row's stiffness in Ĵ is therefore at least ``|∂u_d/∂θ| U_θ / U_d`` (the fitted coupling, ``U`` as
under Depth): a tilt step then moves the offset row's effort ``u_d / U_d`` no faster than
``ω_c`` times the tilt row's own effort. Where the tilt loops run at ``bore_gain`` ω_c (a
clearance fit's bore) the floor is ``bore_gain²`` times that: a part held all round, whose
coupling sets the tilt row's slope, turns at ``ω_c / bore_gain`` there, while a peg pressed on
one side, whose own slope sets it, turns at ``bore_gain`` ω_c.

**Tilt rate.** A tilt row turns the peg no faster than ``tilt_rate``: the overshoot allowed
in one stated ``loop_delay``. As a stiff part comes free its tilt row's stiffness falls and
its gain rises; turning faster than the response can come back, the tilt passes its zero.

**Finding the hole.** A clearance fit's peg that lands on the hole's top face beside the bore
moves away from the face's centre of pressure, read from the tilt rows at the entry, pressing
with ``search_force``, for at most ``search_range`` (:mod:`fbcc_ros.core.control.hole_search`).

**Freeing a wedged peg.** A clearance fit that stops at once in its bore with nothing in its rows
(F_z up to ``wedge_force``) is wedged in two-point contact, whose wrench holds no tilt: the law
pushes with ``search_force`` while it turns the tilt command in directions tried in turn, until
the peg goes in (:mod:`fbcc_ros.core.control.wedge`).

**Lever friction.** A(l)'s lever (eq. 24) holds the axial friction's moment at μR. With the
scenario's μ where the part's differs by Δμ, cos γ Δμ of every lateral force reads as tilt (0.044
for Δμ = 0.15 here): while the offset rows correct the entry it turns aligned tilts past zero
and tilted ones the wrong way (by up to 1° in the study, ``docs/reproduction.md``). The
lever takes the part's μ once the identification has read it on one contact sliding in
(``friction_max``; identification, the lever's friction).

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
had arrived. The tilt loops then integrate at ``settle_gain`` of ω_c (their stiffness still
rises as l³); the offset loops keep ω_c (theirs rises only as l).

**Depth.** The insertion advances at ``insertion.speed`` while the lateral loops are settled and
slows, holds or backs off while they are not: with the lateral effort
``e = max_j max(|u'_j| - n_j, 0) / U_j`` (u' the rows as the depth loop sees them, below;
``n_j`` their noise there, ``dead_band`` deviations of ``sensor_noise`` through that filter, so
noise alone does not hold the depth; ``U`` = ``offset_force`` for dx, dy and ``tilt_effort`` for
the tilts)
and its identified depth sensitivity ``∂e/∂l`` (the RLS's ``b_j``), the depth rate is

.. math::
    \\dot l_c = \\mathrm{clip}\\left(\\omega_l \\frac{1 - e}{\\partial e / \\partial l},
    -v, v\\right)\\ \\text{in contact},\\qquad \\dot l_c = v\\ \\text{otherwise},

a depth loop that holds ``e`` at 1 with the bandwidth ``depth_bandwidth``, whatever the
stiffness, or less: :func:`~fbcc_ros.core.control.loop_design.design` keeps its phase margin too,
with what is in it (39.5 rad/s at the defaults). The depth loop sees the rows through its own
low-pass (``depth_filter_frequency``), not H_f, whose lag would hold it to 29.5 rad/s, and past
the dither notches. The command never leads the measured depth by more than
``v * depth_lead``, so a hold takes effect within a sample. An axial force above
``fz_back_off`` backs off; backing out pulls the peg by at most ``pull_limit`` if set, and in
a clearance fit's bore the loop pushes by at most ``push_limit`` if set, unless a tilt row's
slope is the coupling's (a part held all round; under Coupled tilt row) or the load is a press
fit's (its bound then follows the press: :mod:`~fbcc_ros.core.control.press_fit`).
Through the entry (the first ``entry_depth``: a chamfer and the rim) it steps at most
``entry_step`` between two samples, whatever the rate (a late sample does not step further):
the first contact comes within a step, before the law can see it.

**The grip's compression.** The depth the law reads is the arm's; a push F_z compresses what
holds the peg by F_z / k (``axial_stiffness``, 0: rigid), so the command's end is the depth
plus F_z / k. Past the depth it does not fall back as F_z does (the arm behind its command),
and the peg it believes (the arm's depth less F_z / k) must keep going in: one that falls back
by more than its noise has stopped short of the depth the grip was said to leave (a grip softer
than stated, on the hole's bottom), and the command stops where the arm is. Reached, the fit
holds the peg: the command moves at most ``entry_step`` a sample, backs off no further than the
depth (it does not pull the peg), and does not push into the compression again.

**The noise it is told.** ``sensor_noise`` sets the dead zone, the stiffness's noise floor, the
guard's threshold and the depth loop's ``n_j``. An F/T sensor's is the default. A source noisier
than that (the LBR's virtual sensor from its measured torques reads its moments 15 times
noisier) would hold the depth on its noise: the compensation measures the noise floor in its
tare, and :meth:`RobustFbcc.take_noise` takes each component that is over :data:`NOISIER` times
the one told.

State per trial lives in one float array, stepped by one compiled kernel for the
simulator's batch and the controller's single row alike
(:mod:`fbcc_ros.core.control.robust_kernel`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole, as_rows
from fbcc_ros.core.control import guard as guard_mod
from fbcc_ros.core.control import identification as ident
from fbcc_ros.core.control import press_fit
from fbcc_ros.core.control import robust_kernel as rk
from fbcc_ros.core.control import robust_vector as rv
from fbcc_ros.core.control.axis_insertion import AxisInsertion
from fbcc_ros.core.control.phase import Phase
from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.errors import InputError

#: A measured noise over this many times the one the law was told replaces it
#: (:meth:`RobustFbcc.take_noise`); under it the told one stays: a tare's spread of a few hundred
#: readings is itself uncertain by about 10 %, and a law told right should not move with it.
NOISIER = 2.0


class RobustFbcc:
    """The stiffness-robust FBCC law (module doc), with the interface of
    :class:`fbcc_ros.core.control.laws.ComplianceLaw`: ``reset(features)``, then
    ``step(response, features, dt)`` once per period returns the command features x_c.

    ``features`` are the measured ones (the robot's feature solution); the identification needs
    all five, not only the depth.
    """

    CODE: ClassVar[int] = -1  # not a code of control._law_rows

    def __init__(self, nominal: PegHole, params: RobustParams | None = None,
                 insertion: Any = None) -> None:  # fmt: skip
        from fbcc_ros.core.control.laws import Insertion  # control imports this module

        self.nominal = nominal
        self.params = params or RobustParams()
        self._told_noise = np.asarray(self.params.sensor_noise, dtype=float)
        self.insertion = insertion or Insertion()
        self._coeffs: dict[float, FloatArray] = {}
        self._prm: dict[float, FloatArray] = {}
        self._single = True
        self.axis = AxisInsertion(nominal.peg_radius)
        self.reset(np.zeros(5))

    @staticmethod
    def preload() -> None:
        """Load the compiled step now, not on the first period (:func:`rk.load_step`)."""
        rk.load_step()

    def take_noise(self, measured: ArrayLike) -> bool:
        """The noise of (Fx, Fy, Fz, Mx, My) measured at the cell [N, N·m]: a component over
        :data:`NOISIER` times the one the law was told replaces it (the source is noisier:
        a virtual sensor's), the others stay as told. Returns whether that changed the law's;
        the new noise applies from the next :meth:`prepare`."""
        m = np.asarray(measured, dtype=float)
        if m.shape != (5,) or not np.isfinite(m).all():
            raise InputError("noise", m.tolist(), "five finite standard deviations")
        used = tuple(np.where(m > NOISIER * self._told_noise, m, self._told_noise).tolist())
        if used == tuple(self.params.sensor_noise):
            return False
        self.params = dataclasses.replace(self.params, sensor_noise=used)  # type: ignore[arg-type]
        self._prm.clear()
        return True

    # -- the ComplianceLaw interface ----------------------------------------------------------
    def prepare(self, dt: float) -> None:
        """Check the rate and compute the period's coefficients now (not in the loop)."""
        self._coefficients(dt)
        self._parameters(dt)

    def max_period(self) -> float:
        """The longest period [s] the law resolves (:meth:`RobustParams.check_rate`)."""
        p = self.params
        return 1.0 / max(p.bandwidth, p.depth_bandwidth)

    def reset(self, features: ArrayLike) -> None:
        """Start an insertion from the measured features, shape (5,) or (N, 5)."""
        rows, self._single = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        rows = self.axis.reset(rows)  # the law runs along the peg's axis
        n = len(rows)
        self._main = np.zeros((n, rk.N_MAIN))
        self._main[:, rk.C_RFR : rk.C_RFR + 5] = rows
        self._main[:, rk.C_LCMD] = rows[:, 2]
        self._main[:, rk.C_MU] = self.nominal.friction
        self._main[:, rk.C_BACKOFF : rk.C_BACKOFF + 4] = 1.0
        press_fit.reset(self._main[:, rk.C_PRESS : rk.C_PRESS + press_fit.N_STATE])
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
        rk.robust_rows(np.ascontiguousarray(w), self.axis.measured(x, dt), self._parameters(dt),
                     self._coefficients(dt), self._main, self._ident, self._guard,
                     self._command)  # fmt: skip
        command = self.axis.command(self._command)
        return command[0] if self._single else command

    def phase_of(self, trial: int) -> Phase:
        """``inserting``, ``inserted`` (the depth command reached the depth) or
        ``force_limit``."""
        m = self._main[trial]
        if m[rk.C_STOPPED]:
            return Phase.FORCE_LIMIT
        reached = m[rk.C_LCMD] >= self.insertion.depth + m[rk.C_SINK]  # the grip's compression
        return Phase.INSERTED if reached else Phase.INSERTING

    @property
    def phase(self) -> list[Phase]:
        return [self.phase_of(i) for i in range(len(self._command))]

    @property
    def stopped(self) -> np.ndarray:
        """Per trial, whether the force limit stopped it (bool array)."""
        return self._main[:, rk.C_STOPPED] > 0

    # -- what this law adds -------------------------------------------------------------------
    def estimate(self, trial: int = 0) -> ident.ContactEstimate:
        """The contact identification of one trial now."""
        m = self._main[trial]
        lever = ident.lever_friction(m[rk.C_LEVER : rk.C_LEVER + ident.N_LEVER],
                                     self.nominal.friction)  # fmt: skip
        return ident.estimate_of(self._ident[trial], m[rk.C_MU], lever, m[rk.C_CONTACT] > 0)

    def adjustments(self) -> FloatArray:
        """The integrators ``∫ ω_c Ĵ⁻¹ dz(ū) dt`` of every trial, (N, 5) in the law's axis
        coordinates (a copy): the command is ``x_rfr`` less these, so a rise moves a feature
        down."""
        return self._main[:, rk.C_INT : rk.C_INT + 5].copy()

    def hold_adjustments(self, held: np.ndarray, previous: FloatArray) -> None:
        """Return the integrators of the ``held`` rows ((N, 5) bool) to ``previous`` (from
        :meth:`adjustments` before the period): that period's adjustment of those rows is
        undone from the next command on (a gate outside the law,
        :mod:`fbcc_ros.core.control.state_gate`)."""
        ints = self._main[:, rk.C_INT : rk.C_INT + 5]
        ints[held] = previous[held]

    def guard_trips(self, trial: int = 0) -> int:
        """How often the oscillation guard tripped in this insertion."""
        return int(self._main[trial, rk.C_TRIPS])

    @property
    def trips(self) -> FloatArray:
        """Guard trips per trial."""
        return self._main[:, rk.C_TRIPS].copy()

    @property
    def lever_frictions(self) -> FloatArray:
        """The friction eq. 24's lever measured, per trial; NaN where it has not (it uses the
        nominal μ there)."""
        lever = self._main[:, rk.C_LEVER]  # 0 until measured
        return np.where(lever > 0.0, lever, np.nan)

    def _coefficients(self, dt: float) -> FloatArray:
        c = self._coeffs.get(dt)
        if c is None:
            self.params.check_rate(dt)
            c = self._coeffs[dt] = self.params.filter_coefficients(dt)
        return c

    def _parameters(self, dt: float) -> FloatArray:
        prm = self._prm.get(dt)
        if prm is None:
            prm = self._prm[dt] = rv.parameters(self.params, self.insertion, self.nominal, dt)
        return prm
