"""The hardware-free cell over real DDS: an assembly through the ROS graph against the pure
simulator, and every node started as a process with its YAML file, as ``ros2 run`` would."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.bag.reader import read_bag
from fbcc_ros.core.contact.model import FEATURE_NAMES
from fbcc_ros.core.sim import scenario
from fbcc_ros.core.sim.simulation import simulate
from fbcc_ros.harness.cell_run import CellRun
from fbcc_ros.nodes.bringup import cell_nodes, run_cell, start_insertion
from fbcc_ros.nodes.bringup import main as bringup_main
from fbcc_ros.ros.cdr import decode_string
from test.nodes.conftest import kill_left

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "config" / "scenarios" / "bringup_interference.yaml"
NODES = ("mock_cell", "dynamic_compensation", "kinematics", "fbcc_controller")
#: A live 1 kHz loop over DDS on a shared two-core machine: a CPU stall of the machine (not of
#: the code) can starve one run, so a failed run is repeated, at most twice, and each repeat is
#: reported ("R" in pytest's summary; docs/nodes.md, known limits).
REALTIME = pytest.mark.flaky(reruns=2)


@REALTIME
def test_an_assembly_through_the_ros_graph_agrees_with_the_simulator() -> None:
    """Four nodes in one process on the EventsExecutor, over Fast DDS: the mock cell (joint
    space, IK, a sensor under the hole with a fixture, tared by the compensation) and the pure
    simulator end in the same state with the same peak force. The hole is tilted by 2°: the peg
    ends within 20 µm of the depth along the true axis."""
    sc = scenario.load(SCENARIO)
    outcome, _ = simulate(sc, "fbcc", record=False)
    summary = run_cell(str(SCENARIO), "fbcc")
    why = f"{summary['phase']} {summary['reason']} {summary['cycles']}"
    assert summary["success"] and outcome.success[0], why
    assert summary["phase"] == "inserted" and summary["cycles"]["ik_failures"] == 0, why
    final = np.array([summary["final_features"][k] for k in FEATURE_NAMES])
    expected = outcome.final_features[0]
    np.testing.assert_allclose(final[[0, 1]], expected[[0, 1]], atol=2e-6)  # offsets [m]
    np.testing.assert_allclose(final[2], expected[2], atol=1e-5)  # depth [m]
    assert abs(sc.initial[4]) > 0.03 and abs(final[2] - sc.insertion.depth) <= 2e-5
    np.testing.assert_allclose(final[[3, 4]], expected[[3, 4]], atol=1e-4)  # tilts [rad]
    assert summary["peak_fz"] == pytest.approx(outcome.peak_fz[0], rel=0.05)


@REALTIME
@pytest.mark.parametrize("stiffness", [1e8, 1e9, 1e10])
def test_the_robust_law_through_the_ros_graph_agrees_with_the_simulator(
    tmp_path: Path, stiffness: float
) -> None:
    """The default (robust) law, unchanged, on clearance parts of 0.1, 1 and 10 GPa: the ROS
    cell and fbcc-sim agree on success, depth and tilts. A peg at rest in a clearance has no
    force to hold it at one place: the two cells' offsets are each inside the 10 µm clearance,
    not at the same point of it (they differ by up to 13 µm at 1 GPa, the loops' timing
    differing)."""
    import yaml

    data = yaml.safe_load(SCENARIO.read_text())
    data["geometry"].update(hole_radius=0.00505, stiffness=stiffness)
    data["controller"] = {"type": "fbcc", "params": {"loop_delay": 0.05}}
    data["initial"] = {"dx": 6e-5, "dy": -4e-5, "theta_x": 0.0, "theta_y": 0.0}
    path = tmp_path / "robust.yaml"
    path.write_text(yaml.safe_dump(data))
    sc = scenario.load(path)
    outcome, _ = simulate(sc, "fbcc", record=False)
    summary = run_cell(str(path), "fbcc")
    why = f"{summary['phase']} {summary['reason']} {summary['cycles']}"
    assert summary["success"] == bool(outcome.success[0]) == True, why  # noqa: E712
    final = np.array([summary["final_features"][k] for k in FEATURE_NAMES])
    expected = outcome.final_features[0]
    clearance = sc.geometry.hole_radius - sc.geometry.peg_radius
    for offsets in (final[[0, 1]], expected[[0, 1]]):
        assert np.hypot(*offsets) <= clearance + 0.5e-6, (final, expected)  # contact: < 0.5 µm
    np.testing.assert_allclose(final[2], expected[2], atol=1e-5)  # depth [m]
    np.testing.assert_allclose(final[[3, 4]], expected[[3, 4]], atol=1.75e-3)  # tilts [rad]


@REALTIME
def test_an_assembly_with_each_node_in_its_own_process() -> None:
    """``fbcc_bringup --processes``: the nodes as ``python -m fbcc_ros.nodes.<node>`` processes,
    started through the ``fbcc/start`` service, scored from ``mock_cell/truth``. The loop is
    slower here (latency of several periods on two cores), so only the end state and the peak
    force are compared with the simulator."""
    sc = scenario.load(SCENARIO)
    outcome, _ = simulate(sc, "fbcc", record=False)
    summary = run_cell(str(SCENARIO), "fbcc", processes=True)
    why = f"{summary['phase']} {summary['reason']} {summary['cycles']}"
    assert summary["success"] and summary["mode"] == "processes", why
    final = np.array([summary["final_features"][k] for k in FEATURE_NAMES])
    np.testing.assert_allclose(final[[0, 1]], outcome.final_features[0][[0, 1]], atol=2e-6)
    np.testing.assert_allclose(final[2], outcome.final_features[0][2], atol=1e-5)
    assert summary["peak_fz"] == pytest.approx(outcome.peak_fz[0], rel=0.10)
    cpu = summary["cpu_per_node"]
    assert all(cpu[node] > 0.01 for node in NODES), cpu  # each process did work


@REALTIME
def test_in_one_process_the_nodes_are_chained_and_every_topic_is_still_published() -> None:
    """The compensated wrench, the features and the command go from node to node as calls,
    not through DDS (the downstream subscriptions are gone), and the observer, another node,
    still receives each of them as the insertion runs."""
    path = str(SCENARIO)
    with CellRun(cell_nodes(path, scenario.load(path), "fbcc")) as run:
        assert run.chained == [
            "dynamic_compensation.out_compensated -> fbcc_controller.on_wrench",
            "dynamic_compensation.out_guard -> fbcc_controller.on_fault",
            "kinematics.out_features -> fbcc_controller.on_features",
            "fbcc_controller.out_command -> kinematics.on_command"]
        heard = {name: sorted(s.topic_name for s in node.subscriptions)
                 for name, node in run.nodes.items()}  # fmt: skip
        # the once-a-tare noise floor, the IK failures and the resets still come over DDS
        assert heard["fbcc_controller"] == ["/fbcc/kinematics_status", "/ft_sensor/noise"], heard
        assert heard["kinematics"] == ["/fbcc/rearm", "/joint_states"], heard  # rearm: rare
        start_insertion(run, timeout=10.0)
        before = dict(run.observer.counts)
        run.spin_for(1.0, lambda _: None)
        grew = {k: run.observer.counts[k] - before[k] for k in ("compensated", "features",
                                                                 "commands")}  # fmt: skip
        assert all(n > 100 for n in grew.values()), grew
        # a node killed and started anew joins the chain in its place, nothing calls the old
        old = run.nodes["fbcc_controller"]
        run.restart("fbcc_controller")
        new = run.nodes["fbcc_controller"]
        comp, kin = run.nodes["dynamic_compensation"], run.nodes["kinematics"]
        for outlet in (comp.out_compensated, comp.out_guard, kin.out_features):
            assert [c.chained_to for c in outlet.local] == ["fbcc_controller"]
        assert sorted(s.topic_name for s in new.subscriptions) == [
            "/fbcc/kinematics_status", "/ft_sensor/noise"]
        assert new is not old and len(new.out_command.local) == 1
        run.spin_until(lambda: new.sup.features is not None and new.sup.not_armed(new.now()) == "",
                       5.0, "the restarted controller did not hear the chain")  # fmt: skip
    with CellRun(cell_nodes(path, scenario.load(path), "fbcc"), chain=False) as run:
        assert run.chained == []
        # the wrench, the features, the two fault reports (kinematics, guard) and the noise floor
        heard = sorted(s.topic_name for s in run.nodes["fbcc_controller"].subscriptions)
        assert heard == ["/fbcc/features", "/fbcc/guard", "/fbcc/kinematics_status",
                         "/ft_sensor/compensated", "/ft_sensor/noise"], heard


@REALTIME
def test_abort_through_the_service_holds_the_command() -> None:
    """Over DDS: start, abort mid-insertion through ``fbcc/abort``; the phase says so, the arm
    stops where it was, a second abort is refused with the reason, a second start runs; reset
    (``fbcc/reset``) is refused while it runs and acknowledges its abort (idle)."""
    path = str(SCENARIO)
    sc = scenario.load(path)
    with CellRun(cell_nodes(path, sc, "fbcc")) as run:
        start_insertion(run, timeout=10.0)
        run.spin_for(0.5, lambda _: None)
        answer = run.call(run.observer.abort_client)
        assert answer.success, answer.message
        run.spin_until(lambda: run.observer.phase == "aborted", 2.0, "no aborted phase")
        run.spin_for(0.2, lambda _: None)  # the arm's lag settles on the held command
        held = run.observer.truth[-1][3]
        run.spin_for(0.5, lambda _: None)
        assert 0.5e-3 < held < sc.insertion.depth  # stopped part-way
        assert abs(run.observer.truth[-1][3] - held) < 1e-7  # depth l [m] no longer moves
        again = run.call(run.observer.abort_client)
        assert not again.success and again.message == "nothing to abort: aborted"
        restart = run.call(run.observer.start_client)
        assert restart.success, restart.message  # aborted is not active: a new one may start
        refused = run.call(run.observer.reset_client)
        assert not refused.success and refused.message == "inserting: abort it first"
        assert run.call(run.observer.abort_client).success
        reset = run.call(run.observer.reset_client)
        assert reset.success and reset.message.startswith("aborted acknowledged"), reset.message
        run.spin_until(lambda: run.observer.phase == "armed", 2.0, "not armed after the reset")


@REALTIME
def test_a_tripped_wrench_guard_faults_the_controller_and_holds_the_arm() -> None:
    """Over DDS: the compensation's guard at 5 N (the interference fit pushes harder), its dead
    band at 1000 N so the controller's input stays zero. The guard trips on the unfiltered
    wrench, the controller faults with its reason, and the arm stops where it was; a reset
    acknowledges it and re-arms the guard, which trips again on the force still there."""
    path = str(SCENARIO)
    specs = cell_nodes(path, scenario.load(path), "fbcc")
    specs[1].parameters.update({"guard.force_limit": 5.0, "deadband": [1000.0, 100.0]})
    with CellRun(specs) as run:
        start_insertion(run, timeout=10.0)
        run.spin_until(lambda: run.observer.phase == "fault", 4.0, "no fault phase")
        assert run.observer.reason.startswith("wrench guard") and "the limit 5 N" in (
            run.observer.reason)  # fmt: skip
        run.spin_for(0.2, lambda _: None)  # the arm's lag settles on the held command
        held = run.observer.truth[-1][3]
        run.spin_for(0.5, lambda _: None)
        assert held < 10e-3 and abs(run.observer.truth[-1][3] - held) < 1e-7  # l [m] held
        # the true contact force, tick by tick: past the limit only by what the arm's lag and
        # the trip's latency add (7.0 N measured); the controller's own 300 N limit, behind the
        # dead band, would never have stopped it
        force = max(float(np.linalg.norm(row[6:9])) for row in run.observer.truth)
        assert force < 25.0, force
        # the reset acknowledges the fault and re-arms the guard; the peg still presses with
        # more than 5 N, so the fresh guard trips again and the controller faults again
        comp = run.nodes["dynamic_compensation"].stage.comp
        tripped = comp.guard
        assert run.call(run.observer.reset_client).success
        run.spin_until(lambda: comp.guard is not tripped and comp.guard.tripped, 3.0,
                       "the guard was not re-armed, or did not trip again")  # fmt: skip
        run.spin_until(lambda: run.observer.phase == "fault", 3.0, "no fault after re-arming")
        assert run.observer.reason.startswith("wrench guard")


@REALTIME
def test_each_node_reports_on_diagnostics() -> None:
    """``/diagnostics`` once a second per node: the compensation's counters (taring, then
    accepted samples, nothing rejected), the controller's phase, all at level OK."""
    from diagnostic_msgs.msg import DiagnosticArray

    path = str(SCENARIO)
    statuses: dict[str, object] = {}

    def keep(msg: DiagnosticArray) -> None:
        for status in msg.status:
            statuses[status.hardware_id] = status

    with CellRun(cell_nodes(path, scenario.load(path), "fbcc")) as run:
        run.observer.create_subscription(DiagnosticArray, "/diagnostics", keep, 50)
        start_insertion(run, timeout=10.0)
        run.spin_for(2.5, lambda _: None)  # the last report is >= 1.5 s into the insertion
    assert set(statuses) == set(NODES), statuses
    comp = {kv.key: kv.value for kv in statuses["dynamic_compensation"].values}  # type: ignore[attr-defined]
    assert int(comp["accepted"]) > 500 and comp["non_finite"] == "0", comp
    assert int(comp["taring"]) == 200  # the bringup's tare, done before the start
    ctrl = statuses["fbcc_controller"]
    assert ctrl.message in ("inserting", "inserted"), ctrl  # type: ignore[attr-defined]
    # every node OK; on a starved machine two reports are right to warn: the mock that it
    # skipped ticks (its 1 kHz timer fell behind), the controller that its wrenches come at
    # less than its rate (it stepped on a third of them in one CI run)
    for name, status in statuses.items():
        level, message = status.level, status.message  # type: ignore[attr-defined]
        skipped = name == "mock_cell" and "ticks_skipped" in message
        slow = name == "fbcc_controller" and "configured for 1000 Hz" in message
        assert level == b"\x00" or (level == b"\x01" and (skipped or slow)), (name, status)


@REALTIME
def test_bringup_command_reports_exits_zero_and_records_the_session(tmp_path: Path, capfd) -> None:
    """The README's first command: one assembly, its summary, and a bag of the whole session
    (recorded by default) that holds the insertion from its start to its end."""
    # capfd, not capsys: the EventsExecutor enables faulthandler, which needs a real stderr
    assert bringup_main([str(SCENARIO), "--out", str(tmp_path)]) == 0
    out = capfd.readouterr().out
    assert "assembled: phase inserted" in out, out
    summary = json.loads((tmp_path / "summary.json").read_text())
    bag = read_bag(Path(summary["bag"]["path"]))
    assert bag.path.parent.parent == tmp_path / "bags" and not bag.truncated
    assert summary["bag"]["messages"] == {t: bag.counts[t] for t in bag.topics}
    sc = scenario.load(SCENARIO)
    # nothing lost: the recorder, in its own process, got at least every sample and joint
    # command the observer in the cell's process counted during the insertion (and the taring
    # before). How many the loop delivers is the machine's speed, which fbcc-bench measures
    # (a starved 1 kHz timer skips ticks, and says so); this test asks that none is lost.
    for topic in ("/joint_states", "/ft_sensor/raw", "/mock_cell/truth"):
        assert bag.counts[topic] >= summary["cycles"]["samples"] > 0, (
            topic, bag.counts, summary["cycles"])  # fmt: skip
    assert bag.counts["/joint_command"] >= summary["cycles"]["commands"] > 0
    # from its start to its end: the recorded commands span the whole run
    stamps = [m.log_time_ns * 1e-9 for m in bag.of("/joint_command")]
    assert max(stamps) - min(stamps) >= 0.9 * sc.duration, (min(stamps), max(stamps))
    phases = [decode_string(m.data) for m in bag.of("/fbcc/phase")]
    assert phases[0] == "idle" and "inserting" in phases and phases[-1] == "inserted", phases


def test_bringup_without_recording_and_never_over_a_bag(tmp_path: Path, capfd) -> None:
    (tmp_path / "old" / "x_0.mcap").parent.mkdir()
    (tmp_path / "old" / "x_0.mcap").write_bytes(b"a session")
    assert bringup_main([str(SCENARIO), "--bag", str(tmp_path / "old")]) == 2
    assert "a new or empty folder" in capfd.readouterr().err
    assert (tmp_path / "old" / "x_0.mcap").read_bytes() == b"a session"
    with pytest.raises(SystemExit):
        bringup_main([str(SCENARIO), "--bag", str(tmp_path / "b"), "--no-record"])


def test_bringup_bad_input_exits_two(capsys) -> None:
    assert bringup_main(["no/such/scenario.yaml"]) == 2
    assert "no/such/scenario.yaml" in capsys.readouterr().err
    assert bringup_main([str(SCENARIO), "--wait-for-recorder"]) == 2  # its own is waited for
    assert "--wait-for-recorder" in capsys.readouterr().err
    for args, allowed in ((["--fault", "nope"], "one of ['moment-spike'"),
                          (["--fault", "disk-full", "--no-record"], "a recorded run")):
        assert bringup_main([str(SCENARIO), *args]) == 2
        err = capsys.readouterr().err
        assert f"--fault={args[1]!r} is not allowed" in err and allowed in err, err


@pytest.mark.parametrize("node", NODES)
def test_each_node_starts_as_a_process_with_its_yaml(node: str, tmp_path: Path) -> None:
    """``python -m fbcc_ros.nodes.<node> --ros-args --params-file config/<node>.yaml``: still
    running after start-up, no error logged, and it stops on SIGINT."""
    cmd = [sys.executable, "-m", f"fbcc_ros.nodes.{node}", "--ros-args", "--params-file",
           str(ROOT / "config" / f"{node}.yaml")]  # fmt: skip
    log = tmp_path / "log.txt"
    with log.open("w") as f:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=f, stderr=subprocess.STDOUT, env=os.environ)
        try:
            time.sleep(4.0)
            assert proc.poll() is None, log.read_text()
            proc.send_signal(signal.SIGINT)
            assert proc.wait(timeout=10) == 0
        finally:
            kill_left(proc)
    text = log.read_text()
    assert "Traceback" not in text and "[ERROR]" not in text, text


@pytest.mark.parametrize(
    ("node", "override", "message"),
    [
        ("fbcc_controller", "law:=pid",
         "law='pid' is not allowed: expected one of ['scenario', 'fbcc', 'admittance', 'none']"),
        ("fbcc_controller", "timeout:=-1.0",
         "Parameter timeout out of range Min: 0.001, Max: 10.0, value: -1.0"),
        ("dynamic_compensation", "virtual_sensor:=true",
         "virtual_sensor=True is not allowed: expected placement 'wrist' with it"),
    ],
)  # fmt: skip
def test_a_bad_parameter_stops_a_node_with_a_message(
    node: str, override: str, message: str
) -> None:
    cmd = [sys.executable, "-m", f"fbcc_ros.nodes.{node}", "--ros-args", "-p", override]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2
    assert message in run.stderr and "Traceback" not in run.stderr, run.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--params-file", "/nonexistent/cell.yaml"],
         "--params-file='/nonexistent/cell.yaml' is not allowed: expected a readable file"),
        (["--params-file", "/dev/zero"], "a regular file (this is a character device)"),
        (["--params-file", "TWICE"], "'timeout' given twice, on line 3 and line 4"),
        (["-r", "__ns:=not-a-namespace"],
         "the ROS arguments were refused: failed to initialize rcl: Couldn't parse remap rule"),
    ],
)  # fmt: skip
def test_bad_ros_arguments_stop_a_node_with_one_line(args: list[str], message: str,
                                                     tmp_path: Path) -> None:  # fmt: skip
    """Files and ROS arguments rcl would refuse with a traceback end in one line, exit 2."""
    twice = tmp_path / "twice.yaml"
    twice.write_text("fbcc_controller:\n  ros__parameters:\n    timeout: 0.1\n    timeout: 9.0\n")
    args = [str(twice) if a == "TWICE" else a for a in args]
    cmd = [sys.executable, "-m", "fbcc_ros.nodes.fbcc_controller", "--ros-args", *args]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2, run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert message in last and "Traceback" not in run.stderr, run.stderr


def test_the_latency_probe_stops_watching_what_it_does_not_need() -> None:
    """Observer.probe_only: the truth, compensated wrenches and features are unsubscribed (the
    mock then stops publishing its truth); the commands, the TCP commands and the phase stay."""
    import rclpy

    from fbcc_ros.harness.observer import Observer
    from fbcc_ros.ros import topics

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        observer = Observer(probe=True, context=context)
        before = {s.topic_name for s in observer.subscriptions}
        observer.probe_only()
        after = {s.topic_name for s in observer.subscriptions}
        gone = {"/" + t for t in (topics.TRUTH, topics.COMPENSATED_WRENCH, topics.FEATURES)}
        assert before - after == gone
        kept = {"/" + t for t in (topics.JOINT_COMMAND, topics.TCP_COMMAND, topics.PHASE)}
        assert kept <= after
        observer.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_a_node_under_a_namespace_reads_the_shipped_parameter_file(tmp_path: Path) -> None:
    """``ros2 run fbcc_ros kinematics --ros-args -r __ns:=/lbr --params-file
    config/kinematics.yaml``: the file's ``/**/kinematics`` key reaches the node under /lbr; the
    same file with a bare ``kinematics`` key is ignored there (the node runs on its default)."""
    import rclpy
    import rclpy.executors
    import yaml
    from rcl_interfaces.srv import GetParameters

    shipped = yaml.safe_load((ROOT / "config" / "kinematics.yaml").read_text())
    body = shipped["/**/kinematics"]
    body["ros__parameters"]["rate_hz"] = 250.0
    for key, expected in (("/**/kinematics", 250.0), ("kinematics", 1000.0)):
        (tmp_path / "k.yaml").write_text(yaml.safe_dump({key: body}))
        cmd = [sys.executable, "-m", "fbcc_ros.nodes.kinematics", "--ros-args", "-r",
               "__ns:=/lbr", "--params-file", str(tmp_path / "k.yaml")]  # fmt: skip
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL,
                                stderr=subprocess.STDOUT)  # fmt: skip
        context = rclpy.Context()
        rclpy.init(context=context)
        node = rclpy.create_node("asker", context=context)
        try:
            client = node.create_client(GetParameters, "/lbr/kinematics/get_parameters")
            assert client.wait_for_service(timeout_sec=15.0), "no /lbr/kinematics"
            future = client.call_async(GetParameters.Request(names=["rate_hz"]))
            executor = rclpy.executors.SingleThreadedExecutor(context=context)
            executor.add_node(node)
            executor.spin_until_future_complete(future, timeout_sec=10.0)
            assert future.result().values[0].double_value == expected, key
        finally:
            node.destroy_node()
            rclpy.try_shutdown(context=context)
            context.destroy()
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=10)
