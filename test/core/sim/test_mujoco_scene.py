"""The MuJoCo peg-in-hole scene against physics: a free insertion meets no force, a peg pushed
into the wall reads the grip's stiffness times its deflection, sliding begins and goes on at
mu N, the bottom and the top face stop the peg, a chamfer leads an offset peg in."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.mujoco_scene import (
    AXIAL,
    Contact,
    MujocoPegHole,
    Part,
    scene_xml,
    shape_error,
)

R, CLEARANCE = 0.00501, 1.0e-5


def _pair(friction: float = 0.15, depth: float = 0.01) -> PegHole:
    return PegHole(hole_radius=R, peg_radius=R - CLEARANCE, hole_depth=depth,
                   base_thickness=0.005, friction=friction, stiffness=1e11)  # fmt: skip


def _move(plant: MujocoPegHole, start: np.ndarray, end: np.ndarray, seconds: float,
          every: int = 10) -> list[np.ndarray]:  # fmt: skip
    """The hand from ``start`` to ``end`` in ``seconds``; the wrench on the hole each ``every``
    steps."""
    n = max(1, round(seconds / (plant.dt * every)))
    wrenches = []
    for k in range(1, n + 1):
        plant.set_hand(start + (end - start) * k / n)
        plant.step(every)
        wrenches.append(plant.wrench_on_hole())
    return wrenches


def test_the_bores_shape_error_is_the_polygons() -> None:
    assert shape_error(0.005, 128) == pytest.approx(0.005 * (1 / math.cos(math.pi / 128) - 1))
    assert 1.4e-6 < shape_error(0.005, 128) < 1.6e-6
    assert scene_xml(_pair()).count('class="hole"/>') == 128 + 1  # the facets and the bottom
    assert scene_xml(_pair(), part=Part(chamfer=3e-4)).count('class="hole"/>') == 2 * 128 + 1


def test_bad_scene_parameters_are_refused() -> None:
    with pytest.raises(ConfigError, match="timeconst"):
        Contact(timeconst=1e-4, timestep=1e-4)
    with pytest.raises(ConfigError, match="timestep"):
        Contact(timeconst=1e-3, timestep=2e-4)  # past MAX_TIMESTEP, the armature's
    with pytest.raises(ConfigError, match="facets"):
        Part(facets=8)
    with pytest.raises(ConfigError, match="chamfer"):
        Part(chamfer=0.01, rim=0.005)


def test_an_aligned_peg_inserts_freely_at_10_um_clearance() -> None:
    plant = MujocoPegHole(_pair(depth=0.012), Holder(5e4, 30.0))
    start, end = np.array([0, 0, -0.001, 0, 0.0]), np.array([0, 0, 0.010, 0, 0.0])
    plant.place(start)
    wrenches = _move(plant, start, end, 1.1)
    assert max(abs(w[2]) for w in wrenches) < 0.5
    assert plant.features()[2] == pytest.approx(0.010, abs=2e-6)


@pytest.mark.parametrize("lateral", [2e4, 5e4, 2e5])
def test_a_peg_pushed_into_the_wall_reads_the_grips_stiffness(lateral: float) -> None:
    """The hand 0.1 mm sideways: the peg stops at the wall, 10 µm away (a facet's middle), and
    presses it with the grip's stiffness times the rest (the tilt held stiff)."""
    plant = MujocoPegHole(_pair(), Holder(lateral, 1e5))
    at = np.array([0, 0, 0.005, 0, 0.0])
    plant.place(at)
    _move(plant, at, at + np.array([1e-4, 0, 0, 0, 0]), 0.05)
    plant.step(2000)
    force = plant.wrench_on_hole()
    assert force[0] == pytest.approx(lateral * (1e-4 - CLEARANCE), rel=0.05)
    assert abs(force[1]) < 0.01 * force[0] and plant.features()[0] == pytest.approx(
        CLEARANCE, abs=0.5e-6
    )


@pytest.mark.parametrize("friction", [0.15, 0.35])
def test_a_peg_pressed_on_the_wall_sticks_then_slides_at_mu_n(friction: float) -> None:
    plant = MujocoPegHole(_pair(friction), Holder(5e4, 1e5))
    at = np.array([0, 0, 0.005, 0, 0.0])
    plant.place(at)
    pressed = at + np.array([1e-4, 0, 0, 0, 0])
    _move(plant, at, pressed, 0.05)
    plant.step(2000)
    normal = plant.wrench_on_hole()[0]
    depth = plant.features()[2]
    # the hand down by half of what mu N stretches the axial grip: the peg stays
    half = 0.5 * friction * normal / AXIAL
    _move(plant, pressed, pressed + np.array([0, 0, half, 0, 0]), 0.05)
    assert plant.features()[2] - depth < 0.05 * half
    # then 40 µm down at 20 µm/s: it slides, the wall taking mu N along the axis
    stuck = pressed + np.array([0, 0, half, 0, 0])
    sliding = _move(plant, stuck, pressed + np.array([0, 0, 4e-5, 0, 0]), 2.0)
    assert plant.features()[2] - depth > 3e-5
    ratios = [-w[2] / w[0] for w in sliding[len(sliding) // 2 :]]
    assert np.mean(ratios) == pytest.approx(friction, rel=0.10)


def test_the_bottom_stops_the_peg() -> None:
    """The hand 0.5 mm past the bottom: the peg stops there, sunk into the soft contact by
    what about 500 N asks of it (13 µm: one contact point, solimp's 10 µm width), and the
    bottom holds what the axial grip spring pushes."""
    plant = MujocoPegHole(_pair(), Holder(5e4, 30.0))
    start = np.array([0, 0, 0.009, 0, 0.0])
    plant.place(start)
    _move(plant, start, start + np.array([0, 0, 0.0015, 0, 0]), 0.1)
    plant.step(3000)
    depth = plant.features()[2]
    assert 0.010 <= depth < 0.010 + 2e-5
    assert plant.wrench_on_hole()[2] == pytest.approx(-AXIAL * (0.0105 - depth), rel=0.01)


@pytest.mark.parametrize(("chamfer", "enters"), [(0.0, False), (3e-4, True)])
def test_an_offset_peg_stands_on_the_top_face_unless_a_chamfer_leads_it_in(
        chamfer: float, enters: bool) -> None:  # fmt: skip
    """0.2 mm off, 20 times the clearance: without a chamfer the peg lands on the hole's top
    face and is pressed there (0.1 mm past it: 100 N); a 0.3 mm chamfer slides it in."""
    plant = MujocoPegHole(_pair(), Holder(5e4, 30.0), Part(chamfer=chamfer))
    start = np.array([2e-4, 0, -0.001, 0, 0.0])
    plant.place(start)
    down = 0.0011 + (0.0019 if enters else 0.0)
    wrenches = _move(plant, start, start + np.array([0, 0, down, 0, 0]), 0.6)
    depth = plant.features()[2]
    if enters:
        assert depth > 0.0015 and max(abs(w[2]) for w in wrenches) < 30.0
    else:
        # on the top face: 100 N sink the peg 2.0 µm into MuJoCo's soft contact (with the tilt
        # of an off-centre support), a chamfered one goes in by millimetres
        assert abs(depth) < 5e-6
        assert wrenches[-1][2] == pytest.approx(-AXIAL * 0.0001, rel=0.05)


def _off_the_peg(plant: MujocoPegHole) -> float:
    """How far the contact farthest from the peg's surface lies outside it [m]."""
    d, model = plant.data, plant.model
    peg = model.body("peg").id
    rot, tip = d.xmat[peg].reshape(3, 3), d.site_xpos[model.site("tip").id]
    worst = 0.0
    for i in range(d.ncon):
        v = rot.T @ (d.contact[i].pos - tip)  # in the peg's frame, z from the tip up
        radial = math.hypot(v[0], v[1]) - plant.pair.peg_radius
        worst = max(worst, radial, -v[2], v[2] - plant.part.peg_length)
    return worst


@pytest.mark.parametrize(("dx", "tilt", "chamfer"), [
    (1e-4, 0.0, 3e-4), (2e-5, 0.0, 0.0), (0.0, 0.01, 3e-4), (5e-5, 0.005, 3e-4),
    (-1e-4, 0.0, 3e-4)])  # fmt: skip
def test_every_contact_lies_on_the_pegs_surface(dx: float, tilt: float, chamfer: float) -> None:
    """The hand pushed down 2 mm at 5 mm/s from above the hole, off-centre or tilted: every
    contact MuJoCo finds lies within 50 µm of the peg (the convex collider's tolerance at
    its 1 µm default put contacts 5 mm off it, with spikes of 325 N)."""
    pair = PegHole(hole_radius=0.00505, peg_radius=0.00504, hole_depth=0.01,
                   base_thickness=0.005, friction=0.3, stiffness=1.84e8)  # fmt: skip
    plant = MujocoPegHole(pair, Holder(5e4, 30.0), Part(chamfer=chamfer))
    hand = np.array([dx, 0.0, -5e-4, 0.0, tilt])
    plant.place(hand)
    for _ in range(400):
        hand[2] += 5e-6
        plant.set_hand(hand)
        for _ in range(round(1e-3 / plant.dt)):
            plant.step()
            assert _off_the_peg(plant) < 5e-5
