"""Freeing a wedged peg: what the robust law (:mod:`fbcc_ros.core.control.robust_kernel`) does
when a clearance fit stops going in with nothing in its rows.

**Wedging.** A peg tilted by e in its bore touches on two sides at once, its tip on one wall
and the rim on the other, at the depth l where its span fills the bore (l ≈ 2c/e for a radial
clearance c). If l is under μ times the bore's diameter, friction locks it there (Whitney's
wedging). The two contacts then carry the axial push between them, along the line that joins
them, and the wrench the law reads is that push and nothing else: the rows of eq. 28 read no
moment and no lateral force, so the tilt loops, which turn the peg on a moment, never learn its
tilt, and the depth loop, seeing no effort, pushes on (``docs/plant.md``, the Monte Carlo on
MuJoCo).

**What frees it.** Turning the peg toward its bore's axis about the middle of its engaged
length (where the features' offsets are taken) shortens its span: both contacts open, and a
push takes the peg deeper. Turning it the other way is blocked, and the contact pushes back
with a moment the tilt rows read. Which way is which, the wrench does not say.

**What the law does.** A clearance fit's insertion, whose axial force climbs from half
``wedge_force`` to ``wedge_force`` within :data:`WEDGE_TRAVEL` of the arm's travel while its
rows stay under :data:`QUIET` of their hold, has stopped at once with nothing in its rows. If
the load began where a wedge can be (:func:`depths`: in the bore all round, where its span
fills the bore), it is wedged, until the arm is :data:`FREE_ADVANCE` deeper or
:data:`PROBE_TIME` has passed (then the law pushes again, and a peg still wedged is wedged
again). While it is, the depth loop holds F_z at ``search_force`` and the tilt command moves at
``tilt_rate`` in one direction, at most :data:`PROBE_RANGE` from where it wedged. Where the
tilt rows push back against that direction by more than ``wedge_force`` (in their units, a
force at the rim), or the range is reached, the direction turns by the golden angle and the
next is tried; the tilt loops take back what a blocked one loaded. A free direction turns the
peg until it goes in, and is kept: the next wedge, if any, is likely the same one deeper. An
interference fit's friction, which grows with the engaged length, loads the arm over
millimetres and is never taken for a wedge.
"""

from __future__ import annotations

import math

import numba

from fbcc_ros.core.arrays import FloatArray

#: The most arm travel [m] over which F_z climbs from half ``wedge_force`` to ``wedge_force``
#: for the load to be a wedge's: the peg stops at once and the arm compresses the grip's axial
#: path (``hole_search.AXIAL_STIFFNESS``, 10 N in 10 µm), where an interference fit's friction
#: grows with the engaged length, over millimetres.
WEDGE_TRAVEL = 5.0e-5
#: The most friction the law is meant for: a two-point contact deeper than this times the
#: bore's diameter does not wedge (Whitney), and a load that comes at once there is a stiff
#: near line-to-line pair's, which the probe's turn would jam.
WEDGE_FRICTION = 0.5
#: The most a wedged peg's axis, or the hole's top face, is off the believed hole's [rad]: a
#: hole up to 2° off in each axis (2.8° in all) and a degree more that the tilt loops may turn
#: the peg. It bounds where a wedge can be (:func:`depths`).
WEDGE_TILT = math.radians(4.0)
#: The advance [m] past the depth where it wedged that frees the peg: several of the entry's
#: steps, more than a loaded grip's creep.
FREE_ADVANCE = 2.0e-5
#: The most effort (the rows' over their hold, as the depth loop reads them) of a wedge: a peg
#: the rows hold back is the law's own loops' to free.
QUIET = 0.5
#: How long [s] the probe tries to free a wedge before the law pushes again.
PROBE_TIME = 0.5
#: The farthest [rad] the probe turns the command from where it wedged: a freed peg wedges
#: again deeper, if at all, and the probe goes on from there; a contact that lets the peg turn
#: without pushing back or letting it in (a compliant one) is not turned far.
PROBE_RANGE = math.radians(0.5)
#: The turn [rad] of the probe's direction after a blocked one: the golden angle, which spreads
#: the directions tried evenly however many there are.
PROBE_TURN = math.pi * (3.0 - math.sqrt(5.0))

# Columns of the wedge's state in the law's per-trial state.
S_LIGHT = 0  # the arm's depth when F_z was last under half wedge_force [m]
S_WEDGED = 1  # 1 while wedged
S_FROM = 2  # the depth at which it wedged [m]
S_SINCE = 3  # how long it has been wedged [s]
S_PHASE = 4  # the probe's direction [rad]
S_BLOCKED = 5  # 1 while that direction is blocked
S_TURNED = 6  # the probe's turn of the command since it wedged (θ_x, θ_y) [rad]
N_STATE = 8


def depths(hole_radius: float, peg_radius: float, chamfer: float) -> tuple[float, float]:
    """The depths [m] of the believed hole at which a load can be a wedge's (Whitney), from a
    pair's radii and chamfer: past the chamfer and the top face however it tilts by
    :data:`WEDGE_TILT` (by R sin of it over the bore: a load higher up can be the peg resting
    on the face or the bore's edge), where the peg's span fills the bore (2 (R - r) / sin of
    that tilt below the bore's edge, which the face's tilt may raise by as much), and short of
    :data:`WEDGE_FRICTION` times the bore's diameter below that edge, past which friction does
    not lock it. (A peg up to 0.1 mm off the axis moves the face under it by under 10 µm.)"""
    rise = hole_radius * math.sin(WEDGE_TILT)
    two_point = 2.0 * (hole_radius - peg_radius) / math.sin(WEDGE_TILT)
    return (chamfer + max(rise, two_point - rise),
            chamfer + rise + WEDGE_FRICTION * 2.0 * hole_radius)  # fmt: skip


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def wedged(state: FloatArray, depth: float, fz: float, quiet: bool, wedge_force: float,
           dt: float, shallowest: float, deepest: float) -> bool:  # fmt: skip
    """Whether the insertion is wedged (module doc) at the arm's ``depth`` and ``fz``, its rows
    ``quiet`` or not, a period ``dt`` after the last; advances ``state``. A load that began
    (F_z over half ``wedge_force``) outside the :func:`depths` ``shallowest``, ``deepest`` is
    not taken for one."""
    if state[S_WEDGED] > 0.0:
        state[S_SINCE] += dt
        if depth > state[S_FROM] + FREE_ADVANCE or state[S_SINCE] > PROBE_TIME:
            state[S_WEDGED] = 0.0
    elif (fz >= wedge_force and quiet and depth - state[S_LIGHT] < WEDGE_TRAVEL
          and shallowest <= state[S_LIGHT] < deepest):
        state[S_WEDGED], state[S_FROM], state[S_SINCE] = 1.0, depth, 0.0
        state[S_TURNED], state[S_TURNED + 1] = 0.0, 0.0
    if fz < 0.5 * wedge_force:
        state[S_LIGHT] = depth
    return state[S_WEDGED] > 0.0


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def probe_step(state: FloatArray, dt: float, speed: float, u_tx: float, u_ty: float,
               gate: float) -> tuple[float, float]:  # fmt: skip
    """The tilt command's step (θ_x, θ_y) [rad] of a wedged insertion over ``dt``: at
    ``speed`` in the probe's direction, unless the filtered tilt rows (u_θx, u_θy) push back
    against it by more than ``gate`` or it would leave :data:`PROBE_RANGE`, which turns the
    direction by :data:`PROBE_TURN`."""
    cx, cy = math.cos(state[S_PHASE]), math.sin(state[S_PHASE])
    tx, ty = state[S_TURNED] + speed * dt * cx, state[S_TURNED + 1] + speed * dt * cy
    # a row reads positive where the command went too far its way (the loops lower it)
    if u_tx * cx + u_ty * cy > gate or tx * tx + ty * ty > PROBE_RANGE * PROBE_RANGE:
        if state[S_BLOCKED] == 0.0:
            state[S_PHASE] = (state[S_PHASE] + PROBE_TURN) % (2.0 * math.pi)
            state[S_BLOCKED] = 1.0
        return 0.0, 0.0
    state[S_BLOCKED] = 0.0
    state[S_TURNED], state[S_TURNED + 1] = tx, ty
    return speed * dt * cx, speed * dt * cy
