"""Fault drills: one fault injected into the running hardware-free cell, and whether the cell
ended safe (``fbcc_bringup SCENARIO --fault NAME``).

A drill starts the insertion as the bringup does, lets it run :data:`INJECT_AT` seconds (the peg
is in the hole by then), injects its fault the way it would happen on a real cell — through the
mock sensor's ``sensor_fault`` parameter, a node killed and started anew, a parameter set over
its service, a request to the controller, a file-size limit on the recorder's process — and
watches the cell for the scenario's duration more. Drills whose fault passes (a node back up) first
do what an operator would: ``reset`` and ``start``, and the insertion goes on from where the arm
is.

What it reports (:meth:`DrillWatch.result`, the summary's ``fault_drill``):

* ``outcome``: ``refused`` (a request the drill made was refused: a parameter, a start, a tare),
  else the controller's last phase: ``held`` (fault or force limit, holding), ``aborted``, or
  ``recovered`` (inserting or inserted: the fault passed, with or without a reset);
* ``reason``: the refusal, or the first fault the controller reported after the injection;
* the largest true contact force |f| and moment |m| (the mock's ground truth) against the
  wrench guard's limits, and the largest joint-command step as a fraction of one period at the
  joint velocity limits (:class:`StepMeter`);
* whether the bag is complete and consistent (read back: its metadata counts what the file
  holds).

``safe`` (exit status 0) when no limit was exceeded and the bag is complete and consistent — for
``disk-full``, cut at its last flushed chunk and consistent (nothing flushed is lost).
"""

from __future__ import annotations

import dataclasses
import resource
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from std_msgs.msg import Float64MultiArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation.wrench_guard import GuardLimits
from fbcc_ros.core.sim.sensor_faults import SENSOR_FAULTS
from fbcc_ros.ros import topics
from fbcc_ros.ros.convert import positions_from_cdr

#: Seconds of insertion before the fault: the peg is a few millimetres into the hole.
INJECT_AT = 1.0
#: Seconds a fault that passes is left before the drill resets and starts again: long enough
#: to show the hold.
HOLD_FOR = 0.5
#: The recorder's file may grow this much past its size at the injection [bytes]: less than a
#: chunk, so the next chunk's write fails.
DISK_LEFT = 64 * 1024


class StepMeter:
    """The largest joint-command step, as a fraction of what the joint velocity limits allow
    in the time between two commands (one period, or as many whole periods as passed between
    their arrivals: a dropped command leaves the arm two periods for the next).

    Args:
        node: The node to subscribe ``joint_command`` on.
        velocity_limit: The joints' velocity limits [rad/s].
        dt: The control period [s].
    """

    def __init__(self, node: Any, velocity_limit: FloatArray, dt: float) -> None:
        self.limit = np.asarray(velocity_limit, dtype=float) * dt
        self.dt = dt
        self.worst = 0.0
        self._last: tuple[float, FloatArray] | None = None
        node.create_subscription(Float64MultiArray, topics.JOINT_COMMAND, self.on_command, 100,
                                 raw=True)  # fmt: skip

    def on_command(self, data: bytes) -> None:
        now, q = time.monotonic(), positions_from_cdr(data)
        if self._last is not None and q.shape == self._last[1].shape:
            periods = max(1, round((now - self._last[0]) / self.dt))
            step = float(np.max(np.abs(q - self._last[1]) / (self.limit * periods)))
            self.worst = max(self.worst, step)
        self._last = (now, q)


@dataclasses.dataclass
class DrillWatch:
    """What a drill did and saw while the cell ran (filled by the drill's steps)."""

    name: str
    refused: list[str] = dataclasses.field(default_factory=list)
    said: list[str] = dataclasses.field(default_factory=list)  # what the drill did
    faults: list[str] = dataclasses.field(default_factory=list)  # phases with a reason
    rejected: dict[str, int] = dataclasses.field(default_factory=dict)
    reports: list[str] = dataclasses.field(default_factory=list)  # what the nodes warned of
    injected_at: float = 0.0  # system time [s]

    def outcome(self, phase: str) -> str:
        if self.refused:
            return "refused"
        if phase in ("fault", "force_limit", "idle"):
            return "held"
        return "aborted" if phase == "aborted" else "recovered"

    def result(
        self,
        phase: str,
        truth: FloatArray,
        joint_step: float,
        guard: GuardLimits,
        bag: dict[str, Any] | None,
    ) -> dict[str, Any]:
        """The summary's ``fault_drill``: ``truth`` the mock's rows since the start
        (``topics.TRUTH_FIELDS``)."""
        force = float(np.max(np.linalg.norm(truth[:, 6:9], axis=1))) if len(truth) else 0.0
        moment = float(np.max(np.linalg.norm(truth[:, 9:11], axis=1))) if len(truth) else 0.0
        unsafe = []
        if force > guard.force_limit:
            unsafe.append(f"true |f| {force:.1f} N over {guard.force_limit:g} N")
        if moment > guard.moment_limit:
            unsafe.append(f"true |m| {moment:.2f} N·m over {guard.moment_limit:g} N·m")
        if joint_step > 1.0:
            unsafe.append(f"a joint-command step {joint_step:.2f} × the velocity limit's")
        recorded = None
        if bag is not None:  # a full disk cuts the bag: what it holds must be what it counts
            recorded = {"complete": not bag["truncated"],
                        "consistent": bag["metadata_counts"] == bag["messages"]}  # fmt: skip
            if not recorded["consistent"]:
                unsafe.append("the bag's metadata counts other messages than its file holds")
            if bag["truncated"] and self.name != "disk-full":
                unsafe.append(f"the bag is cut short: {bag['truncated']}")
        outcome = self.outcome(phase)
        reason = (self.refused or self.faults or self.reports or [f"no fault; phase {phase}"])[0]
        return {
            "name": self.name,
            "what": DRILLS[self.name].what,
            "outcome": outcome,
            "reason": reason,
            "steps": self.said,
            "faults": self.faults,
            "rejected": self.rejected,
            "reports": self.reports,
            "final_phase": phase,
            "peak_force": round(force, 2),
            "force_limit": guard.force_limit,
            "peak_moment": round(moment, 3),
            "moment_limit": guard.moment_limit,
            "joint_step": round(joint_step, 3),
            "bag": recorded,
            "injected_at": self.injected_at,
            "safe": not unsafe,
            "unsafe": unsafe,
        }


@dataclasses.dataclass(frozen=True)
class Drill:
    """A fault and how it is injected: ``inject(run, watch, bag)`` on the running cell; with
    ``resume`` the drill then resets and starts again after :data:`HOLD_FOR`."""

    what: str
    inject: Callable[[Any, DrillWatch, Path | None], None]
    resume: bool = False


def _sensor(name: str) -> Callable[[Any, DrillWatch, Path | None], None]:
    def inject(run: Any, watch: DrillWatch, bag: Path | None) -> None:
        _set(run, watch, "mock_cell", "sensor_fault", name)

    return inject


def _set(run: Any, watch: DrillWatch, node: str, name: str, value: Any) -> None:
    """Sets a parameter over the node's service, as ``ros2 param set`` would."""
    ok, reason = set_parameter(run, node, name, value)
    watch.said.append(f"ros2 param set /{node} {name} {value}: "
                      f"{'accepted' if ok else 'refused: ' + reason}")  # fmt: skip
    if not ok:
        watch.refused.append(f"{node} {name} {value} refused: {reason}")


def set_parameter(run: Any, node: str, name: str, value: Any) -> tuple[bool, str]:
    """One parameter of ``node`` set through its ``set_parameters`` service."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter

    client = run.observer.create_client(SetParameters, f"/{node}/set_parameters")
    try:
        run.spin_until(client.service_is_ready, 5.0, f"no parameter service on {node}")
        message = Parameter(name, value=value).to_parameter_msg()
        future = client.call_async(SetParameters.Request(parameters=[message]))
        run.spin_until(future.done, 5.0, f"no answer from {node}/set_parameters")
        result = future.result().results[0]
        return bool(result.successful), result.reason
    finally:
        run.observer.destroy_client(client)


def _restart(name: str, **parameters: Any) -> Callable[[Any, DrillWatch, Path | None], None]:
    def inject(run: Any, watch: DrillWatch, bag: Path | None) -> None:
        t0 = time.monotonic()
        run.restart(name, parameters)
        watch.said.append(f"{name} killed and started anew ({time.monotonic() - t0:.2f} s)")

    return inject


def _compensation_restart(run: Any, watch: DrillWatch, bag: Path | None) -> None:
    """Restarted with the bias it had measured (as an operator passes it from ft_sensor/bias):
    no tare under load."""
    bias = run.nodes["dynamic_compensation"].stage.comp.bias
    _restart("dynamic_compensation", bias=[float(b) for b in bias], tare_samples=0)(
        run, watch, bag)


def _start_after_fault(run: Any, watch: DrillWatch, bag: Path | None) -> None:
    _set(run, watch, "mock_cell", "sensor_fault", "force-spike")
    run.spin_until(lambda: run.observer.phase in ("fault", "force_limit"), 2.0,
                   "no fault after the force spike")  # fmt: skip
    _call(run, watch, "start")


def _call(run: Any, watch: DrillWatch, service: str) -> bool:
    """``fbcc/<service>`` called; a refusal is recorded."""
    client = getattr(run.observer, f"{service}_client")
    answer = run.call(client, timeout=5.0)
    watch.said.append(f"fbcc/{service}: {'ok' if answer.success else 'refused'}: "
                      f"{answer.message}")  # fmt: skip
    if not answer.success:
        watch.refused.append(f"fbcc/{service} refused: {answer.message}")
    return bool(answer.success)


def _disk_full(run: Any, watch: DrillWatch, bag: Path | None) -> None:
    """The recorder's process may write only :data:`DISK_LEFT` bytes more into any file: its
    next chunk fails as on a full disk (EFBIG; Python ignores SIGXFSZ)."""
    assert bag is not None, "the bringup refuses disk-full without a bag"
    proc = run.procs["fbcc_record"]
    size = sum(f.stat().st_size for f in Path(bag).glob("*.mcap"))
    _, hard = resource.prlimit(proc.pid, resource.RLIMIT_FSIZE)
    resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (size + DISK_LEFT, hard))
    watch.said.append(f"recorder limited to {(size + DISK_LEFT) / 1e6:.2f} MB of file")


#: The sensor faults that pass, after which the drill resets and starts again: the path comes
#: back (a sensor path blocked for good would leave the start refused).
_PASSING = ("nan-wrench", "future-stamp")

DRILLS: dict[str, Drill] = {
    **{name: Drill(f"sensor: {what}", _sensor(name), resume=name in _PASSING)
       for name, what in SENSOR_FAULTS.items()},
    "compensation-restart": Drill(
        "the compensation node killed and started anew with the bias it had measured",
        _compensation_restart, resume=True),
    "controller-restart": Drill("the controller node killed and started anew",
                                _restart("fbcc_controller"), resume=True),
    "kinematics-restart": Drill("the kinematics node killed and started anew",
                                _restart("kinematics"), resume=True),
    "tare-under-load": Drill(
        "the compensation node started anew with its start-up tare, the peg in the hole",
        _restart("dynamic_compensation"), resume=True),
    "deadband-param": Drill("the compensation's dead band set to [200 N, 20 N·m] while running",
                            lambda run, w, b: _set(run, w, "dynamic_compensation", "deadband",
                                                   [200.0, 20.0])),
    "lowpass-param": Drill("the compensation's low-pass set to 1 Hz while running",
                           lambda run, w, b: _set(run, w, "dynamic_compensation", "lowpass_hz",
                                                  1.0)),
    "max-step-param": Drill("the controller's max_step set to 10 mm (200 times) while running",
                            lambda run, w, b: _set(run, w, "fbcc_controller", "max_step", 0.01)),
    "start-after-fault": Drill("a force spike faults the controller, then start without reset",
                               _start_after_fault),
    "disk-full": Drill("the recorder's disk fills up (its files may not grow)", _disk_full),
}  # fmt: skip


def describe() -> str:
    """``--fault list``: each drill, one line."""
    width = max(map(len, DRILLS))
    return "\n".join(f"{name:{width}s}  {drill.what}" for name, drill in DRILLS.items())


def run_drill(run: Any, name: str, duration: float, bag: Path | None,
              progress: Callable[[float], None]) -> DrillWatch:  # fmt: skip
    """Runs the drill ``name`` on the started cell ``run``, then ``duration`` seconds more (after
    the drill's own reset and start, if it resumes; module doc)."""
    drill = DRILLS[name]
    watch = DrillWatch(name)
    observer = run.observer
    t0 = time.monotonic()

    def clock(_: float) -> None:  # progress on one clock, from the start
        progress(time.monotonic() - t0)

    run.spin_for(INJECT_AT, clock)
    counts = _rejections(run)
    first_phase = len(observer.phases)
    print(f"  fault drill {name}: {drill.what}", flush=True)
    watch.injected_at = time.time()
    drill.inject(run, watch, bag)
    if drill.resume:
        run.spin_for(HOLD_FOR, clock)
        if observer.phase in ("fault", "force_limit"):
            _call(run, watch, "reset")
        if observer.phase not in ("inserting", "inserted") and _call(run, watch, "start"):
            run.spin_until(lambda: observer.phase == "inserting", 2.0, "no phase inserting")
    run.spin_for(duration, clock)  # a resumed insertion has its whole time
    controller = run.nodes.get("fbcc_controller")
    if controller is not None and controller.stage.input_rate.mismatch():
        watch.reports.append(controller.stage.input_rate.mismatch())
    log = run.log_dir / "fbcc_record.log"  # the recorder's own process
    if "fbcc_record" in run.procs and log.exists():
        said = log.read_text(errors="replace").splitlines()
        watch.reports += [line.split("]: ", 1)[-1] for line in said if "recording stopped" in line]
    after = _rejections(run)
    watch.rejected = {k: after[k] - counts.get(k, 0) for k in after
                      if after[k] > counts.get(k, 0)}  # fmt: skip
    watch.faults = [p for p in observer.phases[first_phase:] if ":" in p]
    return watch


def _rejections(run: Any) -> dict[str, int]:
    """The compensation's rejected-sample counts (a restarted node counts from zero)."""
    node = run.nodes.get("dynamic_compensation")
    if node is None:
        return {}
    return {k: v for k, v in node.stage.comp.counts.items() if k not in ("accepted", "taring")}
