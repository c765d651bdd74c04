"""The controller stage (Algorithm 1): the compensated wrench and the peg's pose → the command,
as the peg's pose in {H}, with the supervisor's phases and safety.

The law (``fbcc``, the ``admittance`` baseline or ``none``), its gains and the insertion come
from a scenario file (DESIGN §4: ``geometry`` is the nominal pair, ``controller.params`` the
gains, ``insertion`` the depth and speed). The features are the peg's pose read with the
nominal radius; each compensated wrench (in {H}, moments about its origin, moved here to the
nominal pair's acting point, ``L + H`` below the top face) is one control period of the supervisor
(:mod:`fbcc_ros.core.control.supervisor`: a fault holds the last command and says why).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench import response_from_wrench
from fbcc_ros.core.contact.features import features_from_pose, pose_from_features
from fbcc_ros.core.contact.segmentation import response_state
from fbcc_ros.core.control.deviation_filter import stiffness_range
from fbcc_ros.core.control.laws import make_law
from fbcc_ros.core.control.phase import WAITING
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.state_feed import StateFeed
from fbcc_ros.core.control.supervisor import SafetyLimits, Supervisor
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.pipeline.lateral_watch import LateralWatch
from fbcc_ros.pipeline.parameters import HOLE_FRAME, Param
from fbcc_ros.pipeline.rate import InputRate
from fbcc_ros.pipeline.state_worker import StateWorker

_LIMITS = SafetyLimits()
TABLE = (
    Param("scenario", "config/scenarios/bringup_interference.yaml", "scenario YAML with the "
          "nominal geometry, the gains (controller.params) and the insertion; relative paths "
          "are tried from the working directory, then from the package's share directory"),
    Param("law", "scenario", "control law; scenario: the scenario's controller.type (the first "
          "of a list)", choices=("scenario", "fbcc", "admittance", "none")),
    Param("rate_hz", 0.0, "control rate (one period per compensated wrench); 0: the "
          "scenario's rate_hz", "Hz", 0.0, 10000.0),
    Param("timeout", _LIMITS.timeout, "stale input fault after this gap", "s", 1e-3, 10.0,
          read_only=False),
    Param("max_step", _LIMITS.max_step, "largest change of dx, dy, l per command", "m", 1e-9,
          0.01, read_only=False),
    Param("max_step_angle", _LIMITS.max_step_angle, "largest change of a tilt per command",
          "rad", 1e-9, 0.1, read_only=False),
    Param("fault_retract", 0.0, "after a fault or a force limit, withdraw this far along the "
          "hole axis from where the arm is (0: hold there)", "m", 0.0, 0.05),
    Param("auto_start", False, "start the first insertion once features and wrenches arrive"),
    Param("estimate_rate_hz", 100.0, "rate of fbcc/contact_estimate (robust law; at most the "
          "control rate)", "Hz", 1.0, 10000.0),
    Param("state_rate_hz", 200.0, "updates of fbcc/contact_state_estimate, the contact state "
          "by the deviation filter (in a process of its own, started once the topic is heard; "
          "at most the control rate; each update weighs the mean of the samples since the "
          "last); 0: none", "Hz", 0.0, 10000.0),
    Param("state_stiffness", [0.0, 0.0], "the part's contact stiffness k as the contact-state "
          "filter takes it, [low, high], log-uniform between; [0, 0]: the scenario's "
          "geometry.stiffness (the part's k as stated; a part more than 2x off it costs the "
          "filter accuracy); [1e8, 1e11] for a part whose k nobody knows", "Pa"),
    HOLE_FRAME,  # transport settings (the node's)
)  # fmt: skip


def safety_limits(values: dict[str, Any]) -> SafetyLimits:
    """The supervisor's limits from :data:`TABLE`'s values."""
    return SafetyLimits(values["timeout"], values["max_step"], values["max_step_angle"])


def state_stiffness(value: list[float]) -> tuple[float, float] | None:
    """The filter's k range of the ``state_stiffness`` parameter; None for [0, 0]."""
    if [float(x) for x in value] == [0.0, 0.0]:
        return None
    return stiffness_range(value, "state_stiffness")


class ControllerStage:
    """The supervised law of :data:`TABLE`'s values.

    Attributes:
        sup: The supervisor (phase, reason, the law).
        nominal: The controller's nominal pair (its radius reads the features).
        auto_start: Start the first insertion once features and wrenches arrive (after a
            reset, an insertion waits for ``start``).
    """

    def __init__(self, values: dict[str, Any]) -> None:
        sc = scenario_io.load(scenario_io.find(values["scenario"]))
        self.nominal = sc.geometry
        #: where the law's moments are taken (the wrenches come about the {H} origin)
        self.acting_point = sc.geometry.acting_point_in_hole()
        name = sc.laws[0] if values["law"] == "scenario" else values["law"]
        law = make_law(name, sc.geometry, sc.params, sc.insertion)
        rate = values["rate_hz"] or sc.rate_hz
        #: the safety limits at start-up: the runtime ones are at most these
        self.configured = safety_limits(values)
        try:
            self.sup = Supervisor(law, 1.0 / rate, self.configured, values["fault_retract"])
        except ConfigError as exc:  # a period too long for the gains: say it as the rate
            if exc.field != "dt":
                raise
            allowed = f"a rate the gains resolve ({exc.allowed})"
            raise ConfigError("rate_hz", rate, allowed) from None
        self.auto_start = bool(values["auto_start"])
        self.robust = isinstance(law, RobustFbcc)
        #: one contact estimate every this many periods
        self.estimate_every = max(1, round(rate / values["estimate_rate_hz"]))
        self._periods = 0
        self.response: FloatArray | None = None  # the last period's
        self.input_rate = InputRate(rate, "the compensated wrench")
        self.lateral = LateralWatch()
        #: the periods the contact-state filter is handed (None: no filter), and its process
        state_rate = values["state_rate_hz"]
        every = max(1, round(rate / state_rate)) if state_rate > 0 else 0  # at most the rate
        self.state_feed = StateFeed(every) if every else None
        self.state_stiffness = state_stiffness(values["state_stiffness"])
        self.state_worker: StateWorker | None = None
        self._was_active = False

    def preload(self) -> None:
        """Load the law's compiled step now, not in the first period."""
        self.sup.law.preload()

    def apply(self, values: dict[str, Any]) -> None:
        """The runtime parameters (the safety limits), only ever tighter than at start-up: a
        limit loosened while the cell runs raises ConfigError, and the change is refused."""
        limits = safety_limits(values)
        for name in ("timeout", "max_step", "max_step_angle"):
            value, configured = getattr(limits, name), getattr(self.configured, name)
            if value > configured:
                raise ConfigError(name, value, f"at most its start-up value {configured:g} "
                                  "while running (a limit is only tightened at runtime)")
        self.sup.limits = limits

    def warnings(self) -> list[str]:
        """What is wrong with the stage's input: its rate, a dead band hiding the lateral
        forces."""
        return [w for w in (self.input_rate.mismatch(), self.lateral.warning()) if w]

    @property
    def said(self) -> str:
        """The phase and, if any, why."""
        return f"{self.sup.phase}: {self.sup.reason}" if self.sup.reason else self.sup.phase

    @property
    def ready_to_start(self) -> bool:
        """With ``auto_start``: idle, features have come, and nothing was started yet."""
        return (self.auto_start and self.sup.phase in WAITING and self.sup.command is None
                and self.sup.features is not None)  # fmt: skip

    def features(self, now: float, peg_in_hole: pin.SE3 | None, stamp: float | None = None
                 ) -> pin.SE3 | None:  # fmt: skip
        """The peg's measured pose in {H} (None: unreadable, a fault while inserting), sampled
        at ``stamp``; returns a new command pose if they move one (the retract after a fault),
        else None. Raises :class:`~fbcc_ros.core.errors.InputError` for a peg tilted 90° or
        more."""
        if peg_in_hole is None:
            self.sup.on_features(now, [float("nan")] * 5)
            return None
        return self.pose(self.sup.on_features(now, self.features_of(peg_in_hole), stamp))

    def pose(self, command: FloatArray | None) -> pin.SE3 | None:
        """The peg's pose in {H} for command features (None for None)."""
        if command is None:
            return None
        return pin.SE3(*pose_from_features(command, self.nominal.peg_radius))

    def features_of(self, peg_in_hole: pin.SE3) -> FloatArray:
        """The features of a peg pose in {H}, read with the nominal radius (the measured pose,
        or a command this stage gave)."""
        radius = self.nominal.peg_radius
        return features_from_pose(peg_in_hole.rotation, peg_in_hole.translation, radius)

    def wrench(self, now: float, stamp: float, wrench: ArrayLike) -> pin.SE3 | None:
        """One control period on the compensated wrench sampled at ``stamp``: the command as
        the peg's pose in {H} (the held one outside an insertion; None before the first)."""
        self.input_rate.sample(stamp)
        self.response = response_from_wrench(wrench, self.acting_point)
        if self.lateral.sample(self.response) and self.sup.active:
            self.sup.fault(f"blind: {self.lateral.warning()}", now)
        command = self.sup.on_response(now, self.response, stamp)
        self._periods += 1
        self._feed_state(stamp)
        return self.pose(command)

    def _feed_state(self, stamp: float) -> None:
        """Hand the contact-state filter this period's sample if its feed takes it; a new
        insertion starts a new filter."""
        feed, worker = self.state_feed, self.state_worker
        active = self.sup.active
        if feed is None or self.response is None:
            return
        if active and not self._was_active:
            feed.start_insertion()
            if worker is not None:
                worker.start_insertion()
        self._was_active = active
        features = self.sup.features
        if active and features is not None:
            sample = feed.take(features, self.response)
            if sample is not None and worker is not None:
                worker.put(stamp, sample)

    def start_state_worker(self) -> bool:
        """Start the contact-state filter's process (once someone listens); whether it runs."""
        if self.state_feed is not None and self.state_worker is None:
            self.state_worker = StateWorker(self.nominal, self.state_stiffness)
        return self.state_worker is not None

    def state_estimates(self, most: int) -> list[list[float]]:
        """At most ``most`` of the filter's answers come since the last call, oldest first:
        each the stamp of the sample it follows, then P(state) of XOZ and of YOZ over
        ``segmentation.STATES``."""
        if self.state_worker is None:
            return []
        return _state_rows(self.state_worker.answers(most))

    def drain_state_estimates(self) -> tuple[list[list[float]], int]:
        """Stopping: every answer still owed, waited for (``StateWorker.drain``), as
        :meth:`state_estimates` gives them, and how many were owed."""
        worker = self.state_worker
        if worker is None or not worker.alive or not worker.behind:
            return [], 0
        owed = worker.behind
        return _state_rows(worker.drain()), owed

    def close(self) -> None:
        """Stop the contact-state filter's process."""
        if self.state_worker is not None:
            self.state_worker.close()

    def estimate(self, stamp: float) -> list[float] | None:
        """The robust law's contact estimate (``identification.ESTIMATE_FIELDS``, the stamp
        first) every ``estimate_every`` periods while inserting; else None."""
        law = self.sup.law
        if not (self.robust and self.sup.active and self._periods % self.estimate_every == 0):
            return None
        assert isinstance(law, RobustFbcc)
        return [stamp, *law.estimate(0).as_row(law.guard_trips(0))]

    def noise(self, wrench_std: ArrayLike) -> str:
        """The compensated wrench's noise floor the compensation measured (its tare: the
        standard deviation of each component of the wire wrench, {H} origin; it comes with the
        tare, before an insertion); the robust law takes the components noisier than it was
        told (``RobustFbcc.take_noise``). Returns what it did, or ``""``."""
        law = self.sup.law
        if not isinstance(law, RobustFbcc):
            return ""
        # response = B wrench (linear): the components' variances add through B²
        basis = np.eye(6)
        b = np.column_stack([response_from_wrench(e, self.acting_point) for e in basis])
        std = np.sqrt(b**2 @ np.asarray(wrench_std, dtype=float) ** 2)
        if not law.take_noise(std):
            return ""
        law.prepare(self.sup.dt)
        return ("the robust law takes the measured noise (Fx, Fy, Fz, Mx, My) "
                f"{np.round(law.params.sensor_noise, 4).tolist()}: noisier than it was told")

    def contact_state(self) -> str | None:
        """The boundary mapping's state per plane of the last response, ``xoz/yoz``, while
        inserting (~50 µs: ask only for a listener)."""
        if self.response is None or self.sup.features is None or not self.sup.active:
            return None
        xoz, yoz = response_state(self.response, self.sup.features[2], self.nominal)
        return f"{xoz}/{yoz}"


def _state_rows(answers: list[tuple[float, FloatArray]]) -> list[list[float]]:
    """The filter's answers as rows: the stamp, then P(state) per plane."""
    return [[stamp, *p.ravel().tolist()] for stamp, p in answers]
