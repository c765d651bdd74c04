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

* ``outcome``: ``refused`` (a request the drill made was refused: a parameter, a start), else
  from the controller's last phase: ``held`` (fault or force limit holding; idle, its last
  command held), ``aborted``, or ``recovered`` (inserting or inserted: the fault passed, with or
  without a reset);
* ``reason``: the refusal, else the first fault the controller reported after the injection,
  else what a node warned of (a sensor's rate, the recorder's stop);
* the largest true contact force |f| and moment |m| about the {H} origin (kept by the mock's
  plant at every step, so no sample the loop drops is missed) against the running wrench
  guard's limits, and the largest step between the joint commands the mock arm received, as a
  fraction of one period's travel at the joint velocity limits (a position-controlled arm
  applies each command within a cycle, however long it was in coming);
* holding at the end, how far the arm's measured pose is from the hold;
* whether the bag is complete and consistent (read back: its metadata counts what the file
  holds).

All of it is read from the cell's topics, its nodes' ``/diagnostics`` (the mock's truth, the
guard's limits, the controller's tracking error, the samples rejected) and the bag, so a drill
runs alike with the nodes in this process or each in its own (``--processes``).

``safe`` when no limit was exceeded and the bag is complete and consistent (for ``disk-full``,
cut at its last flushed chunk and consistent); ``as_expected`` when the outcome is the one the
fault calls for (:class:`Drill`) and, for ``disk-full``, the recording was cut. The bringup
exits 0 when both hold.
"""

from __future__ import annotations

import dataclasses
import resource
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fbcc_ros.core.control.phase import ACTIVE, NEEDS_RESET, Phase
from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.sim.sensor_faults import SENSOR_FAULTS
from fbcc_ros.harness import cell_faults as cell
from fbcc_ros.harness.insertion_time import spin_insertion
from fbcc_ros.ros import topics

#: Seconds of insertion before the fault: the peg is a few millimetres into the hole.
INJECT_AT = 1.0
#: Seconds a fault that passes is left before the drill resets and starts again: long enough
#: to show the hold.
HOLD_FOR = 0.5
#: The arm ends within this of its hold [m] (offsets and depth: measured against the hold).
HOLD_TOLERANCE = 5e-5
#: Seconds a drill waits, resetting, for the controller to say it is armed before it starts, as
#: an operator watching it would: a guard re-arms on the reset, then its wrench comes; a node
#: killed and started anew leaves its dead process's endpoints in the graph for up to its DDS
#: lease (3 s, ``ros/fastdds.xml``), a second source the controller will not start beside.
REARM_WAIT = 6.0
#: The nodes whose /diagnostics a drill reads (by name).
MOCK, COMPENSATION, CONTROLLER = "mock_cell", "dynamic_compensation", "fbcc_controller"
#: The recorder's file may grow this much past its size at the injection [bytes]: less than a
#: chunk, so the next chunk's write fails.
DISK_LEFT = 64 * 1024


@dataclasses.dataclass
class DrillWatch:
    """What a drill did and saw while the cell ran (filled by :func:`run_drill`)."""

    name: str
    refused: list[str] = dataclasses.field(default_factory=list)
    said: list[str] = dataclasses.field(default_factory=list)  # what the drill did
    faults: list[str] = dataclasses.field(default_factory=list)  # phases with a reason
    rejected: dict[str, int] = dataclasses.field(default_factory=dict)
    reports: list[str] = dataclasses.field(default_factory=list)  # what the nodes warned of
    injected_at: float = 0.0  # system time [s]
    #: the true contact's largest |f| [N] and |m| about the {H} origin [N·m] (the mock's)
    peak: tuple[float, float] = (0.0, 0.0)
    #: the running wrench guard's limits on |f| [N] and |m| [N·m]
    limits: tuple[float, float] = (0.0, 0.0)
    #: the largest joint-command step the arm received, in periods' travel
    joint_step: float = 0.0
    #: at the end, holding: how far the arm's measured pose is from the held command (the
    #: largest of dx, dy, l) [m]; None when not holding or not known
    hold_error: float | None = None

    def outcome(self, phase: str) -> str:
        if self.refused:
            return "refused"
        if phase == Phase.ABORTED:
            return "aborted"
        return "recovered" if phase in ACTIVE else "held"  # idle: the arm holds its command

    def result(self, phase: str, bag: dict[str, Any] | None) -> dict[str, Any]:
        """The summary's ``fault_drill`` (module doc); ``bag`` the bringup's ``bag``."""
        drill = DRILLS[self.name]
        (force, moment), (force_limit, moment_limit) = self.peak, self.limits
        joint_step = self.joint_step
        unsafe = []
        if force > force_limit:
            unsafe.append(f"true |f| {force:.1f} N over {force_limit:g} N")
        if moment > moment_limit:
            unsafe.append(f"true |m| {moment:.2f} N·m over {moment_limit:g} N·m")
        if joint_step > 1.0:
            unsafe.append(f"a joint-command step {joint_step:.2f} times one period's travel")
        if self.hold_error is not None and self.hold_error > HOLD_TOLERANCE:
            unsafe.append(f"the arm {self.hold_error * 1e3:.3f} mm from its hold (at most "
                          f"{HOLD_TOLERANCE * 1e3:g} mm)")  # fmt: skip
        recorded = None
        if bag is not None:  # a full disk cuts the bag: what it holds must be what it counts
            recorded = {"complete": not bag["truncated"],
                        "consistent": bag["metadata_counts"] == bag["messages"]}  # fmt: skip
            if not recorded["consistent"]:
                unsafe.append("the bag's metadata counts other messages than its file holds")
            if bag["truncated"] and not drill.cuts_bag:
                unsafe.append(f"the bag is cut short: {bag['truncated']}")
        outcome = self.outcome(phase)
        unexpected = []
        if outcome != drill.expected:
            unexpected.append(f"outcome {outcome}, where this fault calls for {drill.expected}")
        if drill.cuts_bag and (recorded is None or recorded["complete"]):
            unexpected.append("the recording was not cut: the fault did not take")
        reason = (self.refused or self.faults or self.reports or [f"no fault; phase {phase}"])[0]
        return {
            "name": self.name,
            "what": drill.what,
            "outcome": outcome,
            "expected": drill.expected,
            "as_expected": not unexpected,
            "unexpected": unexpected,
            "reason": reason,
            "steps": self.said,
            "faults": self.faults,
            "rejected": self.rejected,
            "reports": self.reports,
            "final_phase": phase,
            "peak_force": round(force, 2),
            "force_limit": force_limit,
            "peak_moment": round(moment, 3),
            "moment_limit": moment_limit,
            "joint_step": round(joint_step, 3),
            "hold_error": None if self.hold_error is None else round(self.hold_error, 7),
            "bag": recorded,
            "injected_at": self.injected_at,
            "safe": not unsafe,
            "unsafe": unsafe,
        }


@dataclasses.dataclass(frozen=True)
class Drill:
    """A fault, how it is injected (``inject(run, watch, bag)`` on the running cell) and the
    outcome it calls for; with ``resume`` the drill then resets and starts again after
    :data:`HOLD_FOR`; ``cuts_bag``: the fault ends the recording early."""

    what: str
    inject: Callable[[Any, DrillWatch, Path | None], None]
    expected: str
    resume: bool = False
    cuts_bag: bool = False


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
        message = Parameter(name, value=value).to_parameter_msg()
        result = run.call(client, 5.0, SetParameters.Request(parameters=[message])).results[0]
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
    bias = cell.bias(run)[0]
    _restart("dynamic_compensation", bias=[float(b) for b in bias], tare_samples=0)(
        run, watch, bag)


def _start_after_fault(run: Any, watch: DrillWatch, bag: Path | None) -> None:
    _set(run, watch, "mock_cell", "sensor_fault", "force-spike")
    run.spin_until(lambda: run.observer.phase in NEEDS_RESET, 2.0,
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


#: What each sensor fault calls for: a guard trip or a stale input holds; the faults that pass
#: are then reset and started again, and the path must come back (a sensor path blocked for
#: good would leave the start refused); a slow sensor or a burst is not a fault.
_SENSOR_EXPECTED = {"moment-spike": "held", "force-spike": "held", "stale-wrench": "held",
                    "nan-wrench": "recovered", "future-stamp": "recovered",
                    "slow-sensor": "recovered", "sensor-burst": "recovered"}  # fmt: skip

DRILLS: dict[str, Drill] = {
    **{name: Drill(f"sensor: {what}", _sensor(name), _SENSOR_EXPECTED[name],
                   resume=name in ("nan-wrench", "future-stamp"))
       for name, what in SENSOR_FAULTS.items()},
    "compensation-restart": Drill(
        "the compensation node killed and started anew with the bias it had measured",
        _compensation_restart, "recovered", resume=True),
    "controller-restart": Drill("the controller node killed and started anew",
                                _restart("fbcc_controller"), "recovered", resume=True),
    "kinematics-restart": Drill("the kinematics node killed and started anew",
                                _restart("kinematics"), "recovered", resume=True),
    "tare-under-load": Drill(
        "the compensation node started anew with its start-up tare, the peg in the hole",
        _restart("dynamic_compensation"), "refused", resume=True),
    "deadband-param": Drill("the compensation's dead band set to [200 N, 20 N·m] while running",
                            lambda run, w, b: _set(run, w, "dynamic_compensation", "deadband",
                                                   [200.0, 20.0]), "refused"),
    "lowpass-param": Drill("the compensation's low-pass set to 1 Hz while running",
                           lambda run, w, b: _set(run, w, "dynamic_compensation", "lowpass_hz",
                                                  1.0), "refused"),
    "max-step-param": Drill("the controller's max_step set to 10 mm (200 times) while running",
                            lambda run, w, b: _set(run, w, "fbcc_controller", "max_step", 0.01),
                            "refused"),
    "start-after-fault": Drill("a force spike faults the controller, then start without reset",
                               _start_after_fault, "refused"),
    "disk-full": Drill("the recorder's disk fills up (its files may not grow)", _disk_full,
                       "recovered", cuts_bag=True),
    "frozen-kinematics": Drill(f"the kinematics does not run for {cell.FROZEN_FOR:g} s (its "
                               "process stopped), then goes on", cell.frozen("kinematics"),
                               "held"),
    "frozen-compensation": Drill(f"the compensation does not run for {cell.FROZEN_FOR:g} s, then "
                                 "goes on", cell.frozen("dynamic_compensation"), "held"),
    "stray-wrench": Drill(f"a stray node publishes zero wrenches on {topics.RAW_WRENCH} at "
                          f"{cell.STRAY_HZ:g} Hz, stamped {cell.STRAY_AHEAD * 1e3:g} ms ahead",
                          cell.stray(topics.RAW_WRENCH, "wrench"), "held"),
    "stray-joint-states": Drill(f"a stray node publishes joint states on {topics.JOINT_STATES} "
                                f"at {cell.STRAY_HZ:g} Hz, stamped "
                                f"{cell.STRAY_AHEAD * 1e3:g} ms ahead",
                                cell.stray(topics.JOINT_STATES, "joints"), "held"),
    "stray-commander": Drill(f"a stray node commands the arm on {topics.JOINT_COMMAND} (where "
                             f"it is measured) at {cell.STRAY_HZ:g} Hz",
                             cell.stray(topics.JOINT_COMMAND, "command"), "held"),
    "clock-change": Drill("use_sim_time set to true on the running controller (no /clock)",
                          lambda run, w, b: _set(run, w, "fbcc_controller", "use_sim_time", True),
                          "refused"),
    "replay-beside": Drill("fbcc_replay of another session onto the recorded names, beside the "
                           "running cell", cell.replay_beside_drill, "refused"),
}  # fmt: skip


def describe() -> str:
    """``--fault list``: each drill, one line."""
    width = max(map(len, DRILLS))
    return "\n".join(f"{name:{width}s}  {drill.what}" for name, drill in DRILLS.items())


def run_drill(run: Any, name: str, sc: Any, bag: Path | None,
              progress: Callable[[float], None]) -> DrillWatch:  # fmt: skip
    """Runs the drill ``name`` on the started cell ``run``, then the scenario ``sc``'s duration
    more (after the drill's own reset and start, if it resumes; module doc), longer for a
    starved insertion (:mod:`~fbcc_ros.harness.insertion_time`)."""
    drill = DRILLS[name]
    watch = DrillWatch(name)
    observer = run.observer
    t0 = time.monotonic()

    def clock(_: float) -> None:  # progress on one clock, from the start
        progress(time.monotonic() - t0)

    run.spin_for(INJECT_AT, clock)
    if observer.phase != Phase.INSERTING:
        raise FbccError(f"fault drill {name}: the insertion was not running when the fault "
                        f"was due ({stage_said(observer)})")
    counts = _rejections(observer.values(COMPENSATION))
    first_phase = len(observer.phases)
    print(f"  fault drill {name}: {drill.what}", flush=True)
    watch.injected_at = time.time()
    drill.inject(run, watch, bag)
    if drill.resume:
        run.spin_for(HOLD_FOR, clock)
        _resume(run, watch)
    spin_insertion(run, sc.duration, sc.rate_hz, clock)  # a resumed one has its whole time
    run.fresh_status((MOCK, COMPENSATION, CONTROLLER))  # reports that cover the whole run
    mock, comp, controller = (observer.values(n) for n in (MOCK, COMPENSATION, CONTROLLER))
    if controller.get("warnings"):  # a sensor's rate, and the like
        watch.reports.append(controller["warnings"])
    log = run.log_dir / "fbcc_record.log"  # the recorder's own process
    if "fbcc_record" in run.procs and log.exists():
        said = log.read_text(errors="replace").splitlines()
        watch.reports += [line.split("]: ", 1)[-1] for line in said if "recording stopped" in line]
    after = _rejections(comp)  # summed over a restart (the observer's)
    watch.rejected = {k: after[k] - counts.get(k, 0) for k in after
                      if after[k] > counts.get(k, 0)}  # fmt: skip
    watch.faults = [p for p in observer.phases[first_phase:] if ":" in p]
    if observer.phase in (*NEEDS_RESET, Phase.ABORTED):
        watch.hold_error = controller.get("tracking_error")
    watch.peak = (float(mock["true_peak_force"]), float(mock["true_peak_moment"]))
    watch.joint_step = float(mock["largest_command_step"])
    watch.limits = (float(comp["force_limit"]), float(comp["moment_limit"]))
    return watch


def _resume(run: Any, watch: DrillWatch) -> None:
    """What an operator does once the fault has passed: a fault is acknowledged (reset) until
    the controller says it is armed (its ``/diagnostics``), for at most :data:`REARM_WAIT`;
    then, unless the insertion went on by itself, a start."""
    observer = run.observer
    deadline = time.monotonic() + REARM_WAIT
    while observer.phase not in ACTIVE and time.monotonic() < deadline:
        if observer.phase in NEEDS_RESET:
            _call(run, watch, "reset")
        run.fresh_status((CONTROLLER,))
        if observer.values(CONTROLLER).get("armed") is True:
            break
    if observer.phase not in ACTIVE and _call(run, watch, "start"):
        run.spin_until(lambda: observer.phase == Phase.INSERTING, 2.0, "no phase inserting")


def stage_said(observer: Any) -> str:
    """The observed phase, with its reason if any."""
    return f"{observer.phase}: {observer.reason}" if observer.reason else str(observer.phase)


def _rejections(values: dict[str, Any]) -> dict[str, int]:
    """The rejected-sample counts of a compensation node's ``/diagnostics`` values."""
    kept = ("accepted", "taring", "force_limit", "moment_limit")
    return {k: v for k, v in values.items() if isinstance(v, int) and k not in kept}
