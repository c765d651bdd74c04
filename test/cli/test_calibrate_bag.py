"""``fbcc-calibrate BAG`` as on a real cell: mcap bags of an iiwa14 moving through the poses of
``calibration_poses``, its wrist sensor carrying a known payload (the simulation of
test/core/compensation/test_calibration_data.py: bias, white noise, a ring after each stop, at
1 kHz), joint states at 1 kHz or 100 Hz, in another joint order with an extra joint, under a
namespace. The recovered payload and bias must lie within 5 standard deviations of the truth,
the deviations computed from the noise and the poses found (that module's doc says why).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rclpy.qos import QoSProfile

from fbcc_ros.bag.writer import BagWriter
from fbcc_ros.cli import calibrate
from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.compensation import calibration_data as cd
from fbcc_ros.core.compensation import calibration_poses as cp
from fbcc_ros.core.compensation.calibration_file import load_calibration
from fbcc_ros.core.compensation.compensator import SENSOR_FRAME
from fbcc_ros.ros.convert import joints_to_cdr, wrench_to_cdr
from test.core.compensation.test_calibration_data import (
    BIAS,
    HOLDER,
    SENSOR_RPY,
    SENSOR_XYZ,
    iiwa,
    poses,
    simulate,
    within_noise,
)

T0 = 1_790_000_000.0  # the epoch second the recording starts [s]
SENSOR = ["--sensor-xyz", *map(str, SENSOR_XYZ), "--sensor-rpy", *map(str, SENSOR_RPY)]


def write_bag(folder: Path, sim: dict[str, FloatArray], *, every: int = 1,
              namespace: str = "", shuffle: bool = False, velocities: bool = True,
              position_noise: float = 0.0) -> Path:  # fmt: skip
    """The robot's joint states every ``every`` ms (0.3 ms before the sensor's stamps), the
    sensor's readings every ms, under ``namespace``; ``shuffle``: the joints in another order
    with a gripper joint among them."""
    names = list(iiwa().joint_names)
    q = sim["q"] + np.random.default_rng(7).normal(0.0, position_noise, sim["q"].shape)
    dq = sim["dq"]
    if shuffle:
        order = [3, 6, 0, 5, 1, 4, 2]
        names = [names[i] for i in order] + ["gripper_finger_joint"]
        q = np.column_stack([q[:, order], np.full(len(q), 0.02)])
        dq = np.column_stack([dq[:, order], np.zeros(len(q))])
    joints, wrench = f"{namespace}/joint_states", f"{namespace}/ft_sensor/raw"
    with BagWriter(folder) as bag:
        bag.add_topic(joints, "sensor_msgs/msg/JointState", [QoSProfile(depth=10)])
        bag.add_topic(wrench, "geometry_msgs/msg/WrenchStamped", [QoSProfile(depth=10)])
        for i, t in enumerate(sim["t"]):
            if i % every == 0:
                stamp = T0 + t - 3e-4
                v = dq[i] if velocities else np.zeros(0)
                bag.write(joints, joints_to_cdr(names, q[i], v, stamp), round(stamp * 1e9))
            stamp = T0 + t
            bag.write(wrench, wrench_to_cdr(sim["wrench"][i], "ft_sensor", stamp),
                      round(stamp * 1e9))  # fmt: skip
    return folder


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("bags")
    sim = simulate()
    home = iiwa().home
    few = simulate(tuple(tuple(home + np.eye(7)[6] * a) for a in (0.0, 1.2, -1.5)))
    return {
        "1kHz": write_bag(root / "calibration", sim),
        "lbr": write_bag(
            root / "lbr",
            sim,
            every=10,
            namespace="/lbr",
            shuffle=True,
            velocities=False,
            position_noise=1e-5,
        ),
        "turned": write_bag(root / "turned", few),
    }


def _fit_within_noise(out: Path) -> dict[str, float]:
    """The fit written to ``out`` against the truth, to the standard deviations of a fit of the
    simulated poses (the dwells found in the simulation's own joint states)."""
    sim, robot = simulate(), iiwa()
    dwells = cd.static_samples(cd.JointStates(sim["t"], sim["q"], sim["dq"]),
                               cd.Readings(sim["t"], sim["wrench"])).dwells  # fmt: skip
    assert len(dwells) == len(poses().q)
    payload, bias = load_calibration(out)
    assert np.all(np.array(payload.inertia) == 0.0)
    return within_noise(robot, dwells, payload.mass, np.array(payload.com), bias)


def test_static_fit_from_a_bag_at_1khz(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "payload.yaml"
    status = calibrate.main([str(bags["1kHz"]), "--robot", "iiwa14", "--out", str(out), *SENSOR])
    report = capsys.readouterr().out
    assert status == 0, report
    sigmas = _fit_within_noise(out)
    print(f"1 kHz: largest error {sigmas} standard deviations")
    n = len(poses().q)
    assert f"static fit of {n} poses from calibration" in report
    assert "(velocities recorded)" not in report and "1000 Hz, velocities recorded" in report
    assert "refused 0 further than 15 ms" in report and f"poses: {n} held still" in report
    assert "frame 'ft_sensor'" in report and "gravity in {S} over the poses: x [" in report
    table = report[report.index("pose  ") :]
    assert len([line for line in table.splitlines() if line[:4].strip().isdigit()]) == n
    assert f"condition number over all {n}: {poses().condition:.3g}" in table
    assert "WARNING" not in report
    header = out.read_text()
    assert f"# poses: {n} held still" in header and "# residual rms" in header


def test_namespaced_100hz_shuffled_joints_without_velocities(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """/lbr/joint_states at 100 Hz, the joints in another order with a gripper joint, no
    velocities (differentiated), 1e-5 rad of noise on the positions; the topics given with and
    without the leading '/', the bag as its .mcap file."""
    out = tmp_path / "payload.yaml"
    mcap = next(bags["lbr"].glob("*.mcap"))
    args = [str(mcap), "--robot", "iiwa14", "--out", str(out), *SENSOR,
            "--joint-states", "/lbr/joint_states", "--wrench", "lbr/ft_sensor/raw"]  # fmt: skip
    status = calibrate.main(args)
    report = capsys.readouterr().out
    assert status == 0, report
    assert "100 Hz, no velocities: differentiated from the positions" in report
    sigmas = _fit_within_noise(out)
    print(f"100 Hz: largest error {sigmas} standard deviations")


def test_too_few_poses_are_refused_naming_the_missing_excitation(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Home and two turns of A7: the flange points down throughout, so gravity in {S} never
    moves."""
    out = tmp_path / "payload.yaml"
    args = [str(bags["turned"]), "--robot", "iiwa14", "--out", str(out), *SENSOR]
    assert calibrate.main(args) == 1
    captured = capsys.readouterr()
    assert "poses: 3 held still" in captured.out  # found, and listed
    err = captured.err
    assert "fit refused: condition number" in err and "over 3 poses" in err
    assert "gravity stayed along sensor +z" in err
    assert "never had a component along sensor x or y" in err
    assert "mass cannot be told from the force bias" in err
    assert "Tilt the sensor: rotate A" in err and "A6 (iiwa_joint_6)" in err
    assert not out.exists()


def test_a_bag_without_a_held_pose_is_refused(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "payload.yaml"
    args = [str(bags["turned"]), "--robot", "iiwa14", "--out", str(out), "--min-dwell", "5"]
    assert calibrate.main(args) == 1
    err = capsys.readouterr().err
    assert "no pose held still" in err and "--dwell-speed, --min-dwell" in err


def test_missing_topics_list_the_bags_topics(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "payload.yaml")
    assert calibrate.main([str(bags["lbr"]), "--robot", "iiwa14", "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--joint-states='joint_states'" in err
    assert "the bag has no /joint_states; did you mean --joint-states /lbr/joint_states?" in err
    assert "/lbr/ft_sensor/raw (geometry_msgs/msg/WrenchStamped, " in err
    args = [str(bags["turned"]), "--robot", "iiwa14", "--out", out, "--wrench", "/joint_states"]
    assert calibrate.main(args) == 2
    err = capsys.readouterr().err
    assert "/joint_states is sensor_msgs/msg/JointState" in err
    assert "did you mean --wrench /ft_sensor/raw?" in err


def test_wrong_joint_names_or_no_robot(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "payload.yaml")
    assert calibrate.main([str(bags["turned"]), "--robot", "ur5", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "/joint_states names=['iiwa_joint_1'" in err
    assert "all of ur5's joints ['shoulder_pan_joint'" in err and "is --robot right?" in err
    assert calibrate.main([str(bags["turned"]), "--out", out]) == 2
    assert "--robot=None" in capsys.readouterr().err
    assert calibrate.main([str(tmp_path / "none.mcap"), "--robot", "iiwa14", "--out", out]) == 2
    assert "none.mcap" in capsys.readouterr().err


def test_dynamic_fit_from_a_bag(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every paired reading, moves included, with the joints' motion interpolated at its
    stamp: the inertia too. The moves between the poses turn the sensor about every axis
    (measured: 0.1 g, 0.06 mm, 0.03 g m² off; condition number 1.95)."""
    out = tmp_path / "payload.yaml"
    args = [str(bags["1kHz"]), "--robot", "iiwa14", "--out", str(out), *SENSOR, "--dynamic"]
    status = calibrate.main(args)
    report = capsys.readouterr().out
    assert status == 0, report
    assert "dynamic fit of 12120 samples" in report and "refused 0" in report
    payload, bias = load_calibration(out)
    assert payload.mass == pytest.approx(HOLDER.mass, abs=0.005)
    np.testing.assert_allclose(payload.com, HOLDER.com, atol=5e-4)
    np.testing.assert_allclose(payload.inertia, HOLDER.inertia, atol=1e-4)
    np.testing.assert_allclose(bias[:3], BIAS[:3], atol=0.01)
    np.testing.assert_allclose(bias[3:], BIAS[3:], atol=1e-3)


def test_the_report_condition_matches_the_poses_chosen() -> None:
    """calibration_poses' figure is the one the command reports for its poses (same sensor)."""
    robot = iiwa()
    gravity = [cp.gravity_in_frame(robot, q, SENSOR_FRAME) for q in poses().q]
    assert cp.condition(gravity) == pytest.approx(poses().condition, rel=1e-12)


def test_without_robot_the_model_comes_from_the_bags_robot_description(
    bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The committed session latched its URDF: the model is taken from it. The arm held one
    pose there (an insertion), so the fit is refused, saying which joint to turn; a bag
    without a description needs --robot."""
    session = Path(__file__).resolve().parents[1] / "data" / "bags" / "short_interference"
    status = calibrate.main([str(session), "--out", str(tmp_path / "p.yaml")])
    captured = capsys.readouterr()
    assert status == 1
    assert "model from /robot_description (7 joints, the sensor on iiwa_flange)" in captured.out
    assert "condition number inf over 1 poses" in captured.err and "iiwa_joint_5" in captured.err
    assert calibrate.main([str(bags["1kHz"]), "--out", str(tmp_path / "q.yaml")]) == 2
    assert "the bag holds no robot_description" in capsys.readouterr().err
