"""The robust law's configuration (:class:`RobustParams`): every field with its unit, range
and check, as ``controller.params`` without a ``label`` gives it (DESIGN §6).
:mod:`fbcc_ros.core.control.robust` is the law; :mod:`fbcc_ros.core.control.loop_design` its gain
design."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.control import guard as guard_mod
from fbcc_ros.core.errors import ConfigError, InputError, require_number
from fbcc_ros.core.filters import second_order_coefficients

#: Default sensor noise the law assumes (standard deviations of Fx, Fy, Fz, Mx, My) [N, N·m].
DEFAULT_SENSOR_NOISE = (0.05, 0.05, 0.05, 0.002, 0.002)

#: Dither frequencies of the rows dx, dy, theta_x, theta_y as fractions of the control rate
#: (61, 53, 47 and 41 Hz at 1 kHz): distinct, not harmonics of each other, >= 16 samples a period.
DITHER_FRACTIONS = (0.061, 0.053, 0.047, 0.041)
#: Quality factor (centre over width) of the notch at each row's own dither frequency that
#: keeps the law's excitation out of the depth loop's effort and the guard.
NOTCH_QUALITY = 3.0


@dataclasses.dataclass(frozen=True)
class RobustParams:
    """The robust configuration (the default of ``controller.params``). SI units.

    Attributes:
        bandwidth: Largest ω_c, the crossover of every lateral loop [rad/s]; the law runs with
            less when ``loop_delay`` leaves less than ``phase_margin``
            (:func:`~fbcc_ros.core.control.loop_design.design`).
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
        stiffness_min: The softest the command meets, as eq. 8's k [Pa]: the floor of the
            identified stiffness (the highest gain the law will use). The identifier sees the
            contact in series with the grip (arm, F/T sensor, gripper), so the floor is under
            the softest grip too: at 1e7 the offset rows' floor at 10 mm is 3e4 N/m, about a
            2e4 N/m grip's, where the softest material's (1e8) put it at 3e5 N/m and a peg in
            a soft grip settled at a tenth of the designed crossover (at 100 Hz, 54 of 1000
            parts still pressed on their wall by over 0.5 N at the run's end; none at 1e7).
        release: Time constant with which a used stiffness may fall [s].
        dither_force: Dither amplitude of the offset rows, as a force [N].
        dither_effort: Dither amplitude of the tilt rows, in units of A(l) F [N].
        dither_max_offset: Cap of the offset dither [m].
        dither_max_tilt: Cap of the tilt dither [rad].
        offset_force: U of the offset rows: the lateral force at which the insertion holds [N].
        tilt_effort: U of the tilt rows [N, units of A(l) F].
        depth_bandwidth: Largest ω_l of the depth loop [rad/s]
            (:func:`~fbcc_ros.core.control.loop_design.design`).
        depth_filter_frequency: ω of the second-order low-pass (damping ``filter_damping``)
            through which the depth loop sees the rows [rad/s]: faster than H_f, whose lag at
            the depth loop's crossover (16° at 30 rad/s) would cut its bandwidth under the
            stated margin, while the noise it passes (an effort of about 0.05 per deviation)
            stays far below the effort of 1 the depth loop holds. Discretised exactly, it needs
            no rate of its own; the depth loop's design accounts for it at the rate in use.
        depth_lead: Longest lead of the depth command over the measured depth, beyond
            ``loop_delay``, in seconds of insertion speed [s].
        fz_back_off: Axial force above which the insertion backs off [N]: above the largest
            push-in the law is asked to make (the studies admit 2/3 of ``F_ext_limit``, 200 N;
            backing off at 200 N itself left such parts hovering short of the depth).
        pull_limit: The most the depth loop pulls on the peg [N] (0: no bound): backing out
            of a fit whose rows read loud, it stops backing out once F_z is below -pull_limit,
            leaving a peg held by friction to the tilt loops and the wedge probe. Unbounded,
            it pulled wedged pegs on MuJoCo at 93-150 N until they sprang free
            (docs/plant.md).
        push_limit: The most the depth loop pushes on the peg in a clearance fit's bore [N]
            (past ``entry_depth``; 0: no bound): above it the depth backs off to it, unless a
            tilt row's slope is the coupling's (a part held all round, which can need more to
            slide). A peg free in its bore slides in with little; pushed harder it presses a
            jam tighter. 20 N cuts the model's F_z p99 at 1 kHz from 40 N to 28 N and, at
            100 Hz on MuJoCo, the jams pushed into the wrench guard. A pair the law believes a
            clearance fit that its tolerances make an interference fit needs more: where the
            peg stops at the bound after a climb of F_z with the depth, held all round, the
            bound follows that press's line (:mod:`~fbcc_ros.core.control.press_fit`).
        axial_stiffness: The stiffness along the peg's axis of what holds it (arm, F/T sensor,
            gripper) [N/m] (0: rigid, the default). The depth the law reads is the arm's; a
            push F_z compresses the grip by F_z / k, so the arm goes that much deeper to put
            the peg at the depth (a press fit's 200 N in a 1e6 N/m grip: 0.2 mm). Stated too
            stiff, the peg ends short by F_z times the difference of the compliances; too soft,
            it is pushed on until the peg the law believes stops going in (module doc: on the
            hole's bottom, within 2 µm). Measure it by pressing the grasped peg on a rigid
            face: F_z over the arm's travel (docs/integration.md).
        guard_growth, guard_cycles: :class:`fbcc_ros.core.control.guard.GuardParams`; the guard's
            minimum amplitude is ``guard_amplitude`` times the row's filtered noise.
        guard_amplitude: See above (dimensionless).
        guard_effort: A half-wave also counts above this fraction of its row's hold
            (``offset_force``, ``tilt_effort``) when that is lower than ``guard_amplitude``
            deviations, but never under :data:`~fbcc_ros.core.control.guard.NOISE_PEAKS`
            deviations. A tilt row's 40 deviations (3.7) are over its hold of 3: an
            oscillation there backed the depth off before the guard counted it.
        guard_backoff: Factor by which a tripped row's gain falls (> 1).
        guard_hold: How long the depth holds after a trip [s]. The back-off acts at once; on
            the clearance studies of seeds 13 and 3 a hold of 0.2 s left 7 and 6 parts over
            3 s, 0.05 s 3 and 2 (``docs/reproduction.md``).
        settle_force: Once the depth is reached, the band inside which a row does not move the
            peg [N, units of A(l) F], if wider than the dead band: the residual lateral force
            the law accepts. A still peg cannot wedge itself; one whose loops integrate noise
            at the floor's gain drifts by up to the resolutions below, more than a sub-µm
            clearance, and a stiff part then rang into 200 N at the depth.
        settle_gain: The tilt loops' crossover once the depth is reached, as a fraction of
            the one they ran with. There nothing excites the fit while the tilt's stiffness
            still rises (eq. 8: as l³ over the last millimetre); at the full crossover the tilt
            rows of stiff interference parts rang at the depth and the depth backed off. The
            offset loops keep their crossover: their stiffness rises only as l, and where a
            compliant grip makes the plane softer than the estimate's floor their loop is
            already slower than designed (at a quarter, 370 of docs/integration.md's 1000 parts
            at 100 Hz ended pressed against the wall by over 0.5 N; 171 at the full one).
        bore_gain: The tilt loops' crossover in a clearance fit's bore (past ``entry_depth``,
            before the depth), as a multiple of ω_c (1: off). A peg in two-point
            contact there goes in only as fast as the tilt loops turn it upright (at depth l
            its tilt is at most 2c/l), at ω_c over the stiffness of the side it presses while
            the side it turns toward has none: on MuJoCo a peg in a 44 µm bore crept in at
            0.15 mm/s. 2 keeps 24-34° of phase margin where the estimate is exact
            (:func:`~fbcc_ros.core.control.loop_design.loop_margins`). A part held all round,
            whose coupling sets the tilt row's slope, turns at ω_c / bore_gain there instead
            (robust.py, coupled tilt row). docs/plant.md measures it.
        coupling_limit: How much of a plane's identified coupling the law inverts:
            |J01 J10| <= coupling_limit J00 J11 (0: the rows alone, as FBCC's A(l)).
        plane_gate: A plane whose two rows are both inside their dead band holds (nothing to
            sense); one that is not integrates both rows whole, so that a weak tilt row is not
            eaten by its dead band while its plane is in contact.
        tilt_rate: The fastest a tilt row may turn the peg [rad/s]: the overshoot allowed
            (0.2°) in one ``loop_delay`` of the robust scenarios (0.05 s). A tilt turning
            faster passes its zero before the response that says so is back: a stiff part
            coming free 1.4 mm in turned at 6°/s and passed zero by 0.76° (trial 7478 of
            seed 29, ``docs/reproduction.md``).
        lateral_lead, tilt_lead: The most an offset [m] or tilt [rad] command may lead the
            measured pose: a contact's stiffness is unknown until the motion into it is seen,
            a ``loop_delay`` later, and an underestimate must not integrate far meanwhile.
        tilt_depth: The depth [m] above which the tilt rows do not integrate. At the entry
            their lever arms are too short to tell a tilt from an offset: on a hole whose top
            face is tilted, the rim contact turned the peg the wrong way by degrees and it
            jammed (docs/reproduction.md). The offsets, and the depth, still move there.
        friction_max: The largest friction coefficient the lever of A(l) may take from the
            contact (:func:`fbcc_ros.core.control.identification.one_contact_friction`): eq.
            24 puts the axial friction's moment at μR, and a part whose μ differs from the
            scenario's by Δμ leaves cos γ Δμ of every lateral force in its tilt row (a tilt
            turned past zero or the wrong way, ``docs/reproduction.md``). A sliding sample
            reading more is taken for a wedged contact; 0 keeps the scenario's μ.
        entry_step, entry_depth: Through the hole's entry, the first ``entry_depth`` [m] (a
            chamfer and the rim's top face), the depth command moves at most ``entry_step``
            [m] a step (between two samples the law sees, one period or a late sample's
            several): the first contact with the rim comes within one step, and
            a stiff part in a stiff grip turns that step into force before the law can see it
            (at 100 Hz a 5 mm/s insertion steps 50 µm, which stopped stiff parts at the guard
            on the model with its rim, ``docs/integration.md``). 10 µm is 10 N through the
            stiffest grip (:data:`~fbcc_ros.core.control.hole_search.AXIAL_STIFFNESS`) and
            about 190 N on a rigidly held steel peg against a wall; it crosses 0.6 mm in 0.6 s
            at 100 Hz. At 1 kHz the step is the insertion's own up to 10 mm/s.
        search_speed, search_range, search_force: Finding the hole
            (:mod:`fbcc_ros.core.control.hole_search`): a peg the top face carries beside the
            bore moves toward the hole at ``search_speed`` [m/s], away from the face's centre
            of pressure, for at most ``search_range`` [m] of travel (0: no search), pressing
            with at most about ``search_force`` [N] meanwhile. The range covers several times
            the offset the law is meant for (0.1 mm) and the grip's deflection under the
            face's friction before the peg slides (μ ``search_force`` over the tip's lateral
            stiffness, an angular grip's tipping included: 0.15 mm at μ 0.3 in a grip of
            5e4 N/m and 30 N·m/rad at 50 mm).
        wedge_force: Freeing a wedged peg (:mod:`fbcc_ros.core.control.wedge`): a clearance
            fit's insertion that stops at once, its axial force reaching ``wedge_force`` [N]
            within a few tens of microns of the arm's travel while its rows stay quiet, in
            the bore where a two-point contact can wedge (Whitney: up to 4° of tilt, μ up to
            0.5), is wedged. The depth loop then pushes with ``search_force`` only, and the
            tilt command turns, at ``tilt_rate`` and at most 0.5° from where it wedged, in
            directions tried in turn; one whose tilt rows push back by more than
            ``wedge_force`` (in their units, a force at the rim) is left for the next. 0: off.
            A wedge loaded to the back-off (250 N) could not be freed on MuJoCo; 20 N is about
            the friction of the rows' hold (``offset_force``) at μ 0.5.
        offset_resolution, tilt_resolution: The smallest offset [m] and tilt [rad] the law
            resolves: each row's stiffness is at least its filtered noise over this, so noise
            alone cannot drive a row by more.
        F_ext_limit: Force limit [N] on |(Fx, Fy, Fz)|: the insertion stops for good above it
            (Algorithm 1's loop condition), as in
            :class:`fbcc_ros.core.control.compliance.ComplianceParams`.
    """

    bandwidth: float = 30.0
    loop_delay: float = 0.01
    phase_margin: float = math.radians(50.0)
    filter_frequency: float = 150.0
    filter_damping: float = 0.7
    dead_band: float = 3.0
    sensor_noise: tuple[float, float, float, float, float] = DEFAULT_SENSOR_NOISE
    identification_window: float = 0.1
    stiffness_min: float = 1e7
    release: float = 0.3
    dither_force: float = 0.3
    dither_effort: float = 2.0
    dither_max_offset: float = 2e-6
    dither_max_tilt: float = 2e-4
    offset_force: float = 40.0
    tilt_effort: float = 3.0
    depth_bandwidth: float = 50.0
    depth_filter_frequency: float = 400.0
    depth_lead: float = 0.01
    fz_back_off: float = 250.0
    pull_limit: float = 20.0
    push_limit: float = 20.0
    axial_stiffness: float = 0.0
    guard_growth: float = 0.9
    guard_cycles: int = 8
    guard_amplitude: float = 40.0
    guard_effort: float = 0.25
    guard_backoff: float = 4.0
    guard_hold: float = 0.05
    settle_force: float = 0.25
    settle_gain: float = 0.25
    bore_gain: float = 2.0
    coupling_limit: float = 0.0
    plane_gate: bool = True
    offset_resolution: float = 1e-6
    tilt_resolution: float = 2e-4
    tilt_rate: float = math.radians(4.0)
    lateral_lead: float = 2e-5
    tilt_lead: float = 2e-3
    tilt_depth: float = 2e-4
    friction_max: float = 0.8
    entry_step: float = 1e-5
    entry_depth: float = 6e-4
    search_speed: float = 1e-3
    search_range: float = 1e-3
    search_force: float = 5.0
    wedge_force: float = 20.0
    F_ext_limit: float = 300.0

    POSITIVE: ClassVar[tuple[str, ...]] = (
        "bandwidth", "filter_frequency", "filter_damping", "dead_band", "identification_window",
        "stiffness_min", "release", "dither_force", "dither_effort", "dither_max_offset",
        "dither_max_tilt", "offset_force", "tilt_effort", "depth_bandwidth",
        "depth_filter_frequency", "depth_lead", "fz_back_off", "guard_amplitude",
        "guard_backoff", "guard_hold", "F_ext_limit", "guard_effort", "settle_gain",
        "offset_resolution", "tilt_resolution", "phase_margin", "lateral_lead", "tilt_lead",
        "tilt_rate", "entry_step", "search_speed", "search_force",
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
        if require_number("settle_force", self.settle_force) < 0.0:
            raise ConfigError(
                "settle_force",
                self.settle_force,
                "a force >= 0 [N] (0: the dead band alone at the depth)",
            )
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
        e = self.entry_depth
        if not (math.isfinite(e) and 0.0 <= e <= 0.005):
            raise ConfigError("entry_depth", e, "a depth in [0, 0.005] m (0: off)")
        w, most = self.wedge_force, self.F_ext_limit
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not 0.0 <= w < most:
            raise ConfigError("wedge_force", w, f"a force in [0, F_ext_limit = {most} N) (0: off)")
        s = self.search_range
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not 0.0 <= s <= 0.01:
            raise ConfigError("search_range", s, "a travel in [0, 0.01] m (0: no search)")
        f = self.friction_max
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not 0.0 <= f <= 2.0:
            raise ConfigError("friction_max", f, "a friction coefficient in [0, 2] (0: off)")
        t = self.tilt_depth
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0.0 <= t <= 5e-3:
            raise ConfigError("tilt_depth", t, "a depth in [0, 0.005] m")
        if self.settle_gain > 1.0:
            raise ConfigError("settle_gain", self.settle_gain, "a fraction in (0, 1] of ω_c")
        b = self.bore_gain
        if isinstance(b, bool) or not isinstance(b, (int, float)) or not 1.0 <= b <= 2.0:
            raise ConfigError("bore_gain", b, "a multiple in [1, 2] of ω_c (1: off; above 2 "
                              "the loop with an exact estimate keeps under 24° of phase margin)")
        k = self.axial_stiffness
        if isinstance(k, bool) or not isinstance(k, (int, float)) or not 0.0 <= k < math.inf:
            raise ConfigError("axial_stiffness", k, "a stiffness >= 0 [N/m] (0: rigid)")
        for name in ("pull_limit", "push_limit"):
            p = getattr(self, name)
            if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 <= p < most:
                raise ConfigError(name, p, f"a force in [0, F_ext_limit = {most} N) (0: off)")
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
        col = second_order_coefficients(self.filter_frequency, self.filter_damping, dt)
        return np.repeat(col[:, None], 5, axis=1)

    def check_rate(self, dt: float) -> None:
        """Refuse a period that does not resolve the loops' integrators (|s| dt <= 1 for
        ``bandwidth`` and ``depth_bandwidth``). The filters need no rate of their own: they are
        discretised exactly, and the loops are designed through them at the rate in use
        (:mod:`~fbcc_ros.core.control.loop_design`), which lowers a loop's crossover where the
        period's delay would cut its margin."""
        if not (math.isfinite(dt) and dt > 0):
            raise InputError("dt", dt, "a control period > 0 in s")
        fastest = max(self.bandwidth, self.depth_bandwidth)
        if fastest * dt > 1.0:
            raise ConfigError(
                "dt", dt, f"<= {1.0 / fastest:.3g} s (a rate >= {fastest:.3g} Hz): the robust "
                "law's loops (bandwidth, depth_bandwidth) need |s| dt <= 1",
            )  # fmt: skip
