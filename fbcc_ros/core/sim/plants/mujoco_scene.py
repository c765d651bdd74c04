"""The peg-in-hole scene in MuJoCo: a faceted bore with its top face, an optional chamfer and a
bottom, and the peg in a compliant grip driven by the robot's hand. Its contact physics are
MuJoCo's, not eq. 5-13: the independent plant the law is judged on (DESIGN §7).

Frames and conventions are the package's: {H} at the centre of the hole's top face, z out of
the hole (the peg inserts along -z), the peg's features ``(dx, dy, l, theta_x, theta_y)`` of
its tip in {H} (:mod:`fbcc_ros.core.contact.features`), the wrench the peg exerts on the hole
about the {H} origin, SI units, angles in radians (the MJCF says ``angle="radian"``).

* **The bore** is ``facets`` flat boxes whose inner faces are tangent to the hole's circle: the
  hole is the polygon circumscribing it, so its radius is R at a facet's middle and
  ``R / cos(pi / facets)`` at a corner (the shape error :func:`shape_error`, 1.5 µm at R = 5 mm
  and 128 facets). A non-convex mesh would collide as its convex hull, a closed hole. The boxes'
  tops form the hole's top face, as wide as ``face_width``. The pair's chamfer is a second ring
  of boxes at 45°. A plate closes the bottom.
* **The grip**: the peg has six joints at its grip point, ``grip`` above its tip, each a
  position servo whose target is the hand's commanded pose: a spring to the hand with critical
  damping, laterally, in tilt and axially the holder's stiffness (:class:`~fbcc_ros.core.sim.
  holder.Holder`), about z :data:`TWIST` (a rigid holder would leave
  the contact nothing to push against: it takes :data:`RIGID`). A hand that is a mocap body
  with the peg its child would carry the peg along kinematically, past any friction. MuJoCo
  integrates a servo's stiffness explicitly: one too stiff for the timestep gets rotor inertia
  (armature) until its natural frequency times :data:`MAX_TIMESTEP` is :data:`STABLE`; statics
  are unchanged, the fastest grip modes slower than the peg's own mass would make them, and the
  same at every timestep.
* **The contact** is MuJoCo's soft constraint, ``solref`` (time constant, damping ratio) and
  ``solimp``, with an elliptic friction cone, a raised ``impratio`` and the no-slip solver, so
  that the peg sticks below mu N and slides at it (:class:`Contact`). Its figures are checked
  against physics (``test/core/sim/test_mujoco_scene.py``), never against the law's results.
* **The pruning**: each timestep collides the peg only with the bottom and the boxes it can
  provably touch in it (:meth:`MujocoPegHole.step`, :mod:`.pruning`).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import R_ALIGNED, features_from_pose, pose_from_features
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.pruning import PRUNE_MOVE, FacetPruning
from fbcc_ros.core.sim.plants.spec import MAX_TIMESTEP, TIMESTEPS_PER_TIMECONST, PlantSpec

#: The grip's stiffness about z [N·m/rad]: the holder is rigid there (position controlled),
#: MuJoCo needs a finite spring for the contact to act against (axially: the holder's).
TWIST = 1.0e3
#: The largest omega dt of a grip spring (its natural frequency times the timestep): MuJoCo
#: integrates joint springs explicitly, and a stiffer one is given armature to stay there.
STABLE = 0.5
#: MuJoCo's convex-collision tolerance [m] (``ccd_tolerance``). Its default, 1 µm, is a tenth of
#: the clearance: a peg's flat tip level with a facet's top then met contacts 5 mm off its
#: surface, with force spikes of up to 325 N (test_every_contact_lies_on_the_pegs_surface).
CCD_TOLERANCE = 1.0e-9
#: The stiffness that stands for a rigid holder: (lateral [N/m], angular [N·m/rad]), the stiff
#: end of holder.py's range.
RIGID = Holder(1.0e6, 3.0e3)


@dataclasses.dataclass(frozen=True)
class Contact:
    """MuJoCo's contact parameters (MJCF ``solref``, ``solimp``, ``impratio``).

    Attributes:
        timeconst: solref's time constant [s], at least :data:`~.spec.TIMESTEPS_PER_TIMECONST`
            timesteps.
        dampratio: solref's damping ratio.
        solimp: (d0, dwidth, width [m], midpoint, power): the impedance over penetration.
        impratio: The ratio of frictional to normal impedance (elliptic cone).
        timestep: The simulation's timestep [s].
        noslip: Iterations of MuJoCo's no-slip solver: without them a soft contact creeps under
            any tangential force (a peg pressed on the wall with 4.5 N slid down under 0.002 N
            of friction), with them it sticks until mu N.
    """

    timeconst: float = PlantSpec.timeconst
    dampratio: float = 1.0
    solimp: tuple[float, float, float, float, float] = (0.99, 0.999, 1.0e-5, 0.5, 2.0)
    impratio: float = 10.0
    timestep: float = PlantSpec.timestep
    noslip: int = 10

    def __post_init__(self) -> None:
        if not 0 < self.timestep <= MAX_TIMESTEP:
            raise ConfigError("plant.timestep", self.timestep, f"in (0, {MAX_TIMESTEP:g}] s")
        least = TIMESTEPS_PER_TIMECONST * self.timestep
        if not self.timeconst >= least:
            raise ConfigError("plant.timeconst", self.timeconst, f"at least "
                              f"{TIMESTEPS_PER_TIMECONST} timesteps ({least:g} s)")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Part:
    """What the scene adds to the pair's geometry.

    Attributes:
        facets: The bore's flat faces (at least 16).
        face_width: The width of the hole's top face around it [m] (the chamfer is the
            pair's, :attr:`PegHole.chamfer`).
        peg_length: From the tip to the peg's top [m].
        grip: The grip point's height above the tip [m].
        peg_mass: [kg].
    """

    facets: int = 128
    face_width: float = 0.005
    peg_length: float = 0.05
    grip: float = 0.05
    peg_mass: float = 0.05

    def __post_init__(self) -> None:
        if self.facets < 16:
            raise ConfigError("plant.facets", self.facets, "at least 16")


def shape_error(radius: float, facets: int) -> float:
    """How far the bore's corners lie outside its circle [m]: R (1 / cos(pi / N) - 1)."""
    return radius * (1.0 / math.cos(math.pi / facets) - 1.0)


def _quat_z(angle: float) -> str:
    return f"{math.cos(angle / 2)} 0 0 {math.sin(angle / 2)}"


def quaternion(rotation: FloatArray) -> FloatArray:
    """A rotation matrix as MuJoCo's quaternion (w x y z)."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).ravel())
    return quat


def _quat(rotation: FloatArray) -> str:
    return " ".join(map(str, quaternion(rotation)))


#: A rotation of 45° about y: x to (1, 0, -1)/sqrt(2), z to (1, 0, 1)/sqrt(2).
_ROT_Y_45 = np.array([[math.sqrt(0.5), 0.0, math.sqrt(0.5)], [0.0, 1.0, 0.0],
                      [-math.sqrt(0.5), 0.0, math.sqrt(0.5)]])  # fmt: skip


def _bore(pair: PegHole, part: Part) -> str:
    """The fixture's boxes, in {H}."""
    R, N, c = pair.hole_radius, part.facets, pair.chamfer
    if c >= part.face_width:
        raise ConfigError("geometry.chamfer", c, f"less than plant.face_width "
                          f"({part.face_width:g} m)")  # fmt: skip
    depth = pair.hole_depth - c  # the straight bore under the chamfer
    half_t = 0.5 * part.face_width
    boxes = []
    for i in range(N):
        a = 2.0 * math.pi * i / N
        half_w = R * math.tan(math.pi / N) * 1.02  # a little past the corner: no gaps
        r = R + half_t
        boxes.append(f'<geom type="box" size="{half_t} {half_w} {depth / 2}" '
                     f'pos="{r * math.cos(a)} {r * math.sin(a)} {-c - depth / 2}" '
                     f'quat="{_quat_z(a)}" class="hole"/>')  # fmt: skip
        if c > 0:  # the chamfer's face: from (R, -c) to (R + c, 0), 45° out of the axis
            half_c = c * math.sqrt(2.0) / 2
            rc = R + c / 2 + half_t / math.sqrt(2.0)
            zc = -c / 2 - half_t / math.sqrt(2.0)
            wide = (R + c) * math.tan(math.pi / N) * 1.02
            # Rz(a) Ry(45°): the box's x (its depth behind the face) outward and down, its z
            # along the face, outward and up
            tilt = _quat(np.array([[math.cos(a), -math.sin(a), 0.0],
                                   [math.sin(a), math.cos(a), 0.0],
                                   [0.0, 0.0, 1.0]]) @ _ROT_Y_45)  # fmt: skip
            boxes.append(f'<geom type="box" size="{half_t} {wide} {half_c}" '
                         f'pos="{rc * math.cos(a)} {rc * math.sin(a)} {zc}" quat="{tilt}" '
                         f'class="hole"/>')  # fmt: skip
    outer = R + part.face_width
    boxes.append(
        f'<geom name="bottom" type="box" size="{outer} {outer} {pair.base_thickness / 2}" '
        f'pos="0 0 {-pair.hole_depth - pair.base_thickness / 2}" class="hole"/>'
    )
    return "\n".join(boxes)


def peg_xml(pair: PegHole, holder: Holder | None = None, part: Part | None = None
            ) -> tuple[str, str]:  # fmt: skip
    """The peg's body (its six grip joints at its grip point, each a position servo whose
    target is the hand, :meth:`MujocoPegHole.set_hand`) and its servos, as MJCF."""
    part = part or Part()
    grip = RIGID if holder is None or holder.is_rigid else holder
    m, r, L, g = part.peg_mass, pair.peg_radius, part.peg_length, part.grip
    tilt_inertia = m * (3 * r * r + L * L) / 12 + m * (g - L / 2) ** 2  # about the grip point
    joints, servos = [], []
    for i, (kind, axis, k, inertia) in enumerate((
            ("slide", "1 0 0", grip.lateral, m), ("slide", "0 1 0", grip.lateral, m),
            ("slide", "0 0 1", grip.axial, m), ("hinge", "1 0 0", grip.angular, tilt_inertia),
            ("hinge", "0 1 0", grip.angular, tilt_inertia),
            ("hinge", "0 0 1", TWIST, m * r * r / 2))):  # fmt: skip
        # a spring is integrated explicitly: one stiffer than the largest timestep resolves
        # gets armature (rotor inertia) until omega dt <= STABLE there (statics unchanged), the
        # same at every timestep, so that a smaller one refines the dynamics, not changes them
        armature = max(0.0, k * (MAX_TIMESTEP / STABLE) ** 2 - inertia)
        damping = 2.0 * math.sqrt(k * (inertia + armature))  # critical
        joints.append(f'<joint name="grip{i}" type="{kind}" axis="{axis}" '
                      f'armature="{armature}"/>')  # fmt: skip
        servos.append(f'<position name="grip{i}" joint="grip{i}" kp="{k}" kv="{damping}" '
                      'ctrllimited="false"/>')  # fmt: skip
    body = f"""<body name="peg">
      {"".join(joints)}
      <geom name="peg" type="cylinder" size="{r} {L / 2}" pos="0 0 {L / 2 - g}"
            mass="{m}" rgba="0.8 0.5 0.2 1"/>
      <site name="tip" pos="0 0 {-g}"/>
    </body>"""
    return body, "".join(servos)


def scene_xml(pair: PegHole, holder: Holder | None = None, part: Part | None = None,
              contact: Contact | None = None, peg: bool = True) -> str:  # fmt: skip
    """The MJCF of the scene: {H} is the world's origin; the peg (:func:`peg_xml`) with its
    grip joints in the world, unless ``peg`` is False (the fixture alone, for an arm to carry
    the peg: :mod:`.mujoco_cell`)."""
    part, contact = part or Part(), contact or Contact()
    body, servos = peg_xml(pair, holder, part) if peg else ("", "")
    return f"""<mujoco model="fbcc_peg_in_hole">
  <compiler angle="radian"/>
  <option timestep="{contact.timestep}" integrator="implicitfast" cone="elliptic"
          impratio="{contact.impratio}" noslip_iterations="{contact.noslip}" gravity="0 0 -9.81"
          ccd_tolerance="{CCD_TOLERANCE}"/>
  {contact_defaults(pair, contact)}
  <worldbody>
    <body name="fixture">
      {_bore(pair, part)}
    </body>
    {body}
  </worldbody>
  <actuator>
    {servos}
  </actuator>
</mujoco>"""


def contact_defaults(pair: PegHole, contact: Contact) -> str:
    """The MJCF defaults every geom of the peg and the hole takes: the contact (:class:`Contact`)
    and the pair's friction."""
    solimp = " ".join(map(str, contact.solimp))
    return f"""<default>
    <geom solref="{contact.timeconst} {contact.dampratio}" solimp="{solimp}"
          friction="{pair.friction} 0.005 0.0001" condim="4" margin="0"/>
    <default class="hole"><geom rgba="0.6 0.6 0.65 1"/></default>
  </default>"""


class MujocoPegHole:
    """The scene, stepped: set the hand, step, read the peg's features and the wrench on the
    hole.

    Args:
        pair: The true peg and hole (radii, depth, base, friction; its ``stiffness`` is eq.
            8's and not used: the contact's stiffness is MuJoCo's).
        holder: The grip's stiffness at the grip point (None: :data:`RIGID`).
        part: The bore's facets and face width; the peg's length, grip and mass.
        contact: MuJoCo's contact parameters.
        prune: Skip, each timestep, the hole's boxes the peg cannot touch in it (:meth:`step`;
            the same physics, False only to test that).
        model: The scene built around this one instead (its world {H}, its peg and grip as
            :func:`peg_xml`'s, the part's): an arm carrying the peg (:mod:`.mujoco_cell`).
    """

    def __init__(self, pair: PegHole, holder: Holder | None = None, part: Part | None = None,
                 contact: Contact | None = None, prune: bool = True,
                 model: mujoco.MjModel | None = None) -> None:  # fmt: skip
        self.pair, self.part = pair, part or Part()
        self.model = model or mujoco.MjModel.from_xml_string(
            scene_xml(pair, holder, self.part, contact))
        self.data = mujoco.MjData(self.model)
        self.dt = float(self.model.opt.timestep)
        self._peg = self.model.body("peg").id
        self.carried = int(self.model.body_parentid[self._peg]) != 0  # by an arm: its grip
        self._tip = self.model.site("tip").id
        fixture = self.model.body("fixture").id
        self._hole_geoms = set(np.flatnonzero(self.model.geom_bodyid == fixture).tolist())
        self._force = np.zeros(6)
        self._joints = np.array([self.model.joint(f"grip{i}").id for i in range(6)])
        self._dofs = self.model.jnt_dofadr[self._joints]
        self._qpos = self.model.jnt_qposadr[self._joints]
        self._servos = np.array([self.model.actuator(f"grip{i}").id for i in range(6)])
        self._impulse, self._steps = np.zeros(self.model.nv), 0
        mujoco.mj_forward(self.model, self.data)
        self.prune = prune
        self._pruning = FacetPruning(self.model, self.data, pair.peg_radius,
                                     self.part.peg_length, self.part.grip)  # fmt: skip

    def set_hand(self, features: FloatArray) -> None:
        """The hand at the pose that holds the peg, undeflected in its grip, at ``features``
        ``(dx, dy, l, theta_x, theta_y)`` (:func:`~fbcc_ros.core.contact.features.
        pose_from_features`, zero spin): the grip's targets. Not for a carried grip."""
        self.data.ctrl[self._servos] = self._grip_coordinates(features)

    def _grip_coordinates(self, features: FloatArray) -> FloatArray:
        """The grip joints' coordinates of the peg at ``features``: the grip point, then the
        rotation as hinges about x, then y, then z (R = Rx(a) Ry(b) Rz(c))."""
        rot_hp, tip = pose_from_features(features, self.pair.peg_radius)
        rot = rot_hp @ R_ALIGNED  # the peg body's frame: z from the tip to the top
        grip = tip + rot @ np.array([0.0, 0.0, self.part.grip])
        b = math.asin(max(-1.0, min(1.0, float(rot[0, 2]))))
        a = math.atan2(-float(rot[1, 2]), float(rot[2, 2]))
        c = math.atan2(-float(rot[0, 1]), float(rot[0, 0]))
        return np.array([*grip, a, b, c])

    def place(self, features: FloatArray) -> None:
        """The hand and the peg, at rest, undeflected at ``features`` (a trial's start)."""
        self.set_hand(features)
        self.data.qpos[self._qpos] = self.data.ctrl[self._servos]
        self.data.qvel[:] = 0.0
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        """``n`` MuJoCo timesteps, each colliding the peg only with the bottom and the boxes it
        may touch (:class:`~.pruning.FacetPruning`); the model whole again on return. The
        contact's force on the peg is summed over them (:meth:`mean_wrench_on_hole`)."""
        m, d, q, pruning = self.model, self.data, self.data.qpos, self._pruning
        self._impulse[:] = 0.0
        pruned = self.prune and pruning.prunable
        rho, (move_xy, move_z) = pruning.rho, PRUNE_MOVE
        ref: list[float] | None = None
        peg, carried = self._peg, self.carried
        try:
            for _ in range(n):
                if pruned:
                    # a timestep's collision uses the qpos it starts with (mj_step: checks,
                    # then mj_forward, then the integrator): the peg's pose, now, exactly;
                    # carried, from the kinematics of that qpos (R = Rx(a) Ry(b) Rz(c))
                    if carried:
                        mujoco.mj_kinematics(m, d)
                        x, y, z = d.xpos[peg].tolist()
                        r = d.xmat[peg].tolist()
                        a, b = math.atan2(-r[5], r[8]), math.asin(max(-1.0, min(1.0, r[2])))
                    else:
                        x, y, z, a, b, _c = q.tolist()
                    if ref is not None:
                        turn = (abs(a - ref[3]) + abs(b - ref[4])) * rho
                        if not (math.hypot(x - ref[0], y - ref[1]) + turn <= move_xy
                                and abs(z - ref[2]) + turn <= move_z):  # fmt: skip
                            ref = None
                    if ref is None and pruning.prune(x, y, z, a, b):
                        ref = [x, y, z, a, b]
                mujoco.mj_step(m, d)
                # the constraint forces of that step's collision, in the grip's joints
                self._impulse += d.qfrc_constraint
        finally:
            if pruned:
                pruning.restore()
        self._steps = n

    def features(self) -> FloatArray:
        """The peg's true features in {H}: (dx, dy, l, theta_x, theta_y)."""
        rot = self.data.xmat[self._peg].reshape(3, 3) @ R_ALIGNED  # R_HP
        return features_from_pose(rot, self.data.site_xpos[self._tip], self.pair.peg_radius)

    def period_constraint_force(self) -> FloatArray:
        """The constraint forces in every joint (``qfrc_constraint``), their mean over the
        timesteps of the last :meth:`step` [N, N·m]."""
        return self._impulse / max(self._steps, 1)

    def mean_wrench_on_hole(self) -> FloatArray:
        """The wrench the peg exerted on the hole over the last :meth:`step`, its mean over the
        timesteps, as :meth:`wrench_on_hole` gives it: what a force/torque sensor reads over
        the period (a soft contact at rest on the wall can let go for a timestep in eight).

        The grip's joints carry all the constraint force on the peg: its slides (the world's
        x, y, z; the tool's when carried) the force F, its hinges the moment M about the grip
        point g along their axes (``tau_j = a_j . M``); the hole bears ``-F`` and
        ``-(M + g x F)`` about its origin. The axes and g are the period's last: the grip point
        moves microns in a period, 0.1 % of the moment."""
        mean = self.period_constraint_force()[self._dofs]
        d, joints = self.data, self._joints
        # the slides' axes are the world's unless an arm carries the grip
        force = np.linalg.solve(d.xaxis[joints[:3]], mean[:3]) if self.carried else mean[:3]
        moment = np.linalg.solve(d.xaxis[joints[3:]], mean[3:])
        grip = d.xanchor[joints[3]]  # the hinges turn about it (the slides place it)
        return -np.concatenate([force, moment + np.cross(grip, force)])

    def wrench_on_hole(self) -> FloatArray:
        """The wrench the peg exerts on the hole, summed over their contacts, about the {H}
        origin in {H} axes: (fx, fy, fz, mx, my, mz) [N, N·m]; the contacts of the last
        timestep's collision."""
        total = np.zeros(6)
        d = self.data
        for i in range(d.ncon):
            con = d.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if (g1 in self._hole_geoms) == (g2 in self._hole_geoms):
                continue
            mujoco.mj_contactForce(self.model, d, i, self._force)
            frame = con.frame.reshape(3, 3)  # rows: the normal (geom1 -> geom2), tangents
            # the force and the torsional friction's torque (condim 4) geom1 exerts on geom2
            f, torque = frame.T @ self._force[:3], frame.T @ self._force[3:]
            if g1 in self._hole_geoms:  # the hole is geom1: the peg's on it is the opposite
                f, torque = -f, -torque
            total[:3] += f
            total[3:] += np.cross(con.pos, f) + torque
        return total
