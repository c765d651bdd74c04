"""fbcc-calibrate: identify the payload and the sensor bias from recorded data, write the YAML the
dynamic_compensation node loads.

    fbcc-calibrate DATA.csv|DATA.npz --out payload.yaml [--dynamic]
                   [--robot iiwa14 [--sensor-xyz X Y Z --sensor-rpy R P Y]]
                   [--max-condition 1000] [--plot residual.png]

DATA holds one sample per row (CSV, with a header) or one 1-D array per name (npz):

* the raw reading in the sensor frame {S}: ``fx fy fz tx ty tz`` [N, N m];
* the sensor's orientation, either as the quaternion ``qx qy qz qw`` of ``R_base_S`` or, with
  ``--robot``, as the arm's joint positions (columns named as the robot's joints, e.g.
  ``iiwa_joint_1``) with the sensor at ``--sensor-xyz/--sensor-rpy`` in the flange frame;
* with ``--dynamic``: either the motion in {S}, ``ax ay az`` (linear acceleration, gravity
  excluded) ``wx wy wz`` (angular velocity) ``dwx dwy dwz`` (angular acceleration), or, with
  ``--robot``, the time ``t`` [s] and the joint velocities ``v_<joint>``, differentiated once.

Static mode fits mass, centre of mass and bias (10 parameters) from at least 3 poses; dynamic mode
adds the inertia (16). The fit is refused, with exit status 1, when the samples do not excite every
parameter (the condition number is printed); exit status 2 on bad input.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fbcc_ros.core.compensation.compensator import SENSOR_FRAME, calibration_yaml, sensor_motion
from fbcc_ros.core.compensation.payload import (
    GRAVITY_BASE,
    MAX_CONDITION,
    Calibration,
    Motion,
    calibrate,
    payload_wrench,
)
from fbcc_ros.core.errors import InputError, command
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel, pose

WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
QUATERNION = ("qx", "qy", "qz", "qw")
MOTION = ("ax", "ay", "az", "wx", "wy", "wz", "dwx", "dwy", "dwz")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fbcc-calibrate",
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("data", type=Path, help="samples: .csv with a header, or .npz")
    parser.add_argument("--out", required=True, type=Path, help="parameter YAML to write")
    parser.add_argument("--dynamic", action="store_true", help="identify the inertia too")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="orientation from joints by FK")
    parser.add_argument("--sensor-xyz", type=float, nargs=3, default=(0.0, 0.0, 0.0))
    parser.add_argument("--sensor-rpy", type=float, nargs=3, default=(0.0, 0.0, 0.0))
    parser.add_argument("--max-condition", type=float, default=MAX_CONDITION)
    parser.add_argument("--plot", type=Path, help="PNG of the residual per sample")
    return parser


#: Beyond these the fit is no payload of an arm's wrist (the arms modelled carry 3-14 kg): the
#: data's units are the likely cause (forces in mN, torques in N mm).
PLAUSIBLE_MASS_KG = 50.0
PLAUSIBLE_COM_M = 0.5


def implausible(fit: Calibration) -> list[str]:
    """What in a fit no wrist payload would give, and the likely cause."""
    out = []
    if fit.payload.mass > PLAUSIBLE_MASS_KG:
        out.append(f"mass {fit.payload.mass:.4g} kg is more than {PLAUSIBLE_MASS_KG:g} kg: "
                   "are the forces in N (not mN)?")  # fmt: skip
    com = float(np.linalg.norm(fit.payload.com))
    if com > PLAUSIBLE_COM_M:
        out.append(f"centre of mass {com:.4g} m from the sensor is more than {PLAUSIBLE_COM_M:g} m"
                   ": are the torques in N m (not N mm) and the forces in N?")  # fmt: skip
    return out


def read_columns(path: Path) -> dict[str, np.ndarray]:
    """Named 1-D float columns of a CSV (with a header) or an npz file."""
    if not path.is_file():
        raise InputError("data", str(path), "an existing .csv or .npz file")
    try:
        if path.suffix == ".npz":
            with np.load(path) as npz:
                return {k: np.asarray(npz[k], dtype=float).reshape(-1) for k in npz.files}
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
        header, body = rows[0], [r for r in rows[1:] if r]
        values = np.array(body, dtype=float).reshape(len(body), len(header))
        return {name.strip(): values[:, i] for i, name in enumerate(header)}
    except (ValueError, IndexError, OSError) as exc:
        raise InputError(
            "data", str(path), f"a CSV with a header row of names and numbers below it ({exc})"
        ) from exc


def _take(columns: dict[str, np.ndarray], names: tuple[str, ...] | list[str]) -> np.ndarray:
    missing = [n for n in names if n not in columns]
    if missing:
        raise InputError("data", f"missing columns {missing}", f"columns {list(names)}")
    return np.column_stack([columns[n] for n in names])


def motions_from_data(
    columns: dict[str, np.ndarray], dynamic: bool, robot: RobotModel | None
) -> list[Motion]:
    """The sensor's motion at each sample, from the columns the module doc lists."""
    if robot is None:
        quats = _take(columns, QUATERNION)
        norms = np.linalg.norm(quats, axis=1)
        if not (norms > 1e-6).all():  # a quaternion of (almost) zero norm is no rotation
            row = int(np.argmin(norms))
            raise InputError(f"quaternion of sample {row}", quats[row].tolist(),
                             "(qx, qy, qz, qw) of non-zero norm")  # fmt: skip
        rotations = Rotation.from_quat(quats).as_matrix()
        if not dynamic:
            return [Motion.at_rest(r) for r in rotations]
        m = _take(columns, MOTION)
        return [
            Motion(r.T @ GRAVITY_BASE, row[:3], row[3:6], row[6:])
            for r, row in zip(rotations, m, strict=True)
        ]
    q = _take(columns, list(robot.joint_names))
    if not dynamic:
        return [Motion.at_rest(robot.frame_in_base(qi, SENSOR_FRAME).rotation) for qi in q]
    t = _take(columns, ("t",))[:, 0]
    if not (np.diff(t) > 0).all():
        raise InputError("data.t", "not increasing", "strictly increasing sample times [s]")
    dq = _take(columns, [f"v_{j}" for j in robot.joint_names])
    ddq = np.gradient(dq, t, axis=0)  # central differences of the joint velocities
    return [sensor_motion(robot, *state)[1] for state in zip(q, dq, ddq, strict=True)]


def _plot(fit: Calibration, motions: list[Motion], wrenches: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model = np.array([payload_wrench(fit.payload, m) for m in motions]) + fit.bias
    residual = wrenches - model
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for i, name in enumerate(WRENCH[:3]):
        top.plot(residual[:, i], ".-", label=name)
    for i, name in enumerate(WRENCH[3:]):
        bottom.plot(residual[:, 3 + i] * 1e3, ".-", label=name)
    top.set_ylabel("force residual [N]")
    bottom.set_ylabel("torque residual [mN m]")
    bottom.set_xlabel("sample")
    top.set_title(
        f"calibration residual: rms {fit.residual_rms[0]:.3g} N, "
        f"{fit.residual_rms[1] * 1e3:.3g} mN m; condition {fit.condition:.3g}"
    )
    top.legend(ncol=3, fontsize=8)
    bottom.legend(ncol=3, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


@command("fbcc-calibrate")
def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    columns = read_columns(args.data)
    robot = None
    if args.robot:
        robot = RobotModel.from_name(args.robot)
        robot.add_frame(SENSOR_FRAME, pose(args.sensor_xyz, args.sensor_rpy))
    motions = motions_from_data(columns, args.dynamic, robot)
    wrenches = _take(columns, WRENCH)
    try:
        fit = calibrate(motions, wrenches, args.dynamic, args.max_condition)
    except InputError as exc:
        print(f"fbcc-calibrate: fit refused: {exc}", file=sys.stderr)
        return 1
    mode = "dynamic" if args.dynamic else "static"
    p = fit.payload
    report = (
        f"fbcc-calibrate {mode} fit of {fit.samples} samples from {args.data.name}, "
        f"{datetime.date.today().isoformat()}\n"
        f"mass {p.mass:.4f} kg, centre of mass {np.round(p.com, 5).tolist()} m\n"
        f"bias {np.round(fit.bias, 4).tolist()} N, N m\n"
        f"residual rms {fit.residual_rms[0]:.4g} N, {fit.residual_rms[1]:.4g} N m; "
        f"condition number {fit.condition:.3g}"
    )
    if args.dynamic:
        report += f"\ninertia about the centre of mass {np.round(p.inertia, 6).tolist()} kg m^2"
    for warning in implausible(fit):
        report += f"\nWARNING: {warning}"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(calibration_yaml(fit, report))
    if args.plot:
        _plot(fit, motions, wrenches, args.plot)
    print(report)
    print(f"wrote {args.out}")
    return 0
