"""Telling a press fit from a jam under the push bound (``robust_params.push_limit``): what the
robust law (:mod:`fbcc_ros.core.control.robust_kernel`) lets its depth loop push in a clearance
fit's bore.

**Why a bound.** A peg free in its bore slides in with little push; a jammed one (tilted against
two walls, wedged) only presses tighter the harder it is pushed, into the wrench guard at 100 Hz
on MuJoCo. So the depth loop pushes at most ``push_limit`` there.

**What a bound alone stops.** A pair the law believes a clearance fit whose tolerances make an
interference fit (a press fit) needs more: its friction grows with the engaged length,
F_z ≈ c (l - l_0), and at ``push_limit`` it stops short (Table II's spreads make 3.5 % of the
pairs such parts).

**How the two differ.** A jam stops the peg at once: F_z climbs over the compression of the axial
path (10 N in 10 µm through the stiffest, ``hole_search.AXIAL_STIFFNESS``). A press fit's F_z
climbs with the engaged length, over millimetres (from half to the whole of 20 N over 0.5-0.8
mm on the no-rim study's parts that stopped), and the peg stops at the bound only once its
friction there has reached it. A peg that slides in at the bound needs no more. Neither the
lateral force nor the moments tell them apart: a part held all round whose offset the loops
correct is pushed sideways by half its F_z, a wedged peg by none.

**What the law does.** A climb of F_z starts where F_z was last under half ``push_limit``, at
the arm's depth l_a and force F_a. A peg that stops at the bound (F_z over :data:`PRESS_AT` of
``push_limit`` for :data:`PRESS_WAIT`, advancing under :data:`PRESS_STALL`) at l_p, F_p, after
a climb that rose by :data:`PRESS_RISE` of ``push_limit`` or more no steeper than
:data:`PRESS_SLOPE`, is a press fit's, and the two points set its line

.. math::
    F(l) = F_a + s\\,(l - l_a), \\qquad s = \\frac{F_p - F_a}{l_p - l_a};

the bound is then :data:`PRESS_MARGIN` max(F(l), ``push_limit``). A press that goes deeper
raises its bound as its friction rises. A steeper climb starts again from l_p, and under the
bound F_z rises no further: a jam stays at ``push_limit``. F_z falling under half
``push_limit`` forgets the line.

**What it cannot tell.** On our model's soft walls (1-60 GPa) a tilted peg in a 10-30 µm bore
can plough in as a press fit does and stop at the bound: at 100 Hz with the rim 11 of 1000
clearance parts changed (8 in sooner, 2 later within the goal, one failing either way), and F_z
p99 went from 40 N to 43 N (``docs/plant.md``).
"""

from __future__ import annotations

import math

import numba

from fbcc_ros.core.arrays import FloatArray

#: The steepest rise of F_z with the arm's depth [N/m] of a press fit: a jam's is the axial
#: path's stiffness (10 N in 10 µm through the stiffest, ``hole_search.AXIAL_STIFFNESS``; 10 N
#: in ``wedge.WEDGE_TRAVEL`` on MuJoCo's grip), a press fit's its friction per engaged length
#: (200 N, the most the studies press, over 10 mm: 2e4 N/m).
PRESS_SLOPE = 5.0e4
#: The bound over the press's line: its F_z is friction plus what the arm's speed adds, and
#: the line, through two points, is an estimate.
PRESS_MARGIN = 1.5
#: The least rise of F_z, as a fraction of ``push_limit``, whose slope is measured: far over
#: the noise.
PRESS_RISE = 0.25
#: F_z at the bound, as a fraction of ``push_limit``: the depth loop holds it there within
#: its noise and the arm's lag.
PRESS_AT = 0.9
#: How long [s] F_z stays at the bound before the law asks whether the peg has stopped, and
#: the least advance [m] over that time of a peg that has not: a tenth of the insertion's
#: speed (5 mm/s). A peg that slides in at the bound needs no more.
PRESS_WAIT = 0.1
PRESS_STALL = 5.0e-5

# Columns of the press line's state in the law's per-trial state.
S_FROM = 0  # the arm's depth where the climb started [m]
S_FROM_F = 1  # F_z there [N]
S_SLOPE = 2  # the press's line's slope [N/m] (0: no press)
S_WAIT = 3  # how long F_z has been at the bound [s]
S_AT = 4  # the arm's depth when it came there [m]
N_STATE = 5


def reset(states: FloatArray) -> None:
    """Start each row of ``states`` (N, N_STATE) with no climb seen: a load already on at the
    start is no press fit's."""
    states[:] = 0.0
    states[:, S_FROM_F] = math.inf


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def bound(state: FloatArray, depth: float, fz: float, push: float, dt: float) -> float:
    """The most [N] the depth loop pushes at the arm's ``depth`` and ``fz`` under ``push``
    (``push_limit``), a period ``dt`` after the last: ``push``, or along a press fit's line
    (module doc); advances ``state``."""
    climbing = state[S_SLOPE] == 0.0
    at_bound = climbing and fz >= PRESS_AT * push
    if not at_bound:
        state[S_WAIT], state[S_AT] = 0.0, depth
    if fz < 0.5 * push:
        state[S_FROM], state[S_FROM_F], state[S_SLOPE] = depth, fz, 0.0
    elif at_bound:
        state[S_WAIT] += dt
        if state[S_WAIT] >= PRESS_WAIT:
            if depth - state[S_AT] < PRESS_STALL:  # stopped there: does it need more?
                rise, travel = fz - state[S_FROM_F], depth - state[S_FROM]
                if PRESS_RISE * push <= rise <= PRESS_SLOPE * travel:
                    state[S_SLOPE] = rise / travel
                else:  # not a press's climb: it starts again from here
                    state[S_FROM], state[S_FROM_F] = depth, fz
            state[S_WAIT], state[S_AT] = 0.0, depth
    if state[S_SLOPE] == 0.0:
        return push
    return PRESS_MARGIN * max(state[S_FROM_F] + state[S_SLOPE] * (depth - state[S_FROM]), push)
