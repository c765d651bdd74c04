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
