"""The one description of a cell's node set (fbcc_ros.harness.cell_nodes), which the launch
file, fbcc_bringup and the tests start: every profile's parameters are ones its nodes declare,
with allowed values, and a set-up that cannot work is refused before anything starts."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.param_files import file_parameters
from fbcc_ros.harness.cell_nodes import NODES, PROFILES, SOURCE_PARAMETERS, CellSetup, cell_nodes
from fbcc_ros.pipeline import compensation, controller, kinematics, mock_cell
from fbcc_ros.pipeline.parameters import resolve

ROOT = Path(__file__).resolve().parents[2]
TABLES = {"mock_cell": mock_cell.TABLE, "dynamic_compensation": compensation.TABLE,
          "kinematics": kinematics.TABLE, "fbcc_controller": controller.TABLE}  # fmt: skip
LBR = "config/scenarios/lbr_rehearsal.yaml"


def _user_file(tmp_path: Path) -> str:
    """What a user's own file gives beside a real robot: the hole and the tool."""
    hole = {"hole_xyz": [0.6, 0.0, 0.25], "hole_rpy": [0.0, 0.0, 0.0],
            "tool_xyz": [0.0, 0.0, 0.12]}  # fmt: skip
    doc = {f"/**/{n}": {"ros__parameters": hole} for n in ("kinematics", "dynamic_compensation")}
    path = tmp_path / "my_cell.yaml"
    path.write_text(yaml.safe_dump(doc))
    return str(path)


@pytest.mark.parametrize("profile", PROFILES)
def test_each_profile_beside_a_real_robot_resolves_for_each_node(profile: str,
                                                                  tmp_path: Path) -> None:
    nodes = cell_nodes(CellSetup(profile, mock=False, params_file=_user_file(tmp_path)))
    assert [n.name for n in nodes] == list(NODES[1:])  # no mock beside a real robot
    for node in nodes:
        values = resolve(node.name, TABLES[node.name], node.merged())
        if profile != "fbcc":
            assert node.name == "fbcc_controller" or values["robot"] == "robot_description"
        if node.name == "kinematics" and profile != "fbcc":
            assert values["command_topic"] == "forward_position_controller/commands"
            assert values["hole_xyz"] == [0.6, 0.0, 0.25]  # the user's file over the profile


@pytest.mark.parametrize(("scenario", "profile"), [
    ("config/scenarios/bringup_interference.yaml", "fbcc"), (LBR, "lbr")])  # fmt: skip
def test_each_rehearsal_resolves_for_each_node(scenario: str, profile: str) -> None:
    nodes = cell_nodes(CellSetup(profile, scenario, law="admittance"))
    assert [n.name for n in nodes] == list(NODES)
    values = {n.name: resolve(n.name, TABLES[n.name], n.merged()) for n in nodes}
    assert values["fbcc_controller"]["law"] == "admittance"
    rates = {values[n]["rate_hz"] for n in ("mock_cell", "kinematics", "fbcc_controller")}
    assert rates == ({100.0} if profile == "lbr" else {1000.0})
    # the kinematics and the compensation believe the same hole
    hole = [values[n][k] for n in ("kinematics", "dynamic_compensation")
            for k in ("hole_xyz", "hole_rpy")]  # fmt: skip
    assert hole[:2] == hole[2:]


@pytest.mark.parametrize("plant", ["", "model", "mujoco"])
def test_a_mock_on_a_plant_slower_than_real_time_is_the_cells_clock(plant: str) -> None:
    """On MuJoCo the mock publishes /clock and every other node reads it; on the model (real
    time and faster) the cell keeps the wall's clock, as a real cell does."""
    nodes = cell_nodes(CellSetup(plant=plant))
    values = {n.name: resolve(n.name, TABLES[n.name], n.merged()) for n in nodes}
    sim = plant == "mujoco"
    assert values["mock_cell"]["publish_clock"] is sim
    assert values["mock_cell"]["plant"] == plant
    assert "use_sim_time" not in nodes[0].merged()  # the mock is the clock
    for node in nodes[1:]:
        assert node.merged().get("use_sim_time", False) is sim, node.name


def test_the_lbr_profile_reads_the_stacks_joint_torques() -> None:
    nodes = {n.name: n.merged() for n in cell_nodes(CellSetup("lbr", LBR))}
    comp = nodes["dynamic_compensation"]
    assert comp["virtual_sensor"] and comp["joint_torques"] == "measured"
    assert nodes["mock_cell"]["conventions"] == "lbr" and nodes["mock_cell"]["arm_sensing"]


def test_the_rehearsals_measured_torque_source_is_what_the_lbr_profile_ships() -> None:
    """The rehearsal sets the source's values over the profile (a scenario may pick another
    source); for the profile's own source they are the shipped file's, so the rehearsal
    runs what a real cell runs."""
    shipped = file_parameters((ROOT / "config/profiles/lbr.yaml",), "dynamic_compensation")
    rehearsed = SOURCE_PARAMETERS["measured_torques"]
    assert {k: shipped.get(k) for k in rehearsed} == rehearsed


@pytest.mark.parametrize(("setup", "match"), [
    (CellSetup("kuka"), r"profile='kuka'.*one of \['fbcc', 'lbr', 'ros2_control'\]"),
    (CellSetup("lbr"), r"profile='lbr'.*'fbcc' with the scenario's robot.conventions 'fbcc'"),
    (CellSetup("fbcc", LBR), r"profile='fbcc'.*'lbr' with the scenario's robot.conventions"),
    (CellSetup("lbr", mock=False), r"params_file=''.*your cell's parameter file"),
    (CellSetup(plant="gazebo"), r"plant='gazebo'.*one of \['model', 'mujoco'\]"),
])  # fmt: skip
def test_a_set_up_that_cannot_work_is_refused(setup: CellSetup, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        cell_nodes(setup)


def test_the_profile_files_are_keyed_for_any_namespace() -> None:
    for profile in PROFILES[1:]:
        doc = yaml.safe_load((ROOT / "config" / "profiles" / f"{profile}.yaml").read_text())
        assert all(key.startswith("/**/") for key in doc), (profile, list(doc))


def test_dead_bands_that_hide_the_insertion_are_said_before_it_starts(tmp_path: Path) -> None:
    """The LBR stack's estimated wrench (its default 2 N / 0.5 N·m band), and our own
    deadband set too wide in the user's file; the shipped set-ups say nothing."""
    from fbcc_ros.harness.cell_nodes import deadband_warnings

    assert deadband_warnings(cell_nodes(CellSetup())) == []
    assert deadband_warnings(cell_nodes(CellSetup("lbr", LBR))) == []  # measured torques
    data = yaml.safe_load((ROOT / LBR).read_text())
    data.setdefault("sensor", {})["source"] = "estimated"
    estimated = tmp_path / "estimated.yaml"
    estimated.write_text(yaml.safe_dump(data))
    said = deadband_warnings(cell_nodes(CellSetup("lbr", str(estimated))))
    assert len(said) == 1 and "the LBR stack's estimated wrench" in said[0], said
    assert "2 N > 0.5 N" in said[0] and "0.5 N·m >" in said[0]
    ours = tmp_path / "wide.yaml"
    ours.write_text(yaml.safe_dump({"/**/dynamic_compensation": {"ros__parameters": {
        "deadband": [1.0, 0.0]}}}))  # fmt: skip
    said = deadband_warnings(cell_nodes(CellSetup(params_file=str(ours))))
    assert len(said) == 1 and "dynamic_compensation (deadband) (1 N > 0.5 N)" in said[0]


def test_a_model_given_at_launch_replaces_the_scenarios_everywhere_it_is_built_in(
        tmp_path: Path) -> None:  # fmt: skip
    """The mock plays it and the hole is placed under its home; beside the LBR stack our nodes
    still take the model from the description the mock latches; a name not built in is refused."""
    nodes = {n.name: n.merged() for n in cell_nodes(CellSetup(model="iiwa7"))}
    assert {nodes[n]["robot"] for n in ("mock_cell", "kinematics", "dynamic_compensation")} == {
        "iiwa7"}
    default = {n.name: n.merged() for n in cell_nodes(CellSetup())}
    assert nodes["kinematics"]["hole_xyz"] != default["kinematics"]["hole_xyz"]
    lbr = {n.name: n.merged() for n in cell_nodes(CellSetup("lbr", LBR, model="med7"))}
    assert lbr["mock_cell"]["robot"] == "med7"
    assert lbr["kinematics"]["robot"] == "robot_description"
    real = {n.name: n.merged()
            for n in cell_nodes(CellSetup(mock=False, model="panda"))}  # fmt: skip
    assert real["kinematics"]["robot"] == "panda"
    with pytest.raises(ConfigError, match="model='kuka'"):
        cell_nodes(CellSetup(model="kuka"))
