"""fbcc_bringup: the whole hardware-free cell, one assembly, a summary, an exit status.

    fbcc_bringup [SCENARIO.yaml] [--law fbcc|admittance|none] [--out DIR] [--draw-geometry]
                 [--seed N] [--processes] [--bag FOLDER | --no-record]
    fbcc_bringup [SCENARIO.yaml] --calibration-motion [--poses N] [--out DIR] [--bag FOLDER]

Starts the four nodes (mock_cell, dynamic_compensation, kinematics, fbcc_controller) in one
process on rclpy's EventsExecutor, or with ``--processes`` each in its own process, over real
DDS. The compensation tares the sensor (no contact yet), then the insertion is started through
the controller's ``fbcc/start`` service, and the cell runs for the scenario's duration (longer
for a starved insertion: :mod:`fbcc_ros.harness.insertion_time`). The
true features and responses the mock publishes (``mock_cell/truth``) are scored exactly as
``fbcc-sim`` scores a simulation; the summary (with the CPU each node used) is printed and
written to DIR/summary.json. The session is recorded (``fbcc_record``, in its own process so
its disk writes stay off the loop's core) into ``DIR/bags/fbcc_<date>_<time>`` (``./bags/...``
without ``--out``), or into ``--bag``; the insertion starts only once the recorder hears every
topic, and the summary says what the bag holds. Exit status 0 when the assembly succeeded, 1
when it did not (or the controller faulted), 2 on bad input or a cell that does not come up.
With ``--fault NAME`` the run is a fault drill (:mod:`fbcc_ros.harness.fault_drill`): exit 0
when the cell ended safe with the outcome the fault calls for, 1 otherwise. With
``--calibration-motion`` the mock's arm moves through calibration poses instead, recorded, and
``fbcc-calibrate`` fits its wrist sensor's payload and bias from the bag
(:mod:`fbcc_ros.harness.calibration_run`): exit 0 when the fit was accepted.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.bag.writer import check_new_folder
from fbcc_ros.core.errors import FbccError, InputError, command
from fbcc_ros.core.param_files import file_parameters
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.plants.spec import PLANTS
from fbcc_ros.core.sim.simulation import score
from fbcc_ros.harness.cell_nodes import CellSetup, deadband_warnings, on_plant_clock, profile_of
from fbcc_ros.harness.cell_nodes import cell_nodes as harness_cell_nodes
from fbcc_ros.harness.cell_run import CellRun, NodeSpec
from fbcc_ros.harness.fault_drill import DRILLS, describe, run_drill
from fbcc_ros.harness.insertion_time import progress_line, spin_insertion
from fbcc_ros.nodes.fbcc_record import CELL_TOPICS, default_folder
from fbcc_ros.ros import topics

DEFAULT_SCENARIO = "config/scenarios/bringup_interference.yaml"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fbcc_bringup", description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO)
    parser.add_argument("--law", choices=("fbcc", "admittance", "none"), default=None)
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for summary.json (and the node logs with --processes)")
    parser.add_argument(
        "--draw-geometry", action="store_true", help="true radii drawn from Table II's tolerances"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plant", choices=PLANTS, default="", help="the mock cell's contact: "
                        "model (eq. 5-13) or mujoco (docs/plant.md); default: the scenario's")
    parser.add_argument("--processes", action="store_true",
                        help="each node in its own process (as ros2 run would start them)")
    record = parser.add_mutually_exclusive_group()
    record.add_argument("--bag", type=Path, default=None,
                        help="bag folder to record into (new or empty; default "
                        "DIR/bags/fbcc_<date>_<time>)")  # fmt: skip
    record.add_argument("--no-record", action="store_true", help="do not record a bag")
    parser.add_argument(
        "--fault",
        metavar="NAME",
        default=None,
        help="a fault drill: inject the fault NAME into the running cell and say whether it "
        "ended safe (exit 0) or not (1); 'list' lists them",
    )
    calibration = parser.add_argument_group("a calibration motion")
    calibration.add_argument(
        "--calibration-motion",
        action="store_true",
        help="instead of an assembly: move the mock's arm through calibration poses, its "
        "wrist F/T sensor carrying the tool, record the joint states and the readings, and fit "
        "the payload and bias from the bag with fbcc-calibrate (as a real cell would)",
    )
    calibration.add_argument(
        "--poses", type=int, default=12, metavar="N",
        help="how many poses the motion holds (3 to 30; default 12)")  # fmt: skip
    parser.add_argument(
        "--wait-for-recorder",
        action="store_true",
        help="with --no-record: before the insertion, wait (up to 30 s) until an fbcc_record "
        "started on its own subscribes every topic the bringup would record",
    )
    return parser


#: The controller's stale-input timeout in one process, chained (no DDS, no queue between them),
#: is this stall of the machine's beyond one period of the cell's rate (a 100 Hz input is 10 ms
#: old before anything stalls; docs/safety.md): 50 ms tells a dead input sooner, and the fault
#: drills are measured with it. As processes (--processes, ros2 run, ros2 launch) the default,
#: 0.25 s, rides over the stalls of four processes on two cores.
IN_PROCESS_STALL = 0.05


def cell_nodes(
    path: str,
    sc: Any,
    law: str,
    draw_geometry: bool = False,
    seed: int = 0,
    processes: bool = False,
    plant: str = "",
) -> list[NodeSpec]:
    """The four nodes of the hardware-free cell (:mod:`fbcc_ros.harness.cell_nodes`, as the
    launch file starts them, with the mock playing the stack of the scenario's ``robot``
    section), with the bringup's own: the drawn geometry, the seed, the timeout of processes."""
    from fbcc_ros.nodes.dynamic_compensation import DynamicCompensationNode
    from fbcc_ros.nodes.fbcc_controller import FbccControllerNode
    from fbcc_ros.nodes.kinematics import KinematicsNode
    from fbcc_ros.nodes.mock_cell import MockCellNode

    factories = {"mock_cell": MockCellNode, "dynamic_compensation": DynamicCompensationNode,
                 "kinematics": KinematicsNode, "fbcc_controller": FbccControllerNode}
    own: dict[str, dict[str, Any]] = {"mock_cell": {"draw_geometry": draw_geometry, "seed": seed},
           "fbcc_controller": {"law": law, **({} if processes else
                                              {"timeout": IN_PROCESS_STALL + 1 / sc.rate_hz})}}
    setup = CellSetup(profile_of(sc.cell.conventions), path, namespace=sc.cell.namespace,
                      plant=plant)  # fmt: skip
    nodes = harness_cell_nodes(setup)
    for said in deadband_warnings(nodes):
        print(f"WARNING: {said}", flush=True)
    return [NodeSpec(node.name, factories[node.name],
                     {**node.parameters, **own.get(node.name, {})}, files=node.files,
                     namespace=sc.cell.namespace)
            for node in nodes]  # fmt: skip


def recorded_topics(conventions: str, arm_sensing: bool = False) -> list[str]:
    """What the bringup records: the cell's topics but the three computed only while heard
    (``fbcc-report`` derives both contact states from the recorded wrench and features, the
    deviation filter's to the last digit; replay and report do not use the TCP command;
    recording the first two cost the loop ~7 % of its cycles, the filter's child process
    0.04-0.09 of a core in the cell's nodes and a p99 of 3-4 ms instead of 0.8-0.9 ms);
    beside the LBR stack, its command in place of ours; where the mock plays the arm's own
    sensing, the external torques a virtual sensor may read (published only while heard) and,
    beside the LBR stack, its estimated wrench."""
    skip: tuple[str, ...] = (topics.CONTACT_STATE, topics.CONTACT_STATE_ESTIMATE,
                             topics.TCP_COMMAND)
    lbr = conventions == "lbr"
    if lbr:
        skip += (topics.JOINT_COMMAND,)
    stack = [topics.LBR_COMMAND] if lbr else []
    if arm_sensing:
        stack += [topics.EXTERNAL_TORQUES, *([topics.LBR_WRENCH] if lbr else [])]
    return [t for t in CELL_TOPICS if t not in skip] + stack


def recorder(bag: Path, recorded: list[str], namespace: str = "") -> NodeSpec:
    """The cell's recorder, in its own process, writing ``recorded`` into ``bag``."""
    from fbcc_ros.nodes.fbcc_record import FbccRecordNode

    return NodeSpec("fbcc_record", FbccRecordNode, {"out": str(bag), "topics": recorded},
                    own_process=True, namespace=namespace)  # fmt: skip


def wait_recording(run: CellRun, timeout: float, recorded: list[str]) -> None:
    """Waits until the recorder subscribes every topic of ``recorded``, and, for the nodes in
    this process, until their publishers have matched it: a subscription seen in the graph is
    not yet matched by the publisher, and what it publishes meanwhile is lost (the first 30 ms
    of commands, once). Nothing of the insertion is lost."""
    names = [run.observer.resolve_topic_name(t) for t in recorded]
    graph = run.observer.get_subscriptions_info_by_topic
    publishers = [p for node in run.nodes.values() for p in node.publishers
                  if p.topic_name in names]  # fmt: skip

    def missing() -> list[str]:
        unseen = [n for n in names if all(s.node_name != "fbcc_record" for s in graph(n))]
        unmatched = [p.topic_name for p in publishers
                     if p.get_subscription_count() < len(graph(p.topic_name))]  # fmt: skip
        return unseen + unmatched

    # Not spinning meanwhile (discovery and matching run on DDS's threads): the nodes in this
    # process do not tick yet, so the bag holds the sensor's taring from its first sample.
    deadline = time.monotonic() + timeout
    while missing():
        run.check_alive()
        if time.monotonic() > deadline:
            raise FbccError(f"the recorder did not subscribe within {timeout:.0f} s: "
                            f"{missing()} not recorded")  # fmt: skip
        time.sleep(0.02)


def write_parameters(bag: Path, specs: list[NodeSpec]) -> None:
    """The nodes' parameters beside the bag (``fbcc_params.yaml``, ros__parameters form: their
    files' and the values over them), for the offline replay: the whole configuration."""
    import yaml

    from fbcc_ros.bag.offline import PARAMS_FILE

    class Plain(yaml.SafeDumper):  # no &anchors: rcl's YAML parser does not take them
        def ignore_aliases(self, data: Any) -> bool:
            return True

    doc = {s.name: {"ros__parameters": {**file_parameters(s.files, s.name), **s.parameters}}
           for s in specs if not s.own_process}  # the profile's too: the whole configuration
    (bag / PARAMS_FILE).write_text(yaml.dump(doc, Dumper=Plain, sort_keys=False))


def bag_contents(bag: Path) -> dict[str, Any]:
    """What the recorded bag holds, read back: path, messages per topic, truncated or not."""
    from fbcc_ros.bag.reader import metadata_counts, read_bag

    recorded = read_bag(bag)
    messages = {topic: recorded.counts[topic] for topic in recorded.topics}
    return {"path": str(bag), "messages": messages, "truncated": recorded.truncated,
            "metadata_counts": metadata_counts(bag)}  # fmt: skip


def start_insertion(run: CellRun, timeout: float) -> None:
    """Waits for the tared sensor and the features, then starts through ``fbcc/start``.

    A service response can be lost while DDS is still matching the client (seen once here):
    the latched phase then says whether the request got through, and the call is repeated.
    A refusal is repeated too, half a second later: with each node its own process, a start-up
    hiccup of the kinematics left the controller without recent features once in CI.
    """
    counts = run.observer.counts
    run.spin_until(lambda: counts["compensated"] > 0 and counts["features"] > 0, timeout,
                   "the cell did not come up (no compensated wrench or no features)")  # fmt: skip
    refused = ""
    for _ in range(3):
        try:
            answer = run.call(run.observer.start_client, timeout=5.0)
        except FbccError:
            answer = None
        if run.observer.phase == "inserting" or (answer is not None and answer.success):
            return
        if answer is not None:
            refused = answer.message
            run.spin_for(0.5, lambda _: None)
    if refused:
        raise FbccError(f"could not start: {refused}")
    raise FbccError("no answer from fbcc/start, three times")


def run_cell(
    scenario_path: str,
    law: str,
    draw_geometry: bool = False,
    seed: int = 0,
    processes: bool = False,
    log_dir: Path | None = None,
    bag: Path | None = None,
    wait_for_recorder: bool = False,
    fault: str | None = None,
    plant: str = "",
) -> dict[str, Any]:
    """One assembly through the ROS graph, recorded into ``bag`` if given (or, with
    ``wait_for_recorder``, by an fbcc_record started on its own, waited for), with the fault
    drill ``fault`` if given (:mod:`fbcc_ros.harness.fault_drill`); returns the summary (with
    CPU per node, what the bag holds, and the drill's result)."""
    path = str(scenario_io.find(scenario_path))
    sc = scenario_io.load(path)
    specs = cell_nodes(path, sc, law, draw_geometry, seed, processes, plant)
    plant_clock = on_plant_clock(sc, plant)  # the mock is the cell's clock
    recorded = recorded_topics(sc.cell.conventions, sc.cell.source != "ft_sensor")
    if bag is not None:
        specs.append(recorder(bag, recorded, sc.cell.namespace))
    with CellRun(specs, processes=processes, log_dir=log_dir, namespace=sc.cell.namespace,
                 command_topic=topics.joint_command(sc.cell.conventions)) as run:
        if bag is not None or wait_for_recorder:
            wait_recording(run, 30.0, recorded)
        start_insertion(run, timeout=30.0 if processes else 10.0)
        obs = run.observer
        first = len(obs.truth)
        obs.reset_counts()
        cpu0, t0 = run.cpu(), time.monotonic()

        progress = progress_line(obs, plant_clock)
        if fault:
            watch = run_drill(run, fault, sc, bag, progress)
        else:
            spin_insertion(run, sc.duration, sc.rate_hz, progress, plant_clock)
        elapsed = time.monotonic() - t0
        cpu = {k: (v - cpu0[k]) / elapsed for k, v in run.cpu().items()}
        truth = obs.truth_since(first)
        phase, reason, counts = obs.phase, obs.reason, dict(obs.counts)
    if len(truth) < 2:
        raise FbccError("the mock cell's ground truth did not arrive (mock_cell/truth)")
    t = truth[:, 0]
    if plant_clock:  # the cycles of the plant's time, not of the wall's
        elapsed = t[-1] - t[0] + 1 / sc.rate_hz
    outcome = score(sc, t - t[0], truth[:, 1:6], truth[:, 6:11], phase == "force_limit")
    summary = outcome.summary(0)
    summary.update(
        scenario=sc.name,
        law=law,
        plant=plant or sc.plant.type,
        mode="processes" if processes else "one process",
        phase=phase,
        reason=reason,
        cycles={"samples": len(truth), "expected": round(elapsed * sc.rate_hz), **counts},
        cpu_per_node={k: round(v, 4) for k, v in cpu.items()},
    )
    summary["success"] = bool(summary["success"]) and phase not in ("fault", "aborted")
    if bag is not None:
        write_parameters(bag, specs)
        summary["bag"] = bag_contents(bag)
    if fault:
        summary["fault_drill"] = watch.result(phase, summary.get("bag"))
    return summary


def _drill_said(drill: dict[str, Any]) -> str:
    verdict = "SAFE" if drill["safe"] else "UNSAFE: " + "; ".join(drill["unsafe"])
    if not drill["as_expected"]:
        verdict += "; NOT AS EXPECTED: " + "; ".join(drill["unexpected"])
    return (f"fault drill {drill['name']}: {drill['outcome']} ({drill['reason']}); true |f| "
            f"≤ {drill['peak_force']:.1f} N (limit {drill['force_limit']:g}), |m| ≤ "
            f"{drill['peak_moment']:.2f} N·m (limit {drill['moment_limit']:g}); largest joint "
            f"step {drill['joint_step']:.2f} of a period's travel; {_bag_said(drill)} — {verdict}")


def _bag_said(drill: dict[str, Any]) -> str:
    bag = drill["bag"]
    if bag is None:
        return "no bag"
    held = "as its metadata counts" if bag["consistent"] else "NOT as its metadata counts"
    return f"bag {'complete' if bag['complete'] else 'cut short'}, holding {held}"


@command("fbcc_bringup")
def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.calibration_motion:
        from fbcc_ros.harness.calibration_run import bringup_calibration

        return bringup_calibration(args)
    if args.fault == "list":
        print(describe())
        return 0
    if args.fault is not None:
        if args.fault not in DRILLS:
            raise InputError("--fault", args.fault, f"one of {list(DRILLS)} or list")
        if args.fault == "disk-full" and args.no_record:
            raise InputError("--fault", args.fault, "a recorded run (without --no-record)")
    if args.seed < 0:
        raise InputError("--seed", args.seed, "an integer >= 0")
    if args.wait_for_recorder and not args.no_record:
        raise InputError("--wait-for-recorder", True, "with --no-record (a recorder of "
                         "your own; the bringup's own is always waited for)")  # fmt: skip
    sc = scenario_io.load(scenario_io.find(args.scenario))
    law = args.law or sc.laws[0]
    print(
        f"fbcc_bringup: {sc.name}, law {law}, {sc.duration:.1f} s at {sc.rate_hz:.0f} Hz "
        f"(mock cell on the {args.plant or sc.plant.type} plant, compensation, kinematics, "
        "controller over DDS, "
        f"{'one process each' if args.processes else 'in one process'})",
        flush=True,
    )
    logs = args.out / "logs" if args.out else None
    bag = None if args.no_record else args.bag or default_folder(args.out or Path("."))
    if bag is not None:
        check_new_folder(bag)
        print(f"recording into {bag}", flush=True)
    summary = run_cell(args.scenario, law, args.draw_geometry, args.seed, args.processes,
                       logs, bag, args.wait_for_recorder, args.fault, args.plant)  # fmt: skip
    final = summary["final_features"]
    print(
        f"{'assembled' if summary['success'] else 'NOT assembled'}: phase {summary['phase']}"
        f"{' (' + summary['reason'] + ')' if summary['reason'] else ''}; final depth "
        f"{final['l'] * 1e3:.3f} mm, dx {final['dx'] * 1e6:.1f} µm, theta_y "
        f"{np.degrees(final['theta_y']):.3f}°; peak Fz {summary['peak_fz']:.1f} N; "
        f"{summary['cycles']['commands']}/{summary['cycles']['expected']} commands"
    )
    cpu = ", ".join(f"{k} {v:.0%}" for k, v in summary["cpu_per_node"].items())
    print(f"CPU (share of one core): {cpu}")
    if "bag" in summary:
        recorded = summary["bag"]
        cut = f" (TRUNCATED: {recorded['truncated']})" if recorded["truncated"] else ""
        print(f"recorded {sum(recorded['messages'].values())} messages on "
              f"{len(recorded['messages'])} topics into {recorded['path']}{cut}")  # fmt: skip
    drill = summary.get("fault_drill")
    if drill:
        print(_drill_said(drill))
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        print(f"wrote {args.out / 'summary.json'}")
    if drill:
        return 0 if drill["safe"] and drill["as_expected"] else 1
    return 0 if summary["success"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
