"""Robot models with Pinocchio: an arm by name (the KUKA LBRs ``iiwa7``, ``iiwa14``, ``med7`` and
``med14`` from this package's URDFs; ``panda`` and ``ur5`` from example-robot-data) or from any
URDF, a file or the text a ``robot_description`` carries, with the peg (tool) frame {P} added to
its flange; the FK of the peg frame and frame Jacobians.

Frames: ``base`` is the robot's root (the URDF's first link), {F} the flange, {P} the peg frame
(``fbcc_ros.core.contact.features``: origin at the tip centre, z along the peg out of the
flange). A pose named ``peg_in_base`` is ``T_base_P`` (``pin.SE3``).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.kinematics.lbr_names import PEG_LINK, lbr_description, renamed

PEG_FRAME = PEG_LINK
#: The label of a URDF given as text: the topic ROS stacks share it on.
DESCRIPTION = "robot_description"

_URDF_DIR = Path(__file__).resolve().parents[2] / "urdf"


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


#: The LBRs (iiwa 7 and 14, Med 7 and 14): our URDFs share joint and flange names, and one
#: home, where the net pitch q2 - q4 + q6 = pi points the flange down.
LBRS = ("iiwa7", "iiwa14", "med7", "med14")
LBR_HOME = (0.0, 0.5, 0.0, -1.5, 0.0, math.pi - 2.0, 0.0)


def _lbr(name: str) -> Callable[[], RobotSpec]:
    return lambda: RobotSpec(urdf=_URDF_DIR / f"{name}.urdf", flange_frame="iiwa_flange",
                             home=LBR_HOME)  # fmt: skip


#: Robots known by name.
ROBOTS: dict[str, Callable[[], RobotSpec]] = {
    **{name: _lbr(name) for name in LBRS},
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
    """Placement of the peg frame {P} in the flange frame {F}, or in a frame of the model fixed
    to the flange's link (a TCP the URDF defines).

    Attributes:
        xyz: Position of the peg tip's centre in {F} [m].
        rpy: Orientation of {P} in {F}, roll-pitch-yaw about fixed x, y, z [rad] (URDF order).
        frame: The frame xyz and rpy are given in; empty: the flange.
    """

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.10)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frame: str = ""

    def placement(self) -> pin.SE3:
        for field, value in (("tool.xyz", self.xyz), ("tool.rpy", self.rpy)):
            arr = np.asarray(value, dtype=float)
            if arr.shape != (3,) or not np.isfinite(arr).all():
                raise ConfigError(field, value, "3 finite numbers [m] or [rad]")
        return pin.SE3(pin.rpy.rpyToMatrix(*self.rpy), np.asarray(self.xyz, dtype=float))


class RobotModel:
    """A fixed-base arm with the peg frame on its flange.

    Args:
        urdf: Path of the URDF, or its text (a ``robot_description``); meshes are not needed.
        flange_frame: Name of the frame the tool is mounted on; empty: the tip of the chain
            (:func:`tip_frame`).
        tool: Placement of the peg frame in the flange frame.
        locked_joints: Joints to hold at zero and remove (gripper fingers).
        name: For messages.
    """

    def __init__(
        self,
        urdf: str | Path,
        flange_frame: str = "",
        tool: Tool | None = None,
        locked_joints: Sequence[str] = (),
        name: str | None = None,
    ) -> None:
        model, label, text = _parse(urdf)
        #: the URDF's text, as a robot_description carries it
        self.urdf_text = text
        self.name = name or model.name
        if locked_joints:
            missing = [j for j in locked_joints if not model.existJointName(j)]
            if missing:
                raise ConfigError(
                    "locked_joints", missing, f"joints of {label}: {_joint_names(model)}"
                )
            ids = [model.getJointId(j) for j in locked_joints]
            model = pin.buildReducedModel(model, ids, pin.neutral(model))
        if model.nq != model.nv or model.nq == 0:
            raise ConfigError("urdf", label, "an arm of revolute or prismatic joints only "
                              f"(it has {model.nq} position variables)")  # fmt: skip
        flange_frame = flange_frame or tip_frame(model, label)
        if not model.existFrame(flange_frame):
            frames = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
            raise ConfigError("flange_frame", flange_frame, f"a link of {label}: {frames}")
        flange_id = model.getFrameId(flange_frame)
        flange = model.frames[flange_id]
        placement = _tool_base(model, flange, tool, label).placement * (tool or Tool()).placement()
        if model.existFrame(PEG_FRAME):
            own = model.frames[model.getFrameId(PEG_FRAME)]
            if own.parentJoint != flange.parentJoint:
                raise ConfigError(
                    "urdf", label, f"its '{PEG_FRAME}' frame on the same link as the flange"
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
        #: a configuration to start from: a built-in model's own (from_name), else the middle
        #: of each joint's range (a URDF says nothing of where its arm works; zero may be
        #: outside a range, or stretched out in a singularity)
        self.home = (self.lower + self.upper) / 2.0
        self._peg_in_flange = flange.placement.actInv(model.frames[self.peg_id].placement)
        self._flange_in_peg = self._peg_in_flange.inverse()

    @classmethod
    def from_name(cls, robot: str, tool: Tool | None = None, flange_frame: str = "",
                  lbr_name: str = "") -> RobotModel:  # fmt: skip
        """One of :data:`ROBOTS`, with its home configuration set; ``flange_frame`` overrides
        its flange (e.g. a gripper's link); ``lbr_name``: an LBR under lbr_fri_ros2_stack's
        names with that ``robot_name`` (:mod:`~fbcc_ros.core.kinematics.lbr_names`)."""
        if robot not in ROBOTS:
            raise ConfigError("robot", robot, f"one of {sorted(ROBOTS)}")
        spec = ROBOTS[robot]()
        urdf: str | Path = spec.urdf
        flange = flange_frame or spec.flange_frame
        if lbr_name:
            urdf = lbr_description(spec.urdf.read_text(), lbr_name)
            flange = renamed(flange, lbr_name)
        model = cls(urdf, flange, tool, spec.locked_joints, name=robot)
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

    def gravity(self, q: ArrayLike) -> FloatArray:
        """``g(q)``: the joint torques that hold the arm at ``q`` against gravity [N m]."""
        return np.array(pin.computeGeneralizedGravity(self.model, self.data, self.check_joints(q)))

    def jacobian(
        self, q: ArrayLike, frame: str = PEG_FRAME, axes: Any = pin.LOCAL_WORLD_ALIGNED
    ) -> FloatArray:
        """Frame Jacobian, (6, nq): ``(v, omega)`` of the frame's origin, in base axes (the
        default, Pinocchio's LOCAL_WORLD_ALIGNED) or in the frame's own (``pin.LOCAL``)."""
        arr = self.check_joints(q)
        fid = self.frame_id(frame)
        pin.computeJointJacobians(self.model, self.data, arr)
        pin.updateFramePlacements(self.model, self.data)
        return np.array(pin.getFrameJacobian(self.model, self.data, fid, axes))


def _tool_base(model: pin.Model, flange: pin.Frame, tool: Tool | None, label: str) -> pin.Frame:
    """The frame the tool's placement is given in: its ``frame``, fixed to the flange's link, or
    the flange."""
    if tool is None or not tool.frame:
        return flange
    fixed = [f.name for f in model.frames if f.parentJoint == flange.parentJoint
             and f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]  # fmt: skip
    if not model.existFrame(tool.frame) or tool.frame not in fixed:
        raise ConfigError("tool_frame", tool.frame, f"a frame of {label} fixed to the flange's "
                          f"link {flange.name}: {fixed}")  # fmt: skip
    return model.frames[model.getFrameId(tool.frame)]


def _parse(urdf: str | Path) -> tuple[pin.Model, str, str]:
    """The Pinocchio model of a URDF given by path or as text, a label for messages, and the
    text."""
    given = isinstance(urdf, str) and urdf.lstrip().startswith("<")
    if not given and not Path(urdf).is_file():
        raise ConfigError("urdf", str(urdf), "the path of an existing URDF file")
    text = str(urdf) if given else Path(urdf).read_text()
    label = DESCRIPTION if given else Path(urdf).name
    try:
        return pin.buildModelFromXML(text), label, text
    except (ValueError, RuntimeError) as exc:
        shown = text[:60] + "..." if given else str(urdf)
        raise ConfigError("urdf", shown, f"a URDF Pinocchio can parse ({exc})") from exc


def tip_frame(model: pin.Model, label: str = "the URDF") -> str:
    """The link at the tip of the arm: the one link fixed to the last joint that carries no
    other link (a ``peg`` link apart). The flange of a description that names its tool link
    last (``lbr_link_ee``, ``tool0``); a tree with several such tips must name its flange."""
    last = model.njoints - 1
    skip = set()  # the peg link and its joint: the tool frame, not a link of the arm
    if model.existFrame(PEG_FRAME):
        peg = model.getFrameId(PEG_FRAME)
        skip = {peg, model.frames[peg].parentFrame}
    parents = {f.parentFrame for i, f in enumerate(model.frames) if i not in skip}
    tips = [
        f.name
        for i, f in enumerate(model.frames)
        if f.type == pin.FrameType.BODY
        and f.parentJoint == last
        and f.name != PEG_FRAME
        and i not in parents
    ]
    if len(tips) != 1:
        raise ConfigError("flange_frame", "", f"one of the tips of {label}: {tips} (it has "
                          f"{len(tips)}; name the link the tool is mounted on)")  # fmt: skip
    return tips[0]


def _joint_names(model: pin.Model) -> list[str]:
    return [str(n) for n in list(model.names)[1:]]


def pose(xyz: ArrayLike, rpy: ArrayLike = (0.0, 0.0, 0.0)) -> pin.SE3:
    """An SE3 from a position [m] and roll-pitch-yaw [rad] (URDF convention)."""
    return pin.SE3(pin.rpy.rpyToMatrix(*np.asarray(rpy, dtype=float)), np.asarray(xyz, float))
