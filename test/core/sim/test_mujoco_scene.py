"""The MuJoCo peg-in-hole scene against physics: a free insertion meets no force, a peg pushed
into the wall reads the grip's stiffness times its deflection, sliding begins and goes on at
mu N, the bottom and the top face stop the peg, a chamfer leads an offset peg in; pruning the
hole's boxes from the collision changes nothing."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import AXIAL, Holder
from fbcc_ros.core.sim.plants.mujoco_scene import (
    Contact,
    MujocoPegHole,
    Part,
    scene_xml,
    shape_error,
)
from fbcc_ros.core.sim.plants.pruning import PRUNE_MOVE

R, CLEARANCE = 0.00501, 1.0e-5


def _pair(friction: float = 0.15, depth: float = 0.01, chamfer: float = 0.0) -> PegHole:
    return PegHole(hole_radius=R, peg_radius=R - CLEARANCE, hole_depth=depth,
                   base_thickness=0.005, friction=friction, stiffness=1e11,
                   rim=chamfer > 0, chamfer=chamfer)  # fmt: skip


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
    assert scene_xml(_pair(chamfer=3e-4)).count('class="hole"/>') == 2 * 128 + 1


def test_bad_scene_parameters_are_refused() -> None:
    with pytest.raises(ConfigError, match="timeconst"):
        Contact(timeconst=1e-4, timestep=1e-4)
    with pytest.raises(ConfigError, match="timestep"):
        Contact(timeconst=1e-3, timestep=2e-4)  # past MAX_TIMESTEP, the armature's
    with pytest.raises(ConfigError, match="facets"):
        Part(facets=8)
    with pytest.raises(ConfigError, match="chamfer"):  # the pair's, wider than the face
        scene_xml(_pair(chamfer=0.006), part=Part(face_width=0.005))


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
    plant = MujocoPegHole(_pair(chamfer=chamfer), Holder(5e4, 30.0))
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
                   base_thickness=0.005, friction=0.3, stiffness=1.84e8, rim=chamfer > 0,
                   chamfer=chamfer)  # fmt: skip
    plant = MujocoPegHole(pair, Holder(5e4, 30.0))
    hand = np.array([dx, 0.0, -5e-4, 0.0, tilt])
    plant.place(hand)
    for _ in range(400):
        hand[2] += 5e-6
        plant.set_hand(hand)
        for _ in range(round(1e-3 / plant.dt)):
            plant.step()
            assert _off_the_peg(plant) < 5e-5


@pytest.mark.parametrize(("start", "down", "chamfer"), [
    ((1e-4, 0, -1e-4, 0, 0), 2e-4, 0.0),  # 0.1 mm off: onto the top face, pressed 0.1 mm
    ((1e-4, 0, -1e-4, 0, 0), 1.6e-3, 3e-4),  # 0.1 mm off: led in, pressed on the wall
    ((0, 1e-4, -1e-4, -0.01, 0), 1.6e-3, 3e-4),  # and tilted 0.57°
    ((0, 0, -1e-4, 0, 0.0175), 2.6e-3, 0.0)])  # tilted 1°: jammed, two-point contact
def test_pruning_the_hole_changes_nothing(start: tuple[float, ...], down: float, chamfer: float,
                                          monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """The hand pushed down from above the hole: the scene that collides the peg only with the
    boxes it can touch (the default) and the one that collides it with all give bitwise the
    same features and wrench on the hole every millisecond, and the same final state; the
    first kept under half of the boxes on the average step in contact (the peg's tip on the
    top face touches nearly half of the facets)."""
    calls: list[tuple[int, int]] = []  # as each timestep starts: (boxes in, last contacts)
    step = mujoco.mj_step

    def counted(m: mujoco.MjModel, d: mujoco.MjData, nstep: int = 1) -> None:
        calls.append((int(np.count_nonzero(m.geom_contype)) - 2, d.ncon))  # less peg, bottom
        step(m, d, nstep)

    monkeypatch.setattr(mujoco, "mj_step", counted)
    runs = []
    for prune in (False, True):
        calls.clear()
        plant = MujocoPegHole(_pair(chamfer=chamfer), Holder(5e4, 30.0), prune=prune)
        hand = np.array(start)
        plant.place(hand)
        n = 200
        trace = []
        for k in range(1, n + 1):
            plant.set_hand(hand + np.array([0, 0, down * k / n, 0, 0]))
            plant.step(20)
            trace.append(np.concatenate([plant.features(), plant.wrench_on_hole()]))
        runs.append((np.array(trace), plant.data.qpos.copy(), plant.data.qvel.copy()))
    for full, pruned in zip(*runs, strict=True):
        np.testing.assert_array_equal(pruned, full)
    assert max(abs(runs[0][0][:, 5:8]).max(axis=0)) > 1.0  # it did touch
    boxes = len(plant._pruning._contype)
    enabled = np.array([e for e, ncon in calls if ncon > 0])
    assert len(enabled) > n and np.mean(enabled) < boxes / 2


def test_no_box_the_pruning_takes_out_touches_the_peg() -> None:
    """Poses in and over the bore, up to 0.3 mm off-centre and 1° tilted, each also moved by
    what the pruning allows (towards the wall, up or down): MuJoCo's collision, all boxes in,
    finds no contact with a box :meth:`FacetPruning.prune` took out at the pose, and it takes
    out most. (mj_geomDistance is no judge: it returned 0 for a box 0.2 mm from the peg.)"""
    rng = np.random.default_rng(3)
    plant = MujocoPegHole(_pair(chamfer=3e-4))
    m, d, pruning = plant.model, plant.data, plant._pruning
    peg, first, move_xy, move_z = m.geom("peg").id, min(plant._hole_geoms), *PRUNE_MOVE
    out = 0
    for _ in range(200):
        dx, dy = rng.uniform(-3e-4, 3e-4, 2)
        tilt_x, tilt_y = rng.uniform(-0.0175, 0.0175, 2)
        plant.place(np.array([dx, dy, rng.uniform(-5e-4, 3e-3), tilt_x, tilt_y]))
        q = d.qpos.copy()
        assert pruning.prune(*q[:5].tolist())
        kept = pruning._contype.copy()
        out += int(np.count_nonzero(kept == 0))
        pruning.restore()
        wall = np.array([dx, dy]) / math.hypot(dx, dy)
        for lateral, up in ((0.0, 0.0), (1.0, 1.0), (1.0, -1.0)):
            d.qpos[:3] = q[:3] + 0.99 * np.array([*(lateral * move_xy * wall), up * move_z])
            mujoco.mj_fwdPosition(m, d)
            for con in d.contact[: d.ncon]:
                box = int(con.geom1 if con.geom2 == peg else con.geom2) - first
                assert box >= len(kept) or kept[box], (q, box)
    assert out > 0.5 * 200 * len(pruning._contype)


def test_the_period_wrench_is_the_mean_of_the_contacts_wrench_over_its_timesteps() -> None:
    """From the grip's joint forces: over one timestep, the contacts' sum of that timestep;
    over 20, the mean of theirs (what a sensor reads of a soft contact at rest on the wall,
    which lets go for a timestep now and then)."""
    pair = PegHole(hole_radius=0.00505, peg_radius=0.00504, hole_depth=0.01,
                   base_thickness=0.005, friction=0.3, stiffness=1.84e8, rim=True,
                   chamfer=3e-4)  # fmt: skip
    plant = MujocoPegHole(pair, Holder(5e4, 30.0))
    hand = np.array([1e-4, 0.0, -5e-4, 0.0, 0.01])
    plant.place(hand)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    saved = np.empty(mujoco.mj_stateSize(plant.model, spec))
    for _ in range(150):
        hand[2] += 1e-5
        plant.set_hand(hand)
        mujoco.mj_getState(plant.model, plant.data, saved, spec)
        plant.step(20)
        mean = plant.mean_wrench_on_hole()
        mujoco.mj_setState(plant.model, plant.data, saved, spec)
        summed = np.zeros(6)
        for _ in range(20):
            plant.step(1)
            one = plant.wrench_on_hole()
            np.testing.assert_allclose(plant.mean_wrench_on_hole(), one,
                                       atol=1e-6 * max(1.0, abs(one).max()))  # fmt: skip
            summed += one
        # the moments about the grip point where it is at the period's end (microns away):
        # within 1e-5 N·m, a two-hundredth of a 6-axis sensor's noise
        np.testing.assert_allclose(mean[:3], summed[:3] / 20, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(mean[3:], summed[3:] / 20, rtol=0.0, atol=1e-5)
    assert abs(mean[0]) > 0.1  # it pressed
