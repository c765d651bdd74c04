"""fbcc-calibrate's input from a bag (a rosbag2 folder or an .mcap) of the arm moving through
poses: the topics named as given, the joint states and raw readings as series, the arm's model
from ``--robot`` or the bag's robot_description, and the static and dynamic fits of them
(:mod:`fbcc_ros.cli.calibrate` has the command and its doc)."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

from fbcc_ros.bag.reader import Bag, read_bag
from fbcc_ros.cli.calibration_report import poses_table, write
from fbcc_ros.core.compensation import calibration_data as cd
from fbcc_ros.core.compensation import calibration_poses as cp
from fbcc_ros.core.compensation.compensator import SENSOR_FRAME, sensor_motion
from fbcc_ros.core.compensation.payload import Motion, calibrate
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.kinematics.robot import ROBOTS, RobotModel, pose
from fbcc_ros.ros.cdr import decode_string
from fbcc_ros.ros.convert import joints_from_cdr, wrench_from_cdr

#: The cell's topics (fbcc_ros.ros.topics, without importing rclpy) and their types.
JOINT_STATES, RAW_WRENCH = "joint_states", "ft_sensor/raw"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
WRENCH_TYPE = "geometry_msgs/msg/WrenchStamped"


def sensor_robot(args: argparse.Namespace) -> RobotModel:
    robot = RobotModel.from_name(args.robot)
    robot.add_frame(SENSOR_FRAME, pose(args.sensor_xyz, args.sensor_rpy))
    return robot


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
        return sensor_robot(args), f"model {args.robot}"
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


def main_bag(args: argparse.Namespace) -> int:
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
            print(poses_table(samples, gravity, cp.excitation(gravity), start))
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
    table = poses_table(samples, gravity, result, start, fit)
    write(
        args,
        fit,
        motions,
        samples.wrench,
        f"{len(samples.dwells)} poses from {args.data.name}",
        tuple(lines),
        table,
    )
    return 0


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
    write(
        args,
        fit,
        motions,
        samples.wrench,
        f"{fit.samples} samples from {args.data.name}",
        tuple(lines),
    )
    return 0

