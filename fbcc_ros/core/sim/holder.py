"""The compliance of what holds the peg (arm + F/T sensor + gripper), in series with the contact.

The simulator's plant (:mod:`fbcc_ros.core.sim.simulation`) holds the peg rigidly: the true
features are the robot's pose plus the hole's deviation. A real peg sits at the end of a chain of
springs — the arm's joints, the F/T sensor's flexures, the grip of the fingers — so under a contact
wrench it deflects, and the contact, much stiffer than the chain, sees far less force than a rigid
holder would put through it. This module models the holder; :mod:`fbcc_ros.core.sim.holder_solver`
finds the quasi-static equilibrium.

**Model.** The holder is one diagonal spring at the *grip point* G, the centre of the peg's top
face (``peg_length`` along the axis from the tip, where a parallel gripper holds it; the flange,
sensor and arm sit above G and their compliances are referred to it):

* ``lateral`` [N/m]: the translation ``u = (u_x, u_y)`` of G along x and y of {H};
* ``angular`` [N·m/rad]: the rotation ``phi = (phi_x, phi_y)`` of the peg about x and y through G
  (right-hand, the same sense as theta_x, theta_y; DESIGN §3);
* ``axial`` [N/m]: the peg's depth. Only a hole with its rim (``PegHole.rim``: its top face,
  chamfer and bottom) pushes the peg along its axis; against the paper's wall alone the depth is
  the commanded one (the insertion is position controlled). About z the holder stays rigid. No
  coupling between translation and rotation at G (a remote centre compliance device, whose
  centre sits near the tip, is a different model).

**Equilibrium.** The response ``W = (Fx, Fy, Fz, Mx, My)`` is the wrench the peg exerts on the hole
with moments at the contact's acting point A; the hole pushes back on the peg with ``-W``. The
peg is weightless and quasi-static, so the holder's spring balances ``-W`` at G:

.. math::
    k_l\\,u = -(F_x, F_y), \\qquad k_a\\,\\phi = -(M_{G,x}, M_{G,y}),

with ``M_G`` the moment of the peg-on-hole wrench about G. With the force vector on the hole
``F = (Fx, Fy, -Fz)`` (Fz > 0 drags the hole along -z, see :meth:`PegHole.response`) and
``M_G = M_A + (A - G) × F``:

.. math::
    M_{G,x} = M_x + (y_G - y_A) F_z + (z_G - z_A) F_y, \\qquad
    M_{G,y} = M_y - (z_G - z_A) F_x - (x_G - x_A) F_z,

where, as in the contact kernel's ``peg_top`` acting point (with lean ``t = (tan theta_y,
-tan theta_x)``, ``tan theta = |t|``), ``z_G = (r sin theta + peg_length - l) cos theta`` and
``(x_G, y_G) = (dx, dy) + (peg_length - l/2) cos theta · t``; A is ``(0, 0, -(L + H))`` for the
default ``hole_bottom`` acting point, and A = G (no transfer) for ``peg_top``. Check of the sign: a
lateral push Fx > 0 on the hole at a height h below G gives ``M_G,y = -h Fx``, so
``phi_y = h Fx / k_a > 0``: the peg's lower end swings back toward -x, as it should.

**Features.** The peg is a rigid body turned by phi about G and shifted by u, so its features
move by

.. math::
    \\delta = (u_x - h\\,\\phi_y,\\; u_y + h\\,\\phi_x,\\; 0,\\; \\phi_x,\\; \\phi_y),
    \\qquad h = \\mathrm{peg\\_length} - l/2,

h being the distance along the axis from the feature point (the axis at depth l/2) up to G
(first order in the tilts; the axial drop of order h phi²/2 is neglected: the depth is rigid).

**Typical stiffness** at the grip point G of a ~50 mm peg held at its top by a parallel gripper.
"Datasheet" values are manufacturers' calculated stiffness as recalled here, not checked against
the current datasheets (the document search available when this was written did not return
them); "estimate" values are orders of magnitude from the structure. Measure the real cell before
relying on them: push on the grasped peg at G and at its tip with a force gauge and read the
deflections (two points give k_l and k_a).

==============================  ============  =================  ===============================
element                         lateral       angular            source
                                [N/m]         [N·m/rad]
==============================  ============  =================  ===============================
ATI Gamma F/T sensor            9.1e6         1.1e4              datasheet (Kx = Ky; Ktx = Kty)
ATI Mini45 F/T sensor           ~1e7 - 1e8    ~1e4               datasheet, order of magnitude
                                                                 only (recalled, unverified)
KUKA LBR iiwa, position mode    2e4 - 2e5     5e2 - 3e3          estimate: joint stiffness
                                                                 ~1e4 N·m/rad (harmonic drive,
                                                                 torque sensor) over levers of
                                                                 0.4 - 0.8 m, joints in series
parallel gripper, friction      1e4 - 1e5     1e1 - 3e2          estimate: elastomer or plastic
pads on the peg's top                                            pads ~1e5 N/m; a grasp ~10 mm
                                                                 tall resists tilt only over
                                                                 its pads' height
LBR + Gamma + gripper,          ~2e4 - 5e4    ~1e1 - 3e2         the series sum; the grasp
in series                                                        dominates the tilt, arm and
                                                                 grasp share the lateral part
==============================  ============  =================  ===============================

:data:`LBR_GAMMA_GRIPPER` is the middle of the last row, ``Holder(2.5e4, 30)`` (``Holder.series``
of :data:`LBR_IIWA_ESTIMATE`, :data:`ATI_GAMMA` and :data:`PARALLEL_GRIPPER_ESTIMATE`): a 10 N
side load deflects G by 0.4 mm and, applied 40 mm below G, tilts the peg by 0.8°, far more than a
10 µm clearance. A metal V-groove grasp is one to two decades stiffer in tilt. A real arm's
compliance is a full 6×6 matrix (a side force at G also turns the flange through the big joints);
the diagonal model keeps the two terms a push test measures.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import ContactBatch
from fbcc_ros.core.errors import ConfigError, InputError

#: A contact response: features (N, 5) -> wrench on the hole (N, 5), e.g. ContactBatch.response.
Response = Callable[[FloatArray], FloatArray]
BoolArray = NDArray[np.bool_]

#: A grip's stiffness along the peg's axis [N/m]: an LBR in position control and a parallel
#: gripper's pads referred to the grip point, an estimate of the same order as the lateral row of
#: the table above (the rim's face pushes against it; MuJoCo's grip uses it too).
AXIAL = 1.0e6


def _stiffness(field: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
        raise ConfigError(field, value, "a finite stiffness > 0 (SI units)")
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ConfigError(field, value, "a finite stiffness > 0 (SI units)")
    return v


@dataclasses.dataclass(frozen=True)
class Holder:
    """The holder's stiffness at the grip point (see the module doc).

    Attributes:
        lateral: Stiffness of the grip point along x and y of {H} [N/m], finite and > 0.
        angular: Stiffness of the peg's tilt about x and y through the grip point [N·m/rad],
            finite and > 0.
        axial: Stiffness along the peg's axis [N/m], finite and > 0 (default :data:`AXIAL`).
            Only a hole with its rim (``PegHole.rim``) pushes the peg along its axis: against
            the paper's wall alone the depth stays the commanded one.

    About z the holder is rigid. :meth:`rigid` (or ``None`` wherever a holder is taken) is the
    rigid holder of the original plant.
    """

    lateral: float
    angular: float
    axial: float = AXIAL

    def __post_init__(self) -> None:
        object.__setattr__(self, "lateral", _stiffness("holder.lateral", self.lateral))
        object.__setattr__(self, "angular", _stiffness("holder.angular", self.angular))
        object.__setattr__(self, "axial", _stiffness("holder.axial", self.axial))

    @classmethod
    def rigid(cls) -> Holder:
        """The rigid holder (infinite stiffness; the only instance that is not finite)."""
        h = object.__new__(cls)
        object.__setattr__(h, "lateral", math.inf)
        object.__setattr__(h, "angular", math.inf)
        object.__setattr__(h, "axial", math.inf)
        return h

    @property
    def is_rigid(self) -> bool:
        return math.isinf(self.lateral)

    @classmethod
    def series(cls, *parts: Holder) -> Holder:
        """Springs in series, each referred to the grip point: ``1/k = sum 1/k_i`` per axis."""
        if not parts:
            raise ConfigError("holder.parts", [], "at least one Holder")
        soft = [p for p in parts if not p.is_rigid]
        if not soft:
            return cls.rigid()
        return cls(
            1.0 / sum(1.0 / p.lateral for p in soft),
            1.0 / sum(1.0 / p.angular for p in soft),
            1.0 / sum(1.0 / p.axial for p in soft),
        )

    def scaled(self, factor: float) -> Holder:
        """Every stiffness times ``factor``."""
        return Holder(self.lateral * factor, self.angular * factor, self.axial * factor)


#: ATI Gamma F/T sensor (datasheet calculated stiffness, as recalled: Kx = Ky, Ktx = Kty).
ATI_GAMMA = Holder(9.1e6, 1.1e4)
#: KUKA LBR iiwa in position control: each joint's stiffness [N·m/rad] (estimate: harmonic drive
#: and torque sensor in series; the table above), what MuJoCo's LBR gives its joint servos.
LBR_JOINT_STIFFNESS = 1.0e4
#: The same arm referred to a grip point ~0.1 m past the flange (estimate).
LBR_IIWA_ESTIMATE = Holder(5e4, 1e3)
#: A parallel gripper with friction pads holding the peg's top (estimate).
PARALLEL_GRIPPER_ESTIMATE = Holder(5e4, 30.0)
#: The three in series, rounded: ~2.5e4 N/m and ~30 N·m/rad (the grasp dominates the tilt).
LBR_GAMMA_GRIPPER = Holder(2.5e4, 30.0)


@dataclasses.dataclass(frozen=True, eq=False)
class Grip:
    """Where the grip point is, relative to the point the response's moments are taken at.

    Attributes:
        peg_length: Tip-to-top length of the peg [m], scalar or one per row: G is the top face.
        acting_depth: Depth of the acting point below the hole's top face, ``L + H`` [m] (the
            ``hole_bottom`` acting point, on the hole axis), scalar or per row; ``None`` when the
            response's moments are already taken at the peg's top (``peg_top``).
        peg_radius: r [m], for the ``r sin(theta)`` term of the grip height (second order;
            0 drops it).
    """

    peg_length: float | FloatArray
    acting_depth: float | FloatArray | None
    peg_radius: float | FloatArray = 0.0

    @classmethod
    def of(cls, contact: ContactBatch) -> Grip:
        """The grip of a contact batch: its peg lengths, radii and acting point."""
        table = contact.table
        depth = None if contact.peg_top else table[4] + table[5]  # L + H
        return cls(table[6].copy(), depth, table[1].copy())


class Equilibrium(NamedTuple):
    """The solved equilibrium, per row.

    Attributes:
        features: The peg's actual features ``x_robot + delta`` (N, 5).
        wrench: The contact response at those features (N, 5), moments at the contact's own
            acting point (what the rigid plant reported).
        delta: ``(ddx, ddy, 0, dtheta_x, dtheta_y)`` (N, 5), see the module doc.
        converged: Whether the force balance is within the tolerances (N,).
    """

    features: FloatArray
    wrench: FloatArray
    delta: FloatArray
    converged: BoolArray


def per_row(value: float | FloatArray, n: int, field: str) -> FloatArray:
    """A scalar (or one-element) ``value`` repeated over n rows, or an (n,) array as it is."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 0 or a.shape == (1,):
        return np.full(n, float(a.reshape(-1)[0]))
    if a.shape != (n,):
        raise InputError(field, f"array of shape {a.shape}", f"a scalar or shape ({n},)")
    return a


def grip_moments(
    features: FloatArray, wrench: FloatArray, grip: Grip
) -> tuple[FloatArray, FloatArray]:
    """``(M_G,x, M_G,y)``: the moments of the peg-on-hole wrench about the grip point G (N,).

    ``features`` and ``wrench`` are (N, 5) rows, the wrench's moments at the acting point of
    ``grip``; see the module doc for the formula.
    """
    x = np.asarray(features, dtype=float)
    w = np.asarray(wrench, dtype=float)
    if grip.acting_depth is None:  # the moments are already at the peg top
        return w[:, 3].copy(), w[:, 4].copy()
    x_g, y_g, z_g = grip_point(x, grip)
    h = z_g + per_row(grip.acting_depth, len(x), "grip.acting_depth")  # z_G - z_A
    return w[:, 3] + y_g * w[:, 2] + h * w[:, 1], w[:, 4] - h * w[:, 0] - x_g * w[:, 2]


def grip_point(features: FloatArray, grip: Grip) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(x_G, y_G, z_G)``: where the grip point G is in {H} for feature rows (N, 5) (module
    doc; first order in the tilts, as the holder)."""
    x = np.asarray(features, dtype=float)
    n = len(x)
    pl = per_row(grip.peg_length, n, "grip.peg_length")
    rad = per_row(grip.peg_radius, n, "grip.peg_radius")
    tx, ty = np.tan(x[:, 4]), -np.tan(x[:, 3])
    tan2 = tx * tx + ty * ty
    cos_t = 1.0 / np.sqrt(1.0 + tan2)
    sin_t = np.sqrt(tan2) * cos_t
    l = x[:, 2]
    along = (pl - 0.5 * l) * cos_t
    return x[:, 0] + along * tx, x[:, 1] + along * ty, (rad * sin_t + pl - l) * cos_t
