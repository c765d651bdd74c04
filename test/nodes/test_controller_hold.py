"""The controller node publishes a fault's hold at once, off the wrench's path: with no wrench to
answer (a guard trip withholds them, a stale input has none), the arm would otherwise go on to
the last command, a step and its lag beyond where it was measured."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import rclpy
from std_msgs.msg import String

from fbcc_ros.core.contact.features import pose_from_features
from fbcc_ros.nodes.fbcc_controller import FbccControllerNode
from fbcc_ros.pipeline.parameters import HOLE_FRAME
from fbcc_ros.ros.convert import pose_from_cdr, pose_to_cdr, wrench_to_cdr


@pytest.fixture
def controller():
    context = rclpy.Context()
    rclpy.init(context=context)
    node = FbccControllerNode(context=context)
    yield node
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    context.destroy()


@pytest.mark.parametrize("fault", ["guard", "watchdog"])
def test_a_fault_off_the_wrench_path_publishes_its_hold_at_once(controller, fault) -> None:
    sent: list[tuple[float, pin.SE3]] = []
    controller.out_command.local.append(lambda data: sent.append(pose_from_cdr(data)))
    radius = controller.stage.nominal.peg_radius
    now = controller.now()

    def features(x: np.ndarray) -> bytes:
        return pose_to_cdr(pin.SE3(*pose_from_features(x, radius)), HOLE_FRAME.default, now)

    x0 = np.array([0.0, 0.0, 2e-3, 0.0, 0.0])
    controller.on_features(features(x0))
    controller.on_wrench(wrench_to_cdr(np.zeros(6), HOLE_FRAME.default, now))
    assert controller.start_insertion(controller.now())[0]
    for _ in range(3):  # three periods: the command runs ahead of the arm
        controller.on_wrench(wrench_to_cdr(np.zeros(6), HOLE_FRAME.default, controller.now()))
    ahead = controller.sup.command.copy()
    measured = x0 + np.array([0.0, 0.0, 1e-6, 0.0, 0.0])  # the arm, behind its command
    controller.on_features(features(measured))
    count = len(sent)
    if fault == "guard":
        controller.on_fault(String(data="wrench guard: |f| 280 N over 270 N"))
    else:  # the features keep coming, the wrench stops
        while controller.sup.phase == "inserting":
            controller.on_features(features(measured))
            controller.on_watchdog()
    assert controller.sup.phase == "fault"
    assert len(sent) == count + 1  # the hold, with no wrench to answer
    held = controller.stage.features_of(sent[-1][1])
    np.testing.assert_allclose(held, measured, atol=1e-12)
    assert ahead[2] - held[2] > 1e-6  # short of where the command had gone


def test_a_burst_of_start_calls_is_answered_every_one(controller) -> None:
    """20 concurrent ``fbcc/start`` calls: each gets an answer (refused here: no inputs)."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_srvs.srv import Trigger

    caller = Node("caller", context=controller.context)
    executor = SingleThreadedExecutor(context=controller.context)
    for node in (controller, caller):
        executor.add_node(node)
    clients = [caller.create_client(Trigger, "/fbcc/start") for _ in range(20)]
    for client in clients:
        assert client.wait_for_service(timeout_sec=10.0)
    futures = [client.call_async(Trigger.Request()) for client in clients]
    for _ in range(1000):
        executor.spin_once(timeout_sec=0.01)
        if all(f.done() for f in futures):
            break
    answered = [f.result() for f in futures if f.done()]
    assert len(answered) == 20, len(answered)
    assert all(not a.success and "no recent features" in a.message for a in answered)
    caller.destroy_node()


def test_a_second_publisher_on_an_input_faults_naming_it_and_use_sim_time_is_refused(
        controller) -> None:  # fmt: skip
    """Another node publishing on fbcc/features: the controller faults with both names and a
    start is refused while it lasts; ``use_sim_time`` cannot be switched while it runs."""
    import time

    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    first, second = (Node(name, context=controller.context) for name in ("kin_a", "kin_b"))
    first.create_publisher(PoseStamped, "/fbcc/features", 10)
    second.create_publisher(PoseStamped, "/fbcc/features", 10)
    deadline = time.monotonic() + 5.0
    while controller.sup.phase != "fault" and time.monotonic() < deadline:
        controller.sources.check()
        time.sleep(0.02)
    assert "2 publishers on /fbcc/features (/kin_a, /kin_b)" in controller.sup.reason
    ok, why = controller.start_insertion(controller.now())
    assert not ok and "one source per input" in why
    result = controller.set_parameters([Parameter("use_sim_time", value=True)])[0]
    assert not result.successful and "set at start-up only" in result.reason
    assert not controller.get_clock().ros_time_is_active
    for node in (first, second):
        node.destroy_node()
