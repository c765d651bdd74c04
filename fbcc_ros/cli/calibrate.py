"""fbcc-calibrate: identify the payload and the sensor bias from recorded data, write the YAML the
dynamic_compensation node loads.

    fbcc-calibrate DATA.csv|DATA.npz --out payload.yaml [--dynamic]
                   [--robot iiwa14 [--sensor-xyz X Y Z --sensor-rpy R P Y]]
                   [--max-condition 1000] [--plot residual.png]
    fbcc-calibrate BAG [--robot iiwa14 | --flange-frame LINK --locked-joints J ...]
                   --out payload.yaml [--dynamic]
                   [--joint-states joint_states] [--wrench ft_sensor/raw]
                   [--dwell-speed 0.01] [--min-dwell 0.3] [--sensor-xyz ... --sensor-rpy ...]

DATA holds one sample per row (CSV, with a header) or one 1-D array per name (npz):

* the raw reading in the sensor frame {S}: ``fx fy fz tx ty tz`` [N, N m];
* the sensor's orientation, either as the quaternion ``qx qy qz qw`` of ``R_base_S`` or, with
  ``--robot``, as the arm's joint positions (columns named as the robot's joints, e.g.
  ``iiwa_joint_1``) with the sensor at ``--sensor-xyz/--sensor-rpy`` in the flange frame;
* with ``--dynamic``: either the motion in {S}, ``ax ay az`` (linear acceleration, gravity
  excluded) ``wx wy wz`` (angular velocity) ``dwx dwy dwz`` (angular acceleration), or, with
  ``--robot``, the time ``t`` [s] and the joint velocities ``v_<joint>``, differentiated once.

A BAG (a rosbag2 folder with its .mcap, or an .mcap file) of the arm moving through poses, as a
real cell records it (or ``fbcc_bringup --calibration-motion`` on the mock), takes the arm's
model from ``--robot``, or else from the URDF the bag recorded on its ``robot_description``
(std_msgs/String, under any namespace; ``--flange-frame`` names the link the sensor is on when
the chain has several tips, ``--locked-joints`` a gripper's joints). It is read on two topics,
each given relative (``joint_states``), absolute (``/joint_states``) or with its namespace
(``/lbr/joint_states``):

* ``--joint-states`` (sensor_msgs/JointState): matched to the robot's joints by name, in any
  order, extra joints ignored;
* ``--wrench`` (geometry_msgs/WrenchStamped): the raw reading in {S}.

Each reading is paired with the joint state nearest in time (by the stamps; further than 15 ms
apart: refused and counted). Static mode averages each pose held still (every joint slower than
``--dwell-speed`` for at least ``--min-dwell``) into one sample and reports what each pose adds
to the fit's condition number and its residual; dynamic mode fits every paired reading
(:mod:`fbcc_ros.core.compensation.calibration_data`). Poses that excite the fit well:
:func:`fbcc_ros.core.compensation.calibration_poses.calibration_poses`.

Static mode fits mass, centre of mass and bias (10 parameters) from at least 3 poses; dynamic mode
adds the inertia (16). The fit is refused, with exit status 1, when the samples do not excite every
parameter (the condition number is printed; for a bag, with what is missing and which joint to
turn); exit status 2 on bad input (a bag without the topics lists the ones it has).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fbcc_ros.cli.calibrate_bag import JOINT_STATES, RAW_WRENCH, is_bag, main_bag, sensor_robot
from fbcc_ros.cli.calibration_report import WRENCH, write
from fbcc_ros.core.compensation import calibration_data as cd
from fbcc_ros.core.compensation.compensator import SENSOR_FRAME, sensor_motion
from fbcc_ros.core.compensation.payload import GRAVITY_BASE, MAX_CONDITION, Motion, calibrate
from fbcc_ros.core.errors import InputError, command
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel

QUATERNION = ("qx", "qy", "qz", "qw")
MOTION = ("ax", "ay", "az", "wx", "wy", "wz", "dwx", "dwy", "dwz")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fbcc-calibrate",
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "data", type=Path, help="samples: .csv with a header, or .npz; or a bag (folder or .mcap)"
    )
    parser.add_argument("--out", required=True, type=Path, help="parameter YAML to write")
    parser.add_argument("--dynamic", action="store_true", help="identify the inertia too")
    parser.add_argument("--robot", choices=sorted(ROBOTS), help="orientation from joints by FK")
    parser.add_argument("--sensor-xyz", type=float, nargs=3, default=(0.0, 0.0, 0.0))
    parser.add_argument("--sensor-rpy", type=float, nargs=3, default=(0.0, 0.0, 0.0))
    parser.add_argument("--max-condition", type=float, default=MAX_CONDITION)
    parser.add_argument("--plot", type=Path, help="PNG of the residual per sample")
    bag = parser.add_argument_group("a bag")
    bag.add_argument(
        "--joint-states",
        default=JOINT_STATES,
        metavar="TOPIC",
        help=f"sensor_msgs/JointState topic (default {JOINT_STATES})",
    )
    bag.add_argument(
        "--wrench",
        default=RAW_WRENCH,
        metavar="TOPIC",
        help=f"geometry_msgs/WrenchStamped topic, in the sensor frame (default {RAW_WRENCH})",
    )
    bag.add_argument(
        "--flange-frame",
        default="",
        metavar="LINK",
        help="without --robot: the link the sensor is mounted on (default: the chain's tip)",
    )
    bag.add_argument(
        "--locked-joints",
        nargs="+",
        default=[],
        metavar="JOINT",
        help="without --robot: joints of the description held at zero (a gripper's)",
    )
    bag.add_argument(
        "--dwell-speed",
        type=float,
        default=cd.DWELL_SPEED,
        metavar="RAD_S",
        help=f"a pose is held while every joint is slower [rad/s] (default {cd.DWELL_SPEED})",
    )
    bag.add_argument(
        "--min-dwell",
        type=float,
        default=cd.MIN_DWELL,
        metavar="S",
        help=f"for at least this long [s] (default {cd.MIN_DWELL})",
    )
    return parser  # fmt: skip



def read_columns(path: Path) -> dict[str, np.ndarray]:
    """Named 1-D float columns of a CSV (with a header) or an npz file."""
    if not path.is_file():
        raise InputError("data", str(path), "an existing .csv or .npz file, or a bag (a folder "
                         "with its .mcap, or an .mcap file)")  # fmt: skip
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


@command("fbcc-calibrate")
def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if is_bag(args.data):
        return main_bag(args)
    columns = read_columns(args.data)
    robot = sensor_robot(args) if args.robot else None
    motions = motions_from_data(columns, args.dynamic, robot)
    wrenches = _take(columns, WRENCH)
    try:
        fit = calibrate(motions, wrenches, args.dynamic, args.max_condition)
    except InputError as exc:
        print(f"fbcc-calibrate: fit refused: {exc}", file=sys.stderr)
        return 1
    write(args, fit, motions, wrenches, f"{fit.samples} samples from {args.data.name}")
    return 0


