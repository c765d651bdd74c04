"""The robot model from ``robot_description`` over DDS, as a ROS stack shares it: a stand-in for
robot_state_publisher latches a model's URDF, the kinematics node (``robot:
robot_description``) builds its model from it, and the features it measures while the mock arm
moves agree with the mock's truth to 1e-6 — under our names and under lbr_fri_ros2_stack's
(joints ``lbr_A1..7``, the forward position controller's command topic, in ``/lbr``)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import rclpy
import yaml
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from std_msgs.msg import Float64MultiArray, String

from fbcc_ros.core.contact.features import features_from_pose
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.cell import CellKinematics, aligned_hole_at
from fbcc_ros.core.kinematics.ik import solve_ik
from fbcc_ros.core.kinematics.robot import RobotModel
from fbcc_ros.nodes.kinematics import KinematicsNode
from fbcc_ros.nodes.mock_cell import MockCellNode
from fbcc_ros.pipeline.mock_cell import LBR_NAME
from fbcc_ros.ros import topics
from fbcc_ros.ros.cdr import decode_array
from fbcc_ros.ros.convert import pose_from_cdr, positions_to_cdr
from fbcc_ros.ros.executor import make_executor
from fbcc_ros.ros.robot_description import DESCRIPTION_QOS

ROOT = Path(__file__).resolve().parents[2]
RADIUS = 0.00504


def _scenario(tmp_path: Path) -> Path:
    """The bringup scenario with the hole where the nodes believe it (truth = belief) and a
    clearance, so the features measured and the true ones are the same numbers."""
    data = yaml.safe_load((ROOT / "config/scenarios/bringup_interference.yaml").read_text())
    data["geometry"].update(hole_radius=0.00506, peg_radius=RADIUS)
    data["initial"] = {"dx": 0.0, "dy": 0.0, "theta_x": 0.0, "theta_y": 0.0}
    path = tmp_path / "aligned.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _waypoints(robot: RobotModel, hole: pin.SE3) -> list[np.ndarray]:
    """Joints placing the peg at features that vary every coordinate (into the hole by up to
    3 mm, sideways by up to 4 µm, tilted by up to 0.4 mrad)."""
    cell = CellKinematics(robot, hole, RADIUS)
    q = robot.home
    out = []
    for s in np.linspace(0.0, 1.0, 12):
        x = np.array([4e-6 * s, -3e-6 * s, 3e-3 * s, 4e-4 * s, -2e-4 * s])
        q = solve_ik(robot, cell.peg_target(x, 0.0), q).q
        out.append(q)
    return out


@pytest.mark.flaky(reruns=2)
@pytest.mark.parametrize(("model", "conventions", "publisher"), [
    ("iiwa14", "fbcc", "stand_in"), ("panda", "fbcc", "stand_in"),
    *((m, "lbr", "stand_in") for m in ("iiwa7", "iiwa14", "med7", "med14")),
    ("iiwa14", "lbr", "mock")])  # fmt: skip
def test_features_from_a_published_robot_description_match_the_truth(
    model: str, conventions: str, publisher: str, tmp_path: Path
) -> None:
    """``publisher``: who latches the URDF — the stand-in for robot_state_publisher (the mock
    told not to), or the mock, which plays the stack's by default."""
    lbr = conventions == "lbr"
    arm = RobotModel.from_name(model, lbr_name=LBR_NAME if lbr else "")
    hole = aligned_hole_at(arm.peg_in_base(arm.home))
    namespace = "/lbr" if lbr else ""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        stand_in = rclpy.create_node("robot_state_publisher", namespace=namespace,
                                     context=context)  # fmt: skip
        latched = stand_in.create_publisher(String, topics.ROBOT_DESCRIPTION, DESCRIPTION_QOS)
        if publisher == "stand_in":
            latched.publish(String(data=arm.urdf_text))
        mock = MockCellNode(context=context, namespace=namespace, parameter_overrides=[
            Parameter("scenario", value=str(_scenario(tmp_path))),
            Parameter("robot", value=model),
            Parameter("conventions", value=conventions),
            Parameter("publish_description", value=publisher == "mock"),
            Parameter("rate_hz", value=200.0)])  # fmt: skip
        command = topics.LBR_COMMAND if lbr else topics.JOINT_COMMAND
        # a description names every joint, a gripper's too: the arm's are the others
        fingers = ["panda_finger_joint1", "panda_finger_joint2"] if model == "panda" else []
        kinematics = KinematicsNode(context=context, namespace=namespace, parameter_overrides=[
            Parameter("robot", value="robot_description"),
            Parameter("flange_frame", value="panda_link8" if model == "panda" else ""),
            Parameter("locked_joints", value=fingers),
            Parameter("hole_from_home", value=False),
            Parameter("hole_xyz", value=hole.translation.tolist()),
            Parameter("hole_rpy", value=pin.rpy.matrixToRpy(hole.rotation).tolist()),
            Parameter("command_topic", value=command),
            Parameter("rate_hz", value=200.0)])  # fmt: skip
        assert kinematics.stage.joint_names == mock.names == arm.joint_names
        features: dict[float, np.ndarray] = {}
        truth: dict[float, np.ndarray] = {}

        def on_features(data: bytes) -> None:
            stamp, peg = pose_from_cdr(data)
            features[stamp] = features_from_pose(peg.rotation, peg.translation, RADIUS)

        def on_truth(data: bytes) -> None:
            row = decode_array(data)
            truth[row[0]] = np.array(row[1:6])

        sub = stand_in.create_subscription
        sub(Float64MultiArray, topics.TRUTH, on_truth, 100, raw=True)  # type: ignore[arg-type]
        sub(PoseStamped, topics.FEATURES, on_features, 100, raw=True)  # type: ignore[arg-type]
        pub = stand_in.create_publisher(Float64MultiArray, command, 10)
        executor = make_executor(context)
        for node in (stand_in, mock, kinematics):
            executor.add_node(node)
        for q in _waypoints(arm, hole):
            pub.publish(positions_to_cdr(q))
            end = time.monotonic() + 0.15
            while time.monotonic() < end:
                executor.spin_once(timeout_sec=0.01)
        executor.shutdown()
        for node in (stand_in, mock, kinematics):
            node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()
    both = sorted(set(features) & set(truth))
    assert len(both) > 100, (len(features), len(truth))
    measured = np.array([features[t] for t in both])
    true = np.array([truth[t] for t in both])
    assert np.ptp(true[:, 2]) > 2e-3 and np.ptp(true[:, 3]) > 3e-4  # it moved in and tilted
    np.testing.assert_allclose(measured, true, rtol=0.0, atol=1e-6)


def test_without_a_description_the_node_says_where_it_waited(tmp_path: Path) -> None:
    """No one latches a URDF (the mock told not to): the node gives up after
    ``description_timeout``, naming the topic it waited on, under its namespace."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        mock = MockCellNode(context=context, namespace="/lbr", parameter_overrides=[
            Parameter("scenario", value=str(_scenario(tmp_path))),
            Parameter("publish_description", value=False)])  # fmt: skip
        start = time.monotonic()
        with pytest.raises(ConfigError, match=r"a URDF on /lbr/robot_description within "
                           r"description_timeout \(0.5 s\)"):  # fmt: skip
            KinematicsNode(context=context, namespace="/lbr", parameter_overrides=[
                Parameter("robot", value="robot_description"),
                Parameter("description_timeout", value=0.5),
                Parameter("hole_from_home", value=False)])  # fmt: skip
        assert 0.5 <= time.monotonic() - start < 3.0
        mock.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()
