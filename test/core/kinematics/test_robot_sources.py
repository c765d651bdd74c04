"""Where a robot model comes from: a built-in name, a URDF file, or the text a
``robot_description`` carries (with the flange found at the tip of the chain), and our LBR
models under lbr_fri_ros2_stack's names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.kinematics.lbr_names import lbr_description
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel, Tool, pose, tip_frame
from fbcc_ros.pipeline.kinematics import TABLE, cell_from
from fbcc_ros.pipeline.parameters import resolve

LBR = ["iiwa7", "iiwa14", "med7", "med14"]


def _random_q(robot: RobotModel, n: int = 20) -> np.ndarray:
    rng = np.random.default_rng(3)
    return rng.uniform(robot.lower, robot.upper, size=(n, robot.nq))


@pytest.mark.parametrize("name", LBR)
def test_the_text_of_a_description_gives_the_models_kinematics(name: str) -> None:
    tool = Tool(xyz=(0.01, 0.0, 0.12), rpy=(0.0, 0.1, 0.0))
    built_in = RobotModel.from_name(name, tool)
    from_text = RobotModel(built_in.urdf_text, "", tool)  # the flange found: its chain's tip
    assert from_text.flange_frame == "iiwa_flange"
    assert from_text.joint_names == built_in.joint_names
    for q in _random_q(built_in):
        np.testing.assert_allclose(from_text.peg_in_base(q).homogeneous,
                                   built_in.peg_in_base(q).homogeneous, atol=1e-12)  # fmt: skip


@pytest.mark.parametrize("name", LBR)
def test_under_the_stacks_names_only_the_names_change(name: str) -> None:
    ours = RobotModel.from_name(name)
    theirs = RobotModel.from_name(name, lbr_name="lbr")
    assert theirs.joint_names == tuple(f"lbr_A{i}" for i in range(1, 8))
    assert theirs.flange_frame == "lbr_link_ee"
    assert theirs.model.frames[1].name == "lbr_floating_link"  # the stack's root
    assert "peg" not in theirs.urdf_text  # the tool is the nodes' parameter, not the stack's
    np.testing.assert_array_equal(theirs.lower, ours.lower)
    np.testing.assert_array_equal(theirs.velocity_limit, ours.velocity_limit)
    for q in _random_q(ours):
        np.testing.assert_allclose(theirs.peg_in_base(q).homogeneous,
                                   ours.peg_in_base(q).homogeneous, atol=1e-12)  # fmt: skip
    # a description read back: the tip of its chain is the stack's flange
    assert RobotModel(theirs.urdf_text).flange_frame == "lbr_link_ee"
    assert RobotModel.from_name(name, lbr_name="arm2").joint_names[0] == "arm2_A1"


def test_the_stacks_names_are_for_lbrs_only() -> None:
    with pytest.raises(ConfigError, match=r"conventions='lbr'.*LBR family"):
        RobotModel.from_name("panda", lbr_name="lbr")
    with pytest.raises(ConfigError, match=r"robot_name='lbr-1'"):
        lbr_description(ROBOTS["iiwa14"]().urdf.read_text(), "lbr-1")


def test_a_chain_with_several_tips_must_name_its_flange() -> None:
    spec = ROBOTS["ur5"]()
    with pytest.raises(ConfigError, match=r"flange_frame=''.*tips of ur5_robot.urdf: "
                       r"\['ee_link', 'tool0'\]"):  # fmt: skip
        RobotModel(spec.urdf)
    assert RobotModel(spec.urdf, "tool0").flange_frame == "tool0"
    assert tip_frame(RobotModel.from_name("iiwa14").model) == "iiwa_flange"  # the peg skipped


def test_bad_description_text_says_what_it_is() -> None:
    with pytest.raises(ConfigError, match=r"urdf=\"<robot name=.*Pinocchio can parse"):
        RobotModel("<robot name='x'><link name='a'/>")
    with pytest.raises(ConfigError, match=r"urdf='robot_description'.*revolute or prismatic"):
        RobotModel("<robot name='x'><link name='a'/></robot>")


def test_a_models_own_home_is_the_middle_of_its_ranges() -> None:
    """A URDF says nothing of where its arm works: the Panda's zero is outside its A4 range."""
    spec = ROBOTS["panda"]()
    panda = RobotModel(spec.urdf, "panda_link8", locked_joints=spec.locked_joints)
    np.testing.assert_allclose(panda.home, (panda.lower + panda.upper) / 2)
    assert panda.within_limits(panda.home) and not panda.within_limits(np.zeros(7))


def test_the_cell_parameters_choose_the_source(tmp_path: Path) -> None:
    hole = {"hole_from_home": False, "hole_xyz": [0.6, 0.0, 0.3], "hole_rpy": [np.pi, 0.0, 0.0]}
    text = RobotModel.from_name("iiwa7").urdf_text
    from_topic, _ = cell_from(resolve("kinematics", TABLE, {"robot": "robot_description",
                                                            **hole}), text)  # fmt: skip
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(text)
    from_file, _ = cell_from(resolve("kinematics", TABLE, {"robot": "urdf_file",
                                                           "urdf_file": str(urdf), **hole}))
    q = _random_q(from_file, 1)[0]
    np.testing.assert_allclose(from_topic.peg_in_base(q).homogeneous,
                               from_file.peg_in_base(q).homogeneous, atol=1e-12)  # fmt: skip
    with pytest.raises(ConfigError, match=r"robot='robot_description'.*none came"):
        cell_from(resolve("kinematics", TABLE, {"robot": "robot_description", **hole}))
    with pytest.raises(ConfigError, match=r"hole_from_home=True.*hole_xyz/hole_rpy"):
        cell_from(resolve("kinematics", TABLE, {"robot": "robot_description"}), text)
    with pytest.raises(ConfigError, match=r"urdf_file=''"):
        cell_from(resolve("kinematics", TABLE, {"robot": "urdf_file", **hole}))
    with pytest.raises(ConfigError, match=r"locked_joints=.*built-in model iiwa14"):
        cell_from(resolve("kinematics", TABLE, {"locked_joints": ["iiwa_joint_7"]}))


def test_a_tool_frame_of_the_model_places_the_tool_given_in_it() -> None:
    """The UR5's tool0 (its TCP, on the last link) and the iiwa's last link: the tool given in
    them lands where the same tool given from the flange does; a frame on another link is
    refused, naming the ones that may be used."""
    iiwa = RobotModel.from_name("iiwa14")
    link7 = RobotModel.from_name("iiwa14", Tool((0.0, 0.0, 0.145), (0.0, 0.0, 0.0),
                                                "iiwa_link_7"))  # fmt: skip
    assert link7.peg_in_flange().isApprox(iiwa.peg_in_flange(), 1e-12)
    ur5 = RobotModel.from_name("ur5", flange_frame="ee_link")
    at_tcp = RobotModel.from_name("ur5", Tool((0.0, 0.0, 0.1), (0.0, 0.0, 0.0), "tool0"),
                                  flange_frame="ee_link")  # fmt: skip
    tcp = ur5.model.frames[ur5.model.getFrameId("tool0")].placement
    flange = ur5.model.frames[ur5.model.getFrameId("ee_link")].placement
    expected = flange.actInv(tcp) * pose((0.0, 0.0, 0.1))
    assert at_tcp.peg_in_flange().isApprox(expected, 1e-12)
    assert not at_tcp.peg_in_flange().isApprox(ur5.peg_in_flange(), 1e-6)  # tool0 is turned
    with pytest.raises(ConfigError, match=r"tool_frame='iiwa_link_6'.*\['iiwa_link_7'"):
        RobotModel.from_name("iiwa14", Tool(frame="iiwa_link_6"))
