"""fbcc-calibrate as a user runs it: recorded samples in, the node's parameter YAML out, with
the fit's quality reported and ill-posed data refused."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fbcc_ros.cli import calibrate
from fbcc_ros.core.compensation.calibration_file import load_calibration
from fbcc_ros.core.compensation.compensator import SENSOR_FRAME
from fbcc_ros.core.compensation.payload import GRAVITY_BASE, Motion, Payload, payload_wrench
from fbcc_ros.core.kinematics.robot import RobotModel, pose

HOLDER = Payload(0.8, (0.004, -0.002, 0.06), ((4e-3, 2e-4, 0), (2e-4, 3e-3, 0), (0, 0, 1.5e-3)))
BIAS = np.array([1.5, -0.7, 3.0, 0.05, -0.02, 0.01])
NOISE = np.array([0.05] * 3 + [0.002] * 3)
WRENCH = ["fx", "fy", "fz", "tx", "ty", "tz"]


def _write_csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        writer.writerows(np.column_stack(list(columns.values())).tolist())


def _write_quaternion_csv(path: Path, rotations: Rotation, readings: np.ndarray) -> None:
    """Static samples as a user records them: R_base_S as a quaternion, and the reading."""
    quat = rotations.as_quat()
    _write_csv(
        path,
        {**{k: quat[:, i] for i, k in enumerate(("qx", "qy", "qz", "qw"))},
         **{k: readings[:, i] for i, k in enumerate(WRENCH)}},
    )  # fmt: skip


def _readings(motions: list[Motion], seed: int) -> np.ndarray:
    clean = np.array([payload_wrench(HOLDER, m) for m in motions]) + BIAS
    return clean + np.random.default_rng(seed).normal(0.0, NOISE, clean.shape)


def test_static_csv_with_quaternions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rotations = Rotation.random(12, random_state=4)
    readings = _readings([Motion.at_rest(r) for r in rotations.as_matrix()], seed=5)
    data = tmp_path / "poses.csv"
    _write_quaternion_csv(data, rotations, readings)
    out, plot = tmp_path / "cfg" / "payload.yaml", tmp_path / "residual.png"
    assert calibrate.main([str(data), "--out", str(out), "--plot", str(plot)]) == 0
    payload, bias = load_calibration(out)
    assert payload.mass == pytest.approx(0.8, abs=0.02)
    np.testing.assert_allclose(payload.com, HOLDER.com, atol=2e-3)
    np.testing.assert_allclose(bias[:3], BIAS[:3], atol=0.06)
    assert np.all(np.array(payload.inertia) == 0.0)  # a static fit leaves the inertia out
    report = capsys.readouterr().out
    assert "static fit of 12 samples" in report and "residual rms" in report
    assert "# residual rms" in out.read_text()  # the quality travels with the file
    assert plot.stat().st_size > 10_000
    assert "WARNING" not in report


UNITS = [((1e3, 1.0), "forces in N (not mN)"), ((1.0, 1e3), "torques in N m (not N mm)")]


@pytest.mark.parametrize(("scale", "warned"), UNITS)
def test_readings_in_other_units_are_fitted_and_warned(
    scale: tuple[float, float], warned: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same poses with forces in mN (a 800 kg payload) or torques in N mm (its centre of
    mass 60 m away): the fit is written, and the report and the file say what looks wrong."""
    rotations = Rotation.random(12, random_state=4)
    readings = _readings([Motion.at_rest(r) for r in rotations.as_matrix()], seed=5)
    readings[:, :3] *= scale[0]
    readings[:, 3:] *= scale[1]
    data, out = tmp_path / "poses.csv", tmp_path / "payload.yaml"
    _write_quaternion_csv(data, rotations, readings)
    assert calibrate.main([str(data), "--out", str(out)]) == 0
    assert warned in capsys.readouterr().out and warned in out.read_text()


@pytest.fixture(scope="module")
def iiwa() -> RobotModel:
    robot = RobotModel.from_name("iiwa14")
    robot.add_frame(SENSOR_FRAME, pose((0, 0, 0.035), (0, 0, 0.5)))
    return robot


def test_static_npz_from_iiwa_joint_positions(tmp_path: Path, iiwa: RobotModel) -> None:
    rng = np.random.default_rng(8)
    q = iiwa.home + rng.uniform(-1.0, 1.0, (15, 7))
    q = np.clip(q, iiwa.lower, iiwa.upper)
    motions = [Motion.at_rest(iiwa.frame_in_base(qi, SENSOR_FRAME).rotation) for qi in q]
    readings = _readings(motions, seed=9)
    data = tmp_path / "poses.npz"
    np.savez(
        data,
        **{name: q[:, i] for i, name in enumerate(iiwa.joint_names)},
        **{k: readings[:, i] for i, k in enumerate(WRENCH)},
    )
    out = tmp_path / "payload.yaml"
    args = [str(data), "--out", str(out), "--robot", "iiwa14"]
    args += ["--sensor-xyz", "0", "0", "0.035", "--sensor-rpy", "0", "0", "0.5"]
    assert calibrate.main(args) == 0
    payload, bias = load_calibration(out)
    assert payload.mass == pytest.approx(0.8, abs=0.02)
    np.testing.assert_allclose(payload.com, HOLDER.com, atol=2e-3)
    np.testing.assert_allclose(bias[3:], BIAS[3:], atol=3e-3)


def test_dynamic_fit_from_an_iiwa_excitation_trajectory(
    tmp_path: Path, iiwa: RobotModel, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each joint on a sum of two sines (4 s at 250 Hz); the tool reads the holder's dynamic
    wrench; the command differentiates the recorded joint velocities and fits the inertia."""
    t = np.arange(0.0, 4.0, 1 / 250)
    freq = np.array([[0.3, 0.45, 0.6, 0.75, 0.9, 1.05, 1.2], [0.7, 0.85, 1.1, 1.3, 1.6, 1.9, 2.1]])
    amp = np.array([0.5, 0.4, 0.5, 0.4, 0.8, 0.6, 1.0])
    w = 2 * np.pi * freq
    q = iiwa.home + amp * (np.sin(w[0] * t[:, None]) + 0.5 * np.sin(w[1] * t[:, None]))
    dq = amp * (w[0] * np.cos(w[0] * t[:, None]) + 0.5 * w[1] * np.cos(w[1] * t[:, None]))
    ddq = -amp * (
        w[0] ** 2 * np.sin(w[0] * t[:, None]) + 0.5 * w[1] ** 2 * np.sin(w[1] * t[:, None])
    )
    motions = []
    for qi, dqi, ddqi in zip(q, dq, ddq, strict=True):
        placement, vel, acc = iiwa.frame_motion(qi, dqi, ddqi, SENSOR_FRAME)
        motions.append(
            Motion(placement.rotation.T @ GRAVITY_BASE, acc.linear, vel.angular, acc.angular)
        )
    readings = _readings(motions, seed=10)
    data = tmp_path / "excitation.csv"
    _write_csv(
        data,
        {"t": t,
         **{name: q[:, i] for i, name in enumerate(iiwa.joint_names)},
         **{f"v_{name}": dq[:, i] for i, name in enumerate(iiwa.joint_names)},
         **{k: readings[:, i] for i, k in enumerate(WRENCH)}},
    )  # fmt: skip
    out = tmp_path / "payload.yaml"
    args = [str(data), "--out", str(out), "--dynamic", "--robot", "iiwa14"]
    args += ["--sensor-xyz", "0", "0", "0.035", "--sensor-rpy", "0", "0", "0.5"]
    assert calibrate.main(args) == 0, capsys.readouterr().err
    payload, bias = load_calibration(out)
    assert payload.mass == pytest.approx(0.8, abs=0.01)
    np.testing.assert_allclose(payload.com, HOLDER.com, atol=1e-3)
    # to 0.05 g m² (measured 3e-6 kg m², despite differentiating the velocities)
    np.testing.assert_allclose(payload.inertia, HOLDER.inertia, atol=5e-5)
    np.testing.assert_allclose(bias[:3], BIAS[:3], atol=0.01)
    assert "dynamic fit of 1000 samples" in capsys.readouterr().out


def test_poses_about_one_axis_are_refused_with_the_condition_number(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rotations = Rotation.from_euler("z", np.linspace(0, 3, 8)[:, None])
    readings = _readings([Motion.at_rest(r) for r in rotations.as_matrix()], seed=1)
    data = tmp_path / "flat.csv"
    _write_quaternion_csv(data, rotations, readings)
    out = tmp_path / "payload.yaml"
    assert calibrate.main([str(data), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "fit refused" in err and "condition number" in err and "tilt the sensor" in err
    assert not out.exists()


def test_bad_data_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "payload.yaml")
    assert calibrate.main([str(tmp_path / "nope.csv"), "--out", out]) == 2
    assert "nope.csv" in capsys.readouterr().err
    partial = tmp_path / "partial.csv"
    _write_csv(
        partial, {"qx": np.zeros(3), "qy": np.zeros(3), "qz": np.zeros(3), "qw": np.ones(3)}
    )
    assert calibrate.main([str(partial), "--out", out]) == 2
    assert "missing columns ['fx', 'fy', 'fz', 'tx', 'ty', 'tz']" in capsys.readouterr().err
    garbage = tmp_path / "garbage.csv"
    garbage.write_text("qx,qy\n1,banana\n")
    assert calibrate.main([str(garbage), "--out", out]) == 2
    assert "header row of names" in capsys.readouterr().err
