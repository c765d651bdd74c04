"""Which facets of the bore the peg can touch in a timestep, so that MuJoCo's collision leaves
the others out (:meth:`~fbcc_ros.core.sim.plants.mujoco_scene.MujocoPegHole.step`): the same
contacts, the same trajectory to the last bit, nearly three times as fast with the peg along
the wall. A peg in a 10 µm bore lies within the clearance of every facet, so each was a
candidate for MuJoCo's convex collider at every timestep (most of a timestep's cost).

The bound is conservative: a facet is left out only if no point of the peg, moved by up to
:data:`PRUNE_MOVE` from where it is, can reach the half-spaces that hold the facet
(:meth:`FacetPruning.prune`). Tests: ``test/core/sim/test_mujoco_scene.py`` (pruned and
unpruned give equal trajectories; no facet left out touches the peg at 200 random poses).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

#: How far [m] a point of the peg may move (sideways, along z) before
#: :meth:`~.mujoco_scene.MujocoPegHole.step` finds again the hole's boxes it can touch: a
#: larger move keeps more boxes in the collision, a smaller one finds them more often.
#: Sideways it is kept small (the bore's facets lie within a fraction of a micrometre of a peg
#: against its wall), along z larger (the boxes' z-ranges and the peg's length are mm).
PRUNE_MOVE = (1.0e-7, 5.0e-6)
#: The pruning's slack [m]: 10 times :data:`~.mujoco_scene.CCD_TOLERANCE` (GJK goes on to a
#: contact when its distance, an upper bound of the true one, is within it), far above the
#: poses' rounding.
PRUNE_SLACK = 1.0e-8


class FacetPruning:
    """The half-spaces that hold each facet, and which facets the peg may touch (module doc).
    :meth:`prune` switches the others' collision off, :meth:`restore` back on."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, radius: float,
                 length: float, grip: float) -> None:  # fmt: skip
        """The half-spaces ``n . x >= o``, each within a z-range, that hold each bore and
        chamfer box, from its 8 corners (a box is their convex hull; the fixture is static):
        n the box's x axis (its inner face's normal) and, for a tilted box, that axis made
        horizontal (a chamfer box lies outside radius R: that keeps it from a peg deep in the
        bore). Both widened by the slack and by what the peg may move (:data:`PRUNE_MOVE`).

        Args:
            model, data: The scene's, after ``mj_forward`` (the fixture's poses are final).
            radius, length, grip: The peg's radius, length and grip point's height above its
                tip [m] (:class:`~.mujoco_scene.Part`).
        """
        m, d = model, data
        self._radius, self._half = radius, 0.5 * length
        bottom = m.geom("bottom").id
        fixture = np.flatnonzero(m.geom_bodyid == m.geom_bodyid[bottom])
        first = int(fixture.min())
        # the fixture's geoms are numbered in the MJCF's order: its boxes, then the bottom
        assert set(fixture.tolist()) == set(range(first, bottom + 1))
        signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        face, flat, tilted = [], [], []
        for geom in range(first, bottom):
            rot = d.geom_xmat[geom].reshape(3, 3)
            corners = d.geom_xpos[geom] + (signs * m.geom_size[geom]) @ rot.T
            z = corners[:, 2]
            n = rot[:, 0]
            face.append([*n, np.min(corners @ n), np.min(z), np.max(z)])
            if abs(n[2]) > 1e-9:
                h = np.array([n[0], n[1], 0.0]) / math.hypot(n[0], n[1])
                flat.append([*h, np.min(corners @ h), np.min(z), np.max(z)])
                tilted.append(geom - first)
        rows = np.array(face + flat).reshape(-1, 6)
        move_xy, move_z = PRUNE_MOVE
        # a peg point moved by up to move_xy sideways and move_z along z gains at most
        # |n_xy| move_xy + |n_z| move_z along n
        self._offsets = (rows[:, 3] - PRUNE_SLACK - np.hypot(rows[:, 0], rows[:, 1]) * move_xy
                         - np.abs(rows[:, 2]) * move_z)  # fmt: skip
        # a few z-ranges (the bore's, the chamfer's; equal ones, to rounding, merged into
        # their union): row i of group j has its normal and a 1 in columns 4j to 4j + 3, so
        # that one product with the groups' clipped axes gives every row's n . x
        self._zranges: list[list[float]] = []
        group = []
        for zlo, zhi in (rows[:, 4:] + [-move_z - PRUNE_SLACK, move_z + PRUNE_SLACK]).tolist():
            j = next((j for j, (lo, hi) in enumerate(self._zranges)
                      if abs(lo - zlo) < 1e-9 and abs(hi - zhi) < 1e-9),
                     len(self._zranges))  # fmt: skip
            if j == len(self._zranges):
                self._zranges.append([zlo, zhi])
            self._zranges[j] = [min(self._zranges[j][0], zlo), max(self._zranges[j][1], zhi)]
            group.append(j)
        self._by_group = np.zeros((len(rows), 4 * len(self._zranges)))
        for i, j in enumerate(group):
            self._by_group[i, 4 * j : 4 * j + 4] = [*rows[i, :3], 1.0]
        self._nbox, self._tilted = bottom - first, np.array(tilted, dtype=int)
        # views into the model's and the data's buffers, looked up once: step() is hot
        self._contype = m.geom_contype[first:bottom]
        self._conaffinity = m.geom_conaffinity[first:bottom]
        self._contype0, self._conaffinity0 = self._contype.copy(), self._conaffinity.copy()
        L, g = length, grip
        self._axial = L / 2 - g  # the cylinder's centre on the body's z axis
        # the farthest a point of the peg lies from the body's origin (the grip point)
        self.rho = math.hypot(max(g, L - g), radius)
        # MuJoCo resets a blown-up state to qpos0 within mj_step and collides there: the boxes
        # the peg may touch at rest stay in (none in a clearance fit)
        self._at_rest = np.zeros(self._nbox, dtype=bool)
        self.prune(0.0, 0.0, 0.0, 0.0, 0.0)
        self._at_rest = self._contype != 0
        self.restore()
        self.prunable = not self._at_rest.all()  # an interference fit: no box ever out

    def restore(self) -> None:
        """Every facet in the collision again."""
        np.copyto(self._contype, self._contype0)
        np.copyto(self._conaffinity, self._conaffinity0)

    def prune(self, x: float, y: float, z: float, a: float, b: float) -> bool:
        """Disable the boxes the peg cannot touch while it stays within :data:`PRUNE_MOVE` of
        the pose grip point (x, y, z), hinges a (about x) and b (y) (the hinge about z spins
        the cylinder onto itself); False, all enabled, where the bound is not meant to hold.

        A peg point's move is at most |dp| + (|da| + |db|) rho (||Rx(a) - Rx(a')|| <= |a - a'|,
        rho its farthest from the grip point); :meth:`~.mujoco_scene.MujocoPegHole.step`
        checks it per axis. The peg is its axis segment swept by a disk of radius r normal to
        the unit axis u, whose points lie within r sqrt(1 - u_z^2) of its centre in z and
        r sqrt(1 - (n . u)^2) along n: so the peg meets ``n . x >= o`` within [zlo, zhi]
        (widened, :meth:`__init__`) only if the axis, clipped to the z-range widened by the
        former, reaches o less the latter. MuJoCo's convex collider (margin 0) makes a contact
        only for geoms within its ``ccd_tolerance`` of each other (:data:`PRUNE_SLACK`).
        """
        sa, ca, sb, cb = math.sin(a), math.cos(a), math.sin(b), math.cos(b)
        ux, uy, uz = sb, -sa * cb, ca * cb  # the body's z axis: Rx(a) Ry(b) Rz(c) e_z
        if not (uz > 0.1 and max(abs(x), abs(y), abs(z)) < 1.0):  # sideways, or blown up
            self.restore()
            return False
        r, half, k = self._radius, self._half, self._axial
        cx, cy, cz = x + k * ux, y + k * uy, z + k * uz  # the cylinder's centre
        w = r * math.sqrt(max(0.0, 1.0 - uz * uz))
        ends: list[tuple[float, float, float]] = []
        for zlo, zhi in self._zranges:  # the axis's part within each z-range: [lo, hi]
            lo, hi = max(-half, (zlo - w - cz) / uz), min(half, (zhi + w - cz) / uz)
            short = 0.0
            if lo > hi:  # none: its rows' reach 1 m short of any box
                lo, hi, short = 0.0, 0.0, -1.0
            ends += [(cx + lo * ux, cx + hi * ux, ux), (cy + lo * uy, cy + hi * uy, uy),
                     (cz + lo * uz, cz + hi * uz, uz), (short, short, 0.0)]  # fmt: skip
        at = self._by_group @ np.array(ends)  # n . (axis at lo), n . (axis at hi), n . u
        nu = at[:, 2]
        reach = np.maximum(at[:, 0], at[:, 1]) + r * np.sqrt(np.abs(1.0 - nu * nu))
        ok = reach >= self._offsets
        near = ok[: self._nbox]
        near[self._tilted] &= ok[self._nbox :]  # a box is out of reach if one of its sets is
        near |= self._at_rest
        np.multiply(self._contype0, near, out=self._contype)
        np.multiply(self._conaffinity0, near, out=self._conaffinity)
        return True
