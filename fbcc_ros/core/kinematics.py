"""Robot kinematics with Pinocchio: the paper's feature solution and TCP solution (Fig. 7).

* :class:`RobotModel` loads an arm by name (``iiwa14`` from this package's URDF; ``panda`` and
  ``ur5`` from example-robot-data) or from any URDF, and adds the peg (tool) frame {P} to its
  flange. It gives the FK of the peg frame and frame Jacobians.
* :func:`solve_ik` is a damped-least-squares closed-loop IK (CLIK) on the peg frame, warm-started
  from the current joints, that keeps every iterate inside the joint position limits and, for one
  control period ``dt``, inside the velocity limits. It never returns a pose it did not reach:
  when the target is out of reach or needs a joint beyond a limit it raises :class:`IkError`.
* :class:`CellKinematics` binds a robot to the hole's pose and the peg radius:
  ``features(q)`` is the feature solution and ``tcp_solution(x_c, q)`` the TCP solution.

Frames: ``base`` is the robot's root (the URDF's first link), {F} the flange, {P} the peg frame
(``fbcc_ros.core.features``: origin at the tip centre, z along the peg out of the flange), {H} the
hole frame. A pose named ``peg_in_base`` is ``T_base_P`` (``pin.SE3``).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.errors import ConfigError, FbccError, InputError
from fbcc_ros.core.features import (
    R_ALIGNED,
    features_from_pose,
    pose_from_features,
    spin_of,
)

FloatArray = NDArray[np.float64]

#: Name of the peg frame in every model this module builds.
PEG_FRAME = "peg"

_URDF_DIR = Path(__file__).resolve().parent.parent / "urdf"


def _example_robot_data(relative: str) -> Path:
    """A file of the example-robot-data wheel (installed under ``cmeel.prefix``)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:
        raise ConfigError(
            "robot", relative, "example-robot-data installed (pip install example-robot-data)"
        ) from exc
    return Path(str(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/{relative}")))


@dataclasses.dataclass(frozen=True)
class RobotSpec:
    """Where a named robot's model comes from.

    Attributes:
        urdf: Path of the URDF.
        flange_frame: The frame the tool is mounted on.
        locked_joints: Joints held at zero and removed from the model (e.g. gripper fingers).
        home: A configuration with the flange pointing down over the table [rad].
    """

    urdf: Path
    flange_frame: str
    locked_joints: tuple[str, ...] = ()
    home: tuple[float, ...] = ()


#: Robots known by name. The iiwa's net pitch q2 - q4 + q6 = pi points its flange down.
ROBOTS: dict[str, Callable[[], RobotSpec]] = {
    "iiwa14": lambda: RobotSpec(
        urdf=_URDF_DIR / "iiwa14.urdf",
        flange_frame="iiwa_flange",
        home=(0.0, 0.5, 0.0, -1.5, 0.0, math.pi - 2.0, 0.0),
    ),
    "panda": lambda: RobotSpec(
        urdf=_example_robot_data("panda_description/urdf/panda.urdf"),
        flange_frame="panda_link8",
        locked_joints=("panda_finger_joint1", "panda_finger_joint2"),
        home=(0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785),
    ),
    "ur5": lambda: RobotSpec(
        urdf=_example_robot_data("ur_description/urdf/ur5_robot.urdf"),
        flange_frame="tool0",
        home=(0.0, -1.571, 1.571, -1.571, -1.571, 0.0),
    ),
}


@dataclasses.dataclass(frozen=True)
class Tool:
    """Placement of the peg frame {P} in the flange frame {F}.

    Attributes:
        xyz: Position of the peg tip's centre in {F} [m].
        rpy: Orientation of {P} in {F}, roll-pitch-yaw about fixed x, y, z [rad] (URDF order).
    """

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.10)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def placement(self) -> pin.SE3:
        for field, value in (("tool.xyz", self.xyz), ("tool.rpy", self.rpy)):
            arr = np.asarray(value, dtype=float)
            if arr.shape != (3,) or not np.isfinite(arr).all():
                raise ConfigError(field, value, "3 finite numbers [m] or [rad]")
        return pin.SE3(pin.rpy.rpyToMatrix(*self.rpy), np.asarray(self.xyz, dtype=float))


class RobotModel:
    """A fixed-base arm with the peg frame on its flange.

    Args:
        urdf: Path of the URDF (meshes are not needed).
        flange_frame: Name of the frame the tool is mounted on.
        tool: Placement of the peg frame in the flange frame.
        locked_joints: Joints to hold at zero and remove (gripper fingers).
        name: For messages.
    """

    def __init__(
        self,
        urdf: str | Path,
        flange_frame: str,
        tool: Tool | None = None,
        locked_joints: Sequence[str] = (),
        name: str | None = None,
    ) -> None:
        path = Path(urdf)
        if not path.is_file():
            raise ConfigError("urdf", str(path), "the path of an existing URDF file")
        try:
            model = pin.buildModelFromUrdf(str(path))
        except (ValueError, RuntimeError) as exc:
            raise ConfigError("urdf", str(path), f"a URDF Pinocchio can parse ({exc})") from exc
        self.name = name or model.name
        if locked_joints:
            missing = [j for j in locked_joints if not model.existJointName(j)]
            if missing:
                raise ConfigError(
                    "locked_joints", missing, f"joints of {path.name}: {_joint_names(model)}"
                )
            ids = [model.getJointId(j) for j in locked_joints]
            model = pin.buildReducedModel(model, ids, pin.neutral(model))
        if not model.existFrame(flange_frame):
            frames = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
            raise ConfigError("flange_frame", flange_frame, f"a link of {path.name}: {frames}")
        if model.nq != model.nv:
            raise ConfigError("urdf", str(path), "an arm of revolute or prismatic joints only")
        flange_id = model.getFrameId(flange_frame)
        flange = model.frames[flange_id]
        placement = flange.placement * (tool or Tool()).placement()
        if model.existFrame(PEG_FRAME):
            own = model.frames[model.getFrameId(PEG_FRAME)]
            if own.parentJoint != flange.parentJoint:
                raise ConfigError(
                    "urdf", str(path), f"its '{PEG_FRAME}' frame on the same link as the flange"
                )
            if tool is None:  # keep the URDF's own tool frame
                placement = own.placement
            model.frames[model.getFrameId(PEG_FRAME)].placement = placement
        else:
            model.addFrame(
                pin.Frame(
                    PEG_FRAME, flange.parentJoint, flange_id, placement, pin.FrameType.OP_FRAME
                )
            )
        self.model = model
        self.data = model.createData()
        self.flange_frame = flange_frame
        self.flange_id = flange_id
        self.peg_id = model.getFrameId(PEG_FRAME)
        self.joint_names: tuple[str, ...] = tuple(_joint_names(model))
        self.lower = np.array(model.lowerPositionLimit, dtype=float)
        self.upper = np.array(model.upperPositionLimit, dtype=float)
        self.velocity_limit = np.array(model.velocityLimit, dtype=float)
        self.home = np.zeros(model.nq)
        self._peg_in_flange = flange.placement.actInv(model.frames[self.peg_id].placement)
        self._flange_in_peg = self._peg_in_flange.inverse()

    @classmethod
    def from_name(cls, robot: str, tool: Tool | None = None) -> RobotModel:
        """One of :data:`ROBOTS`, with its home configuration set."""
        if robot not in ROBOTS:
            raise ConfigError("robot", robot, f"one of {sorted(ROBOTS)}")
        spec = ROBOTS[robot]()
        model = cls(spec.urdf, spec.flange_frame, tool, spec.locked_joints, name=robot)
        model.home = model.check_joints(spec.home, "home")
        return model

    @property
    def nq(self) -> int:
        return int(self.model.nq)

    def check_joints(self, q: ArrayLike, field: str = "q") -> FloatArray:
        """``q`` as a float array after checking its length and finiteness (not the limits)."""
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.nq,) or not np.isfinite(arr).all():
            raise InputError(
                field, q, f"{self.nq} finite joint values of {self.name} {list(self.joint_names)}"
            )
        return arr

    def within_limits(self, q: FloatArray) -> bool:
        # on floats: a third of the time of numpy's comparisons for seven joints
        limits = zip(self.lower.tolist(), q.tolist(), self.upper.tolist(), strict=True)
        return all(lo <= v <= hi for lo, v, hi in limits)

    def peg_in_base(self, q: ArrayLike) -> pin.SE3:
        """FK: pose of the peg frame in the base frame, ``T_base_P``."""
        return self._frame_in_base(self.check_joints(q), self.peg_id)

    def flange_in_base(self, q: ArrayLike) -> pin.SE3:
        """FK: pose of the flange frame in the base frame, ``T_base_F``."""
        return self._frame_in_base(self.check_joints(q), self.flange_id)

    def _frame_in_base(self, q: FloatArray, frame_id: int) -> pin.SE3:
        pin.forwardKinematics(self.model, self.data, q)
        return pin.updateFramePlacement(self.model, self.data, frame_id).copy()

    def peg_in_flange(self) -> pin.SE3:
        """The tool placement ``T_F_P`` (constant)."""
        return self._peg_in_flange.copy()

    def add_frame(self, name: str, in_flange: pin.SE3) -> None:
        """Adds (or moves) a frame fixed to the flange, e.g. a wrist sensor's measuring frame."""
        if name in (PEG_FRAME, self.flange_frame):
            raise ConfigError("frame", name, f"a name other than '{PEG_FRAME}' and the flange's")
        flange = self.model.frames[self.flange_id]
        placement = flange.placement * in_flange
        if self.model.existFrame(name):
            self.model.frames[self.model.getFrameId(name)].placement = placement
        else:
            self.model.addFrame(
                pin.Frame(
                    name, flange.parentJoint, self.flange_id, placement, pin.FrameType.OP_FRAME
                )
            )
            self.data = self.model.createData()

    def frame_id(self, frame: str) -> int:
        if not self.model.existFrame(frame):
            frames = [f.name for f in self.model.frames if f.type != pin.FrameType.JOINT]
            raise ConfigError("frame", frame, f"a frame of {self.name}: {frames}")
        return int(self.model.getFrameId(frame))

    def frame_in_base(self, q: ArrayLike, frame: str) -> pin.SE3:
        """FK of any frame of the model, ``T_base_frame``."""
        return self._frame_in_base(self.check_joints(q), self.frame_id(frame))

    def frame_motion(
        self, q: ArrayLike, dq: ArrayLike, ddq: ArrayLike, frame: str
    ) -> tuple[pin.SE3, pin.Motion, pin.Motion]:
        """Pose ``T_base_frame``, velocity and classical acceleration of a frame's origin.

        The velocity ``(v, omega)`` and the acceleration ``(a, omega_dot)`` are in the frame's
        own axes (Pinocchio's LOCAL); ``a`` is the classical (not spatial) acceleration of the
        origin, the one an accelerometer there would read, less gravity.
        """
        fid = self.frame_id(frame)
        q_, dq_, ddq_ = (self.check_joints(x, f) for x, f in ((q, "q"), (dq, "dq"), (ddq, "ddq")))
        pin.forwardKinematics(self.model, self.data, q_, dq_, ddq_)
        placement = pin.updateFramePlacement(self.model, self.data, fid).copy()
        velocity = pin.getFrameVelocity(self.model, self.data, fid, pin.LOCAL)
        accel = pin.getFrameClassicalAcceleration(self.model, self.data, fid, pin.LOCAL)
        return placement, velocity, accel

    def jacobian(self, q: ArrayLike, frame: str = PEG_FRAME) -> FloatArray:
        """Frame Jacobian, (6, nq): ``(v, omega)`` of the frame's origin, both in base axes
        (Pinocchio's LOCAL_WORLD_ALIGNED)."""
        arr = self.check_joints(q)
        fid = self.frame_id(frame)
        pin.computeJointJacobians(self.model, self.data, arr)
        pin.updateFramePlacements(self.model, self.data)
        return np.array(pin.getFrameJacobian(self.model, self.data, fid, pin.LOCAL_WORLD_ALIGNED))


def _joint_names(model: pin.Model) -> list[str]:
    return [str(n) for n in list(model.names)[1:]]


class IkError(FbccError):
    """The IK did not reach its target within the limits. Nothing is commanded.

    Attributes:
        reason: What stopped it, in words (the joints held at a limit, or out of reach).
        position_error: Remaining distance of the peg frame from its target [m].
        rotation_error: Remaining rotation angle [rad].
        iterations: Iterations spent.
    """

    def __init__(
        self, reason: str, position_error: float, rotation_error: float, iterations: int
    ) -> None:
        self.reason = reason
        self.position_error = position_error
        self.rotation_error = rotation_error
        self.iterations = iterations
        super().__init__(
            f"IK failed after {iterations} iterations, {position_error:.3g} m and "
            f"{rotation_error:.3g} rad from the target: {reason}"
        )


@dataclasses.dataclass(frozen=True)
class IkSettings:
    """Damped-least-squares CLIK settings.

    Attributes:
        tolerance: Convergence on both the position error [m] and the rotation error [rad];
            10 nm and 10 nrad, a hundred times inside the round-trip target of 1e-6.
        max_iterations: Iterations before giving up; a warm-started 1 ms step needs 1-3.
        damping: lambda of the DLS step [m or rad]; tiny against the arm's singular values, so
            it only matters near singularities, where it bounds the joint step.
        max_step: Largest joint step per iteration [rad], so cold solves do not overshoot.
    """

    tolerance: float = 1e-8
    max_iterations: int = 200
    damping: float = 1e-4
    max_step: float = 0.2


@dataclasses.dataclass(frozen=True)
class IkSolution:
    """A solved configuration and how it was reached."""

    q: FloatArray
    iterations: int
    position_error: float
    rotation_error: float


def solve_ik(
    robot: RobotModel,
    peg_in_base: pin.SE3,
    q_start: ArrayLike,
    dt: float | None = None,
    settings: IkSettings = IkSettings(),
) -> IkSolution:
    """Joints that put the peg frame at ``peg_in_base``, by damped least squares from ``q_start``.

    Each iterate stays within the position limits and, when ``dt`` is given, within
    ``|q - q_start| <= v_max dt`` (one control period at the joint velocity limits). A target that
    needs more than that raises :class:`IkError` naming the joints held at their bounds.

    .. math::
        e = \\log_6(T_{base,P}(q)^{-1} T^*_{base,P}), \\quad
        J_e = -J_{\\log_6} J_{P}^{local}, \\quad
        \\Delta q = -J_e^T (J_e J_e^T + \\lambda^2 I)^{-1} e
    """
    return _clik(robot, peg_in_base, _checked_start(robot, q_start, dt), dt, settings)


def _checked_start(robot: RobotModel, q_start: ArrayLike, dt: float | None, field: str = "q_start"
                   ) -> FloatArray:  # fmt: skip
    """The IK's start as a float array: finite, within the position limits; and ``dt`` > 0."""
    q0 = robot.check_joints(q_start, field)
    if not robot.within_limits(q0):
        limits = zip(robot.joint_names, q0, robot.lower, robot.upper, strict=True)
        outside = [name for name, v, lo, hi in limits if not lo <= v <= hi]
        raise InputError(field, q0.tolist(), f"joints within their position limits {outside}")
    if dt is not None and not (dt > 0.0 and math.isfinite(dt)):
        raise InputError("dt", dt, "a control period > 0 [s]")
    return q0


def _clik(
    robot: RobotModel, peg_in_base: pin.SE3, q0: FloatArray, dt: float | None, settings: IkSettings
) -> IkSolution:
    """The CLIK loop of :func:`solve_ik` on checked inputs."""
    model, data, fid = robot.model, robot.data, robot.peg_id
    lower, upper = robot.lower, robot.upper
    if dt is not None:
        reach = robot.velocity_limit * dt
        lower, upper = np.maximum(lower, q0 - reach), np.minimum(upper, q0 + reach)
    damping2, tol2 = settings.damping**2, settings.tolerance**2
    free = np.zeros(q0.size, dtype=np.bool_)
    q = q0.copy()
    for iteration in range(settings.max_iterations + 1):
        pin.forwardKinematics(model, data, q)
        target_in_peg = pin.updateFramePlacement(model, data, fid).actInv(peg_in_base)
        # Error twist in the peg frame, e = log6(T(q)^-1 T*).
        err = pin.log6(target_in_peg).vector
        e0, e1, e2, e3, e4, e5 = err.tolist()
        pos2, rot2 = e0 * e0 + e1 * e1 + e2 * e2, e3 * e3 + e4 * e4 + e5 * e5
        if pos2 <= tol2 and rot2 <= tol2:
            return IkSolution(q, iteration, math.sqrt(pos2), math.sqrt(rot2))
        if iteration == settings.max_iterations:
            break
        # d e / d q = -Jlog6(T*^-1 T) J_local (Pinocchio's CLIK example); the joint Jacobians
        # reuse the placements of forwardKinematics above.
        pin.computeJointJacobians(model, data)
        jac = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        jlog = pin.Jlog6(target_in_peg.inverse())
        args = (q, jlog, jac, err, lower, upper)
        step, q_next, clipped = _dls_update(*args, free, damping2, settings.max_step)
        if clipped:
            # Active set: joints pinned at a bound that the step pushes further are taken out
            # of the Jacobian, so the others (a redundant arm's null space) carry the correction.
            blocked = ((q <= lower) & (step < 0.0)) | ((q >= upper) & (step > 0.0))
            if blocked.any():
                step, q_next, _ = _dls_update(*args, blocked, damping2, settings.max_step)
            if float(np.abs(q_next - q).max()) < _STALLED:
                break  # every useful direction is blocked by a bound: fail now, not in 200 steps
        q = q_next
    pos_err, rot_err = math.sqrt(pos2), math.sqrt(rot2)
    raise IkError(_why(robot, q, lower, upper, q0, dt), pos_err, rot_err, iteration)


@numba.njit(cache=True)  # type: ignore[misc]
def _dls_update(
    q: FloatArray,
    jlog: FloatArray,
    jac: FloatArray,
    err: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    blocked: NDArray[np.bool_],
    damping2: float,
    max_step: float,
) -> tuple[FloatArray, FloatArray, bool]:
    """One damped-least-squares step, compiled (numpy's per-call overhead was ~8 µs of it):

    .. math::
        J_e = -J_{\\log_6} J, \\quad
        \\Delta q = -J_e^T (J_e J_e^T + \\lambda^2 I)^{-1} e

    with the ``blocked`` joints' columns of ``J_e`` zeroed, ``Delta q`` scaled to at most
    ``max_step`` per joint. Returns ``(Delta q, clip(q + Delta q, lower, upper), clipped)``.
    """
    n = q.size
    jac_e = np.zeros((6, n))
    for i in range(6):
        for j in range(n):
            if not blocked[j]:
                acc = 0.0
                for k in range(6):
                    acc += jlog[i, k] * jac[k, j]
                jac_e[i, j] = -acc
    # A = J_e J_e^T + lambda^2 I is symmetric positive definite: Cholesky, A = L L^T
    chol = np.zeros((6, 6))
    for i in range(6):
        for j in range(i + 1):
            acc = 0.0
            for k in range(n):
                acc += jac_e[i, k] * jac_e[j, k]
            if i == j:
                acc += damping2
            for k in range(j):
                acc -= chol[i, k] * chol[j, k]
            chol[i, j] = math.sqrt(acc) if i == j else acc / chol[j, j]
    # A w = e: L y = e forward, then L^T w = y backward
    w = np.empty(6)
    for i in range(6):
        acc = err[i]
        for k in range(i):
            acc -= chol[i, k] * w[k]
        w[i] = acc / chol[i, i]
    for i in range(5, -1, -1):
        acc = w[i]
        for k in range(i + 1, 6):
            acc -= chol[k, i] * w[k]
        w[i] = acc / chol[i, i]
    step = np.empty(n)
    largest = 0.0
    for j in range(n):
        acc = 0.0
        for i in range(6):
            acc -= jac_e[i, j] * w[i]
        step[j] = acc
        largest = max(largest, abs(acc))
    if largest > max_step:
        step *= max_step / largest
    q_next = np.empty(n)
    clipped = False
    for j in range(n):
        unclipped = q[j] + step[j]
        q_next[j] = min(max(unclipped, lower[j]), upper[j])
        clipped = clipped or q_next[j] != unclipped
    return step, q_next, clipped


def _load_dls(n: int) -> None:
    """Loads the compiled step now (from numba's cache, or compiled on a machine's first run),
    not inside the first control period. A zero error: nothing to solve."""
    zeros, eye = np.zeros(n), np.eye(6)
    _dls_update(zeros, eye, np.zeros((6, n)), np.zeros(6), zeros - 1.0, zeros + 1.0,
                np.zeros(n, dtype=np.bool_), 1e-8, 0.2)  # fmt: skip


#: A clipped step smaller than this [rad] means the solver is pinned against its bounds.
_STALLED = 1e-12


def _why(
    robot: RobotModel,
    q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    q0: FloatArray,
    dt: float | None,
) -> str:
    """Which bounds held the solver, in words."""
    held = []
    for i, name in enumerate(robot.joint_names):
        for bound, limit, side in (
            (lower[i], robot.lower[i], "lower"),
            (upper[i], robot.upper[i], "upper"),
        ):
            if abs(q[i] - bound) > 1e-9:
                continue
            if bound == limit:
                held.append(f"{name} at its {side} position limit {bound:.4g} rad")
            else:  # the one-period box around the start, narrower than the position limits
                held.append(
                    f"{name} at its velocity limit ({robot.velocity_limit[i]:.4g} rad/s: "
                    f"{abs(bound - q0[i]):.3g} rad in dt={dt} s)"
                )
    if held:
        return "held by " + "; ".join(held)
    return "no joint is at a bound: the target is out of reach or at a singularity"


class CellKinematics:
    """The feature solution and TCP solution of one cell: a robot, the hole, the peg.

    Args:
        robot: The arm, with its peg frame.
        hole_in_base: Pose of {H} in the base frame, ``T_base_H``.
        peg_radius: r [m], used by the feature conversion (``fbcc_ros.core.features``); None
            for a cell that only solves poses (:meth:`pose_solution`).
        settings: IK settings.
    """

    def __init__(
        self,
        robot: RobotModel,
        hole_in_base: pin.SE3,
        peg_radius: float | None,
        settings: IkSettings = IkSettings(),
    ) -> None:
        if peg_radius is not None and not (peg_radius > 0.0 and math.isfinite(peg_radius)):
            raise ConfigError("peg_radius", peg_radius, "a radius > 0 [m]")
        self.robot = robot
        self.hole_in_base = hole_in_base.copy()
        self.peg_radius = peg_radius
        self.settings = settings
        _load_dls(robot.nq)

    def peg_in_hole(self, q: ArrayLike) -> pin.SE3:
        """``T_H_P`` at joints ``q``."""
        return self.hole_in_base.actInv(self.robot.peg_in_base(q))

    def features(self, q: ArrayLike) -> FloatArray:
        """Feature solution: joints → ``(dx, dy, l, theta_x, theta_y)`` [m, rad]."""
        peg = self.peg_in_hole(q)
        return features_from_pose(peg.rotation, peg.translation, self._radius())

    def _radius(self) -> float:
        if self.peg_radius is None:
            raise ConfigError("peg_radius", None, "a radius > 0 [m] for the feature conversion")
        return self.peg_radius

    def peg_target(self, command_features: ArrayLike, spin: float) -> pin.SE3:
        """``T_base_P`` of the command features, with the peg's spin about its axis."""
        x_c = np.asarray(command_features, dtype=float)
        if x_c.shape != (5,) or not np.isfinite(x_c).all():
            raise InputError(
                "command_features",
                command_features,
                "5 finite values (dx, dy, l, theta_x, theta_y)",
            )
        rotation, position = pose_from_features(x_c, self._radius(), spin)
        return self.hole_in_base * pin.SE3(rotation, position)

    def tcp_solution(
        self, command_features: ArrayLike, q_current: ArrayLike, dt: float | None = None
    ) -> TcpCommand:
        """TCP solution: command features → peg pose in {H} → flange pose in base → joints.

        The peg keeps its current spin about its own axis (the features do not fix it). With
        ``dt``, the joints must be reachable within one period at the velocity limits.
        Raises :class:`IkError` rather than return a command that misses the target.
        """
        q_now = _checked_start(self.robot, q_current, dt, "q_current")
        return self._solve(self.peg_target(command_features, self._spin(q_now)), q_now, dt)

    def pose_solution(
        self, peg_in_hole: pin.SE3, q_current: ArrayLike, dt: float | None = None
    ) -> TcpCommand:
        """TCP solution of a commanded peg pose in {H} (``T_H_P``), as :meth:`tcp_solution`:
        the peg keeps its current spin about its own axis, whatever the command's."""
        q_now = _checked_start(self.robot, q_current, dt, "q_current")
        rotation = peg_in_hole.rotation
        turn = self._spin(q_now) - spin_of(rotation)  # R_HP = S(a) R_aligned R_z(spin)
        c, s = math.cos(turn), math.sin(turn)
        spun = rotation @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return self._solve(self.hole_in_base * pin.SE3(spun, peg_in_hole.translation), q_now, dt)

    def _spin(self, q: FloatArray) -> float:
        return spin_of(self.hole_in_base.actInv(self.robot._frame_in_base(q, self.robot.peg_id))
                       .rotation)  # fmt: skip

    def _solve(self, target: pin.SE3, q_now: FloatArray, dt: float | None) -> TcpCommand:
        solution = _clik(self.robot, target, q_now, dt, self.settings)
        return TcpCommand(solution.q, target * self.robot._flange_in_peg, target,
                          solution.iterations)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class TcpCommand:
    """What the TCP solution commands.

    Attributes:
        q: Joint positions [rad].
        flange_in_base: The flange pose for a Cartesian position interface, ``T_base_F``.
        peg_in_base: The peg pose it realises, ``T_base_P``.
        iterations: IK iterations used.
    """

    q: FloatArray
    flange_in_base: pin.SE3
    peg_in_base: pin.SE3
    iterations: int


@dataclasses.dataclass(frozen=True)
class FollowResult:
    """The TCP solution applied along a command trajectory, one row per control step.

    Attributes:
        q: Joint positions commanded, (T, nq) [rad].
        features: Features of those joints (the feature solution), (T, 5) [m, rad].
        iterations: IK iterations per step, (T,).
        seconds: Wall time of each step's TCP solution, (T,) [s].
    """

    q: FloatArray
    features: FloatArray
    iterations: NDArray[np.int64]
    seconds: FloatArray


def follow(
    cell: CellKinematics, commands: ArrayLike, q_start: ArrayLike, dt: float
) -> FollowResult:
    """Run the TCP solution on each command features row in turn, warm-started from the
    previous step and bounded by the velocity limits over ``dt`` [s], as the kinematics node
    does in the closed loop. Raises :class:`IkError` (with the step in its message) on the
    first step the robot cannot follow."""
    x_c = np.asarray(commands, dtype=float)
    q = cell.robot.check_joints(q_start, "q_start")
    steps = x_c.shape[0]
    joints = np.empty((steps, q.size))
    features = np.empty((steps, 5))
    iterations = np.empty(steps, dtype=np.int64)
    seconds = np.empty(steps)
    for k in range(steps):
        t0 = time.perf_counter()
        try:
            command = cell.tcp_solution(x_c[k], q, dt)
        except IkError as exc:
            exc.args = (f"step {k} (t = {k * dt:.3f} s): {exc}",)
            raise
        seconds[k] = time.perf_counter() - t0
        q = command.q
        joints[k], iterations[k] = q, command.iterations
        features[k] = cell.features(q)
    return FollowResult(joints, features, iterations, seconds)


def aligned_hole_at(peg_in_base: pin.SE3) -> pin.SE3:
    """``T_base_H`` of a hole whose top face centre is at the peg's tip and whose axis is the
    peg's: the peg at this pose has features (0, 0, 0, 0, 0) and zero spin."""
    return peg_in_base * pin.SE3(R_ALIGNED.T, np.zeros(3))


def pose(xyz: ArrayLike, rpy: ArrayLike = (0.0, 0.0, 0.0)) -> pin.SE3:
    """An SE3 from a position [m] and roll-pitch-yaw [rad] (URDF convention)."""
    return pin.SE3(pin.rpy.rpyToMatrix(*np.asarray(rpy, dtype=float)), np.asarray(xyz, float))
