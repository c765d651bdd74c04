"""Finding the hole: what the robust law (:mod:`fbcc_ros.core.control.robust_kernel`) does when
the peg lands on the hole's top face.

A hole off by more than its clearance and chamfer meets the peg's end face on the flat beside
the bore. The face pushes only along z, so the lateral rows read nothing but its friction, the
tilt rows read the face's moment, and the depth loop holds the peg there at an effort of 1
(20 N on a 10 µm pair 0.1 mm off, ``docs/integration.md``): it would stand there for good.

**Where the hole is.** The face carries the part of the end face that lies outside the bore: a
crescent on the side away from the hole, or the corner a tilted peg leans on. Its centre of
pressure c lies on that side, so the hole is along -c. With the face's contact at the top of
the hole (z = 0 of {H}) and the lever ``λ`` of eq. 24 at the entry, the tilt rows of eq. 28 are

.. math::
    u_{\\theta_y} = \\frac{\\cos\\gamma}{R}(M_y - \\lambda F_x)
    \\approx \\frac{\\cos\\gamma}{R}\\,c_x F_z, \\qquad
    u_{\\theta_x} = \\frac{\\cos\\gamma}{R}(M_x + \\lambda F_y)
    \\approx -\\frac{\\cos\\gamma}{R}\\,c_y F_z,

c taken from the acting point (the friction's μR F_lat is left out: a face's friction is under
μ F_z, small against c F_z). An acting point that rides on the peg (``peg_top``) lies
``peg_length · t`` beside the tip for a lean t = (tan θ_y, -tan θ_x), which
:func:`face_support` adds back; a point fixed in {H} (the cell's, under the hole) is within the
hole's offset of the axis.

**How far out c lies** depends on how the face gives. A compliant face carries the peg flat on
the whole crescent; a rigid one lets the grip's angular spring tip the peg toward the hole until
it rests near the chord between the crescent's ends, which still lies on the peg's side of the
hole's axis. Measured 0.1 mm off a 10 µm hole, the support's lever My/Fz is 1.5-2.1 mm on our
model and 0.6-1.1 mm on MuJoCo (``docs/plant.md``, the peg on the rim). The search trusts the
direction only while the support's tilt rows stand out of their dead band (``dead_band``
filtered-noise deviations): a peg carried all round (an interference fit on its chamfer) reads
c ≈ 0 and does not search.

**What the law does.** At the entry (the measured depth under :data:`START_DEPTH` to start,
under ``tilt_depth``, where the tilt rows do not integrate, once started), before the depth is
reached, while the face carries the load (F_z over half ``search_force``, the lateral force
under :data:`START_FRICTION` of it to start, under :data:`FACE_FRICTION` once sliding) and the
support's rows stand out of their dead band:

* the offset command moves toward -c at ``search_speed``; the offset loops, which would read
  the face's friction as an offset, hold;
* the depth holds F_z at ``search_force``: above it the depth command backs off at
  ``depth_bandwidth`` (F_z - ``search_force``) / :data:`AXIAL_STIFFNESS`, a loop that crosses
  over at ``depth_bandwidth`` on the stiffest axial path it is designed for and slower on a
  softer one. A light load rubs little: the grip deflects by μ F_z over its stiffness before
  the peg slides, and the peg snaps by as much when the face lets it go;
* the search ends after ``search_range`` of travel (its time budget: ``search_range`` /
  ``search_speed``, 1 s by default); the law then goes on as without it.

Once the end face is over the bore the peg drops in, the wall pushes sideways more than the face
carries, and the law's own loops take over. A chamfer acts first: its slope pushes the peg
toward the axis with a lateral force of the order of F_z, which stops the search. An
interference fit does not search: its peg always meets the rim, and only a chamfer leads it in.
"""

from __future__ import annotations

import math

import numba

#: The largest ratio of lateral to axial force read as the top face: its friction, μ F_z, for
#: the μ up to 0.5 the law is meant for (with a margin). A wall pushes sideways 1/μ >= 2 times
#: its axial drag where it touches on one side; a near line-to-line pair touching on two sides
#: at the entry (1.3 µm, 72 GPa) read 0.98 and, taken for a face, turned the peg by a step.
FACE_FRICTION = 2.0 / 3.0
#: Before a search starts, the face is told from a tight pair's wall by two more signs. A peg
#: standing on it has not slid yet (lateral force under this fraction of F_z) and the arm is
#: only as deep as its axial path gives (:data:`START_DEPTH`). Near line-to-line pairs (0.2-0.5
#: µm, 20-100 GPa, 50-100 µm off) touch on two sides 25-190 µm in, at lateral ratios of
#: 0.3-0.65: taken for a face, 4 of 32 were turned into the wall and failed.
START_FRICTION = 0.2
#: The deepest the arm is [m] while the face holds the peg: the axial path's compression under
#: the first contact's force, 45 µm at 45 N through the stiffest path (:data:`AXIAL_STIFFNESS`).
START_DEPTH = 5.0e-5
#: The stiffest axial path [N/m] (grip, sensor and arm in series down to the face) the search's
#: force loop is designed for: the holder's default axial stiffness, ``holder.AXIAL``.
AXIAL_STIFFNESS = 1.0e6


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def face_support(fz: float, u_tx: float, u_ty: float, cg_r: float, lean_arm: float,
                 tan_ty: float, tan_tx: float) -> tuple[float, float]:
    """The face's support in the tilt rows' units (module doc): (c_x, c_y) F_z cos(γ) / R, c
    its centre of pressure from the tip's axis (``lean_arm`` > 0: the acting point rides on the
    peg that far over the tip) or from the acting point's (0: a point fixed in {H}), from F_z
    and the filtered tilt rows (u_θx, u_θy) with their ``cg_r`` = cos(γ) / R at the entry
    (``segmentation.tilt_terms``); ``tan_ty``, ``-tan_tx`` the lean t."""
    back = fz * lean_arm * cg_r
    return u_ty + back * tan_ty, -u_tx - back * tan_tx


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def on_face(fz: float, f_lat: float, support: float, dead_band: float, search_force: float,
            started: bool) -> bool:  # fmt: skip
    """Whether the top face carries the peg off-centre (module doc): the axial force over half
    ``search_force``, the lateral one under :data:`FACE_FRICTION` of it (under
    :data:`START_FRICTION` until the search has ``started``), the support's rows (their norm
    ``support``) out of their dead band."""
    friction = FACE_FRICTION if started else START_FRICTION
    return f_lat < friction * fz and fz > 0.5 * search_force and support > dead_band


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def within_reach(depth: float, tilt_depth: float, started: bool) -> bool:
    """Whether the measured depth is the face's (module doc): under :data:`START_DEPTH` until
    the search has ``started``, then under ``tilt_depth``."""
    return depth < (tilt_depth if started else START_DEPTH)


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def hold_rate(fz: float, force: float, bandwidth: float) -> float:
    """The depth rate [m/s] that brings F_z to ``force``, crossing over at ``bandwidth`` on
    :data:`AXIAL_STIFFNESS` (negative: a back-off)."""
    return bandwidth * (force - fz) / AXIAL_STIFFNESS


@numba.njit(cache=True, inline="always")  # type: ignore[misc]
def force_rate(fz: float, search_force: float, bandwidth: float) -> float:
    """The depth rate [m/s] that holds F_z at ``search_force`` while searching: a back-off above
    it (:func:`hold_rate`); no limit below it."""
    return hold_rate(fz, search_force, bandwidth) if fz > search_force else math.inf
