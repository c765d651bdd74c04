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
import datetime
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fbcc_ros.bag.reader import Bag, read_bag
from fbcc_ros.core.compensation import calibration_data as cd
from fbcc_ros.core.compensation import calibration_poses as cp
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
from fbcc_ros.ros.cdr import decode_string
from fbcc_ros.ros.convert import joints_from_cdr, wrench_from_cdr

WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
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


#: The cell's topics (fbcc_ros.ros.topics, without importing rclpy) and their types.
JOINT_STATES, RAW_WRENCH = "joint_states", "ft_sensor/raw"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
WRENCH_TYPE = "geometry_msgs/msg/WrenchStamped"


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
    if is_bag(args.data):
        return _main_bag(args)
    columns = read_columns(args.data)
    robot = _robot(args) if args.robot else None
    motions = motions_from_data(columns, args.dynamic, robot)
    wrenches = _take(columns, WRENCH)
    try:
        fit = calibrate(motions, wrenches, args.dynamic, args.max_condition)
    except InputError as exc:
        print(f"fbcc-calibrate: fit refused: {exc}", file=sys.stderr)
        return 1
    _write(args, fit, motions, wrenches, f"{fit.samples} samples from {args.data.name}")
    return 0


def _robot(args: argparse.Namespace) -> RobotModel:
    robot = RobotModel.from_name(args.robot)
    robot.add_frame(SENSOR_FRAME, pose(args.sensor_xyz, args.sensor_rpy))
    return robot


def _write(args: argparse.Namespace, fit: Calibration, motions: list[Motion],
           wrenches: np.ndarray, source: str, lines: tuple[str, ...] = (),
           after: str = "") -> None:  # fmt: skip
    """The report on stdout and in the YAML's header (``lines`` after its first), then
    ``after`` on stdout only."""
    mode = "dynamic" if args.dynamic else "static"
    p = fit.payload
    report = "\n".join([
        f"fbcc-calibrate {mode} fit of {source}, {datetime.date.today().isoformat()}",
        *lines,
        f"mass {p.mass:.4f} kg, centre of mass {np.round(p.com, 5).tolist()} m",
        f"bias {np.round(fit.bias, 4).tolist()} N, N m",
        f"residual rms {fit.residual_rms[0]:.4g} N, {fit.residual_rms[1]:.4g} N m; "
        f"condition number {fit.condition:.3g}",
    ])  # fmt: skip
    if args.dynamic:
        report += f"\ninertia about the centre of mass {np.round(p.inertia, 6).tolist()} kg m^2"
    for warning in implausible(fit):
        report += f"\nWARNING: {warning}"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(calibration_yaml(fit, report))
    if args.plot:
        _plot(fit, motions, wrenches, args.plot)
    print(report)
    if after:
        print(after)
    print(f"wrote {args.out}")


# --- a bag


def is_bag(path: Path) -> bool:
    """A bag folder or an .mcap file (read_bag says if it is not one)."""
    return path.is_dir() or path.suffix == ".mcap"


def _same_type(a: str, b: str) -> bool:
    """``sensor_msgs/msg/JointState`` and ``sensor_msgs/JointState`` name one type."""
    return a.replace("/msg/", "/") == b.replace("/msg/", "/")


def bag_topic(bag: Bag, given: str, kind: str, option: str) -> str:
    """The bag's topic that ``given`` names (relative, absolute or with its namespace), of type
    ``kind`` and with messages; else an InputError listing the bag's topics."""
    name = "/" + given.strip().strip("/")
    if _same_type(bag.topics.get(name, ""), kind) and bag.counts[name]:
        return name
    have = ", ".join(f"{t} ({k}, {bag.counts[t]})" for t, k in sorted(bag.topics.items()))
    if name in bag.topics:
        why = f"{name} is {bag.topics[name]} with {bag.counts[name]} messages"
    else:
        why = f"the bag has no {name}"
    typed = [t for t, k in bag.topics.items() if _same_type(k, kind) and bag.counts[t]]
    ending = [t for t in typed if t.endswith(name)]  # the same name under a namespace
    if ending or typed:
        why += f"; did you mean {option} {(ending or typed)[0]}?"
    raise InputError(option, given, f"a {kind} topic of {bag.path.name} with messages ({why}); "
                     f"the bag's topics: {have or 'none'}")  # fmt: skip


def _by_time(t: list[float], *columns: np.ndarray) -> tuple[np.ndarray, ...]:
    """Sorted by stamp, repeated stamps dropped (the first kept)."""
    stamps = np.asarray(t, dtype=float)
    order = np.argsort(stamps, kind="stable")
    stamps = stamps[order]
    keep = np.concatenate(([True], np.diff(stamps) > 0))
    return (stamps[keep], *(c[order][keep] for c in columns))


def bag_series(bag: Bag, joint_topic: str, wrench_topic: str, robot: RobotModel
               ) -> tuple[cd.JointStates, cd.Readings, Counter[str]]:  # fmt: skip
    """The joint states (in the robot's joint order) and the readings of the two topics, and
    the readings' frame_ids."""
    names = robot.joint_names
    t, q, dq = [], [], []
    for m in bag.of(joint_topic):
        try:
            stamp, position, velocity = joints_from_cdr(m.data, names)
        except InputError as exc:
            if exc.field != "joint_states.name":
                raise
            raise InputError(f"{joint_topic} names", exc.value,
                             f"all of {robot.name}'s joints {list(names)} (is --robot "
                             "right?)") from None  # fmt: skip
        t.append(stamp)
        q.append(position)
        dq.append(velocity)
    recorded = all(v is not None for v in dq)
    velocities = np.array(dq if recorded else q, dtype=float)
    tj, qj, vj = _by_time(t, np.array(q, dtype=float), velocities)
    if len(tj) < 2:
        raise InputError(joint_topic, f"{len(tj)} distinct stamps", "at least 2 joint states")
    frames: Counter[str] = Counter()
    tw, w = [], []
    for m in bag.of(wrench_topic):
        stamp, frame, wrench = wrench_from_cdr(m.data)
        frames[frame] += 1
        tw.append(stamp)
        w.append(wrench)
    order = np.argsort(np.asarray(tw), kind="stable")
    readings = cd.Readings(np.asarray(tw, dtype=float)[order],
                           np.asarray(w, dtype=float).reshape(-1, 6)[order])  # fmt: skip
    return cd.JointStates(tj, qj, vj if recorded else None), readings, frames


def _rate(t: np.ndarray) -> str:
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    return f"{1 / step:.4g} Hz" if step > 0 else "one stamp"


DESCRIPTION_TYPE = "std_msgs/msg/String"


def bag_robot(args: argparse.Namespace, bag: Bag) -> tuple[RobotModel, str]:
    """The arm of ``--robot``, or of the URDF the bag latched on its robot_description; and
    where it came from, for the report."""
    if args.robot:
        if args.flange_frame or args.locked_joints:
            raise InputError("--flange-frame/--locked-joints", args.flange_frame or
                             args.locked_joints, f"none with --robot {args.robot} (a built-in "
                             "model names its own)")  # fmt: skip
        return _robot(args), f"model {args.robot}"
    latched = [t for t, k in sorted(bag.topics.items())
               if t.endswith("/robot_description") and _same_type(k, DESCRIPTION_TYPE)
               and bag.counts[t]]  # fmt: skip
    if len(latched) != 1:
        why = ("the bag holds no robot_description" if not latched
               else f"the bag holds several robot_descriptions {latched}")  # fmt: skip
        raise InputError("--robot", None, f"one of {sorted(ROBOTS)} to read this bag: its "
                         f"joint names, and the sensor's orientation by FK ({why} to take the "
                         "model from)")  # fmt: skip
    text = decode_string(next(iter(bag.of(latched[0]))).data)
    robot = RobotModel(text, args.flange_frame, None, args.locked_joints, name=latched[0])
    robot.add_frame(SENSOR_FRAME, pose(args.sensor_xyz, args.sensor_rpy))
    return robot, (f"model from {latched[0]} ({robot.nq} joints, the sensor on "
                   f"{robot.flange_frame})")  # fmt: skip


def _main_bag(args: argparse.Namespace) -> int:
    bag = read_bag(args.data)
    robot, model = bag_robot(args, bag)
    joint_topic = bag_topic(bag, args.joint_states, JOINT_STATE_TYPE, "--joint-states")
    wrench_topic = bag_topic(bag, args.wrench, WRENCH_TYPE, "--wrench")
    joints, readings, frames = bag_series(bag, joint_topic, wrench_topic, robot)
    velocity = (
        "velocities recorded"
        if joints.dq is not None
        else "no velocities: differentiated from the positions"
    )
    lines = [
        model,
        f"read {joint_topic} ({len(joints.t)} joint states, {_rate(joints.t)}, {velocity}), "
        f"{wrench_topic} ({len(readings.t)} readings, {_rate(readings.t)}, frame "
        + ", ".join(f"'{f}'" for f in frames)
        + ")",
    ]
    if bag.truncated:
        lines.append(f"note: the bag ends early ({bag.truncated}); read up to there")
    if args.dynamic:
        return _dynamic_bag(args, robot, joints, readings, lines)
    return _static_bag(args, robot, joints, readings, lines)


def _paired(pairing: cd.Pairing) -> str:
    return (f"paired {int(pairing.ok.sum())} readings with the nearest joint state; refused "
            f"{pairing.refused} further than {pairing.max_gap * 1e3:g} ms from any")  # fmt: skip


def _static_bag(args: argparse.Namespace, robot: RobotModel, joints: cd.JointStates,
                readings: cd.Readings, lines: list[str]) -> int:  # fmt: skip
    samples = cd.static_samples(joints, readings, speed=args.dwell_speed,
                                min_dwell=args.min_dwell)  # fmt: skip
    speed, min_dwell, settle, lead = samples.thresholds
    lines += [
        _paired(samples.pairing),
        f"poses: {len(samples.dwells)} held still (every joint under {speed:g} rad/s for at "
        f"least {min_dwell:g} s; the first {settle:g} s and last {lead:g} s of each dropped)"
        + (f"; {samples.empty} more without a paired reading" if samples.empty else ""),
    ]
    q = samples.q
    start = min(joints.t[0], readings.t[0]) if len(readings.t) else joints.t[0]
    gravity = np.array([cp.gravity_in_frame(robot, qk, SENSOR_FRAME) for qk in q])
    condition = cp.condition(gravity)  # infinite for fewer than 3 poses
    if not condition <= args.max_condition:
        print("\n".join(lines))
        if len(gravity):
            print(_poses_table(samples, gravity, cp.excitation(gravity), start))
        why = cp.explain(gravity, robot, q, SENSOR_FRAME)
        if not len(gravity):
            why = (f"no pose held still: the joints were never all slower than {speed:g} rad/s "
                   f"for {min_dwell:g} s (--dwell-speed, --min-dwell); hold each pose for half "
                   "a second, or fit the moving arm with --dynamic")  # fmt: skip
        print(f"fbcc-calibrate: fit refused: condition number {condition:.3g} over "
              f"{len(gravity)} poses (limit {args.max_condition:.3g}): {why}",
              file=sys.stderr)  # fmt: skip
        return 1
    motions = [Motion(g) for g in gravity]
    fit = calibrate(motions, samples.wrench, False, args.max_condition)
    result = cp.excitation(gravity)
    s = result.spread
    lines.append(
        "gravity in {S} over the poses: "
        + ", ".join(
            f"{a} [{lo:.2f}, {hi:.2f}] g" for a, lo, hi in zip("xyz", s.low, s.high, strict=True)
        )
    )
    table = _poses_table(samples, gravity, result, start, fit)
    _write(
        args,
        fit,
        motions,
        samples.wrench,
        f"{len(samples.dwells)} poses from {args.data.name}",
        tuple(lines),
        table,
    )
    return 0


def _poses_table(samples: cd.StaticSamples, gravity: np.ndarray, result: cp.Excitation,
                 start: float, fit: Calibration | None = None) -> str:  # fmt: skip
    """One line per pose: when (from ``start``), how many readings, gravity's direction, what
    it adds to the condition number, and (after a fit) its residual beside its noise."""
    head = f"{'pose':>4}  {'averaged [s]':>13}  {'readings':>8}  {'gravity in {S} [g]':>20}  "
    head += f"{'condition without':<22}"
    if fit is not None:
        head += f"{'residual F [N]':>14}  {'T [N m]':>8}  {'s.e. F [N]':>10}  {'T [N m]':>8}"
    out = [head.rstrip()]
    for k, (dwell, g) in enumerate(zip(samples.dwells, gravity, strict=True)):
        u = g / np.linalg.norm(g)
        w0, w1 = dwell.window[0] - start, dwell.window[1] - start
        gravity_text = "[" + " ".join(f"{round(x, 2) + 0.0:+.2f}" for x in u) + "]"
        line = (f"{k + 1:>4}  {w0:>6.2f}-{w1:<6.2f}  {dwell.readings:>8}  {gravity_text:>20}  "
                f"{f'{result.without[k]:.3g} ({result.roles[k]})':<22}")  # fmt: skip
        if fit is not None:
            residual = dwell.wrench - payload_wrench(fit.payload, Motion(g)) - fit.bias
            error = dwell.standard_error
            line += (f"{np.linalg.norm(residual[:3]):>14.3g}  "
                     f"{np.linalg.norm(residual[3:]):>8.3g}  {np.linalg.norm(error[:3]):>10.3g}"
                     f"  {np.linalg.norm(error[3:]):>8.3g}")  # fmt: skip
        out.append(line.rstrip())
    out.append(f"condition number over all {len(gravity)}: {result.condition:.3g} (without a "
               f"'needed' pose it grows {cp.NEEDED_RATIO:g}x or more; without a 'redundant' "
               f"one under {(cp.REDUNDANT_RATIO - 1) * 100:g} %)")  # fmt: skip
    return "\n".join(out)


#: At most this many of a trajectory's samples are looked at to say what it lacks.
EXPLAIN_SAMPLES = 50


def _dynamic_bag(args: argparse.Namespace, robot: RobotModel, joints: cd.JointStates,
                 readings: cd.Readings, lines: list[str]) -> int:  # fmt: skip
    samples = cd.dynamic_samples(joints, readings)
    lines.append(_paired(samples.pairing))
    states = zip(samples.q, samples.dq, samples.ddq, strict=True)
    motions = [sensor_motion(robot, *state)[1] for state in states]
    try:
        fit = calibrate(motions, samples.wrench, True, args.max_condition)
    except InputError as exc:
        print("\n".join(lines))
        pick = np.linspace(0, len(motions) - 1, min(len(motions), EXPLAIN_SAMPLES)).astype(int)
        gravity = np.array([motions[i].gravity for i in pick]).reshape(-1, 3)
        static = cp.explain(gravity, robot, samples.q[pick], SENSOR_FRAME) if len(pick) else ""
        print(f"fbcc-calibrate: fit refused: {exc}" + (f"; {static}" if static else ""),
              file=sys.stderr)  # fmt: skip
        return 1
    _write(
        args,
        fit,
        motions,
        samples.wrench,
        f"{fit.samples} samples from {args.data.name}",
        tuple(lines),
    )
    return 0
