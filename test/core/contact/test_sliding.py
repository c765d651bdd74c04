"""The wall's friction against the peg's own sliding where the hole block is solid (the rim):
eq. 11-13 when the peg is pushed straight in, reversed when it is pulled out, none at rest, and
dissipative whatever the motion (a turn in two-point contact is rubbed, not free); and so in
the model plant, whose holder solves the law on the peg's own motion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.contact.features import axis_and_tip
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.sliding import SLIDE_EPS, peg_velocity
from fbcc_ros.core.errors import InputError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.model import ModelContact

DEG = math.pi / 180
PAIR = PegHole(5.05e-3, 5.04e-3, 0.01, 0.005, 0.3, 1e11, rim=True)
#: In the bore, in contact: aligned against +x, and tilted 2° in two-point contact.
POSES = ([5e-5, 0.0, 5e-3, 0.0, 0.0], [1e-4, 0.0, 5e-3, 0.0, 2 * DEG])


@pytest.mark.parametrize("acting_point", ["hole_bottom", "peg_top"])
@pytest.mark.parametrize("pose", POSES)
def test_pushed_straight_in_the_wall_rubs_as_eq_11_to_13(pose: list[float],
                                                         acting_point: str) -> None:  # fmt: skip
    pair = PAIR.replace(acting_point=acting_point, peg_length=0.05)
    paper = pair.replace(rim=False)
    pushed = pair.response(pose, slide=[0.0, 0.0, -5e-3])
    np.testing.assert_allclose(pushed, paper.response(pose), rtol=1e-9, atol=1e-9)
    assert pushed[2] > 100.0  # Fz: the axial friction drags the hole down
    # pulled out, the wall holds the peg back: the friction reverses
    pulled = pair.response(pose, slide=[0.0, 0.0, 5e-3])
    assert pulled[2] == pytest.approx(-pushed[2], rel=1e-12)
    # at rest it carries nothing; below SLIDE_EPS it fades with the speed
    assert pair.response(pose)[2] == 0.0
    creep = pair.response(pose, slide=[0.0, 0.0, -0.1 * SLIDE_EPS])
    assert creep[2] == pytest.approx(0.1 * pushed[2], rel=1e-9)


def _friction_power(pose: list[float], slide: np.ndarray) -> float:
    """The power of the wall's friction on the peg [W] (<= 0: it dissipates), from the wrench on
    the hole about the hole bottom's centre."""
    w = PAIR.response(pose, slide=slide) - PAIR.response(pose)
    force = np.array([w[0], w[1], -w[2]])  # on the hole; Fz > 0 drags it along -z
    moment = np.array([w[3], w[4], 0.0])  # the peg does not spin: Mz does no work
    *_, px, py, pz = axis_and_tip(*pose, PAIR.peg_radius)
    omega = np.array([slide[3], slide[4], 0.0])
    g = np.array([0.0, 0.0, -(PAIR.hole_depth + PAIR.base_thickness)])
    v_g = slide[:3] + np.cross(omega, g - np.array([px, py, pz]))
    return float(-(force @ v_g + moment @ omega))


def test_the_friction_dissipates_whatever_the_motion() -> None:
    rng = np.random.default_rng(7)
    for pose in POSES:
        for _ in range(20):
            slide = np.concatenate([rng.normal(0, 3e-3, 3), rng.normal(0, 0.05, 2)])
            assert _friction_power(pose, slide) < 0.0
    # a peg turned in two-point contact about its tip, without moving it, is rubbed
    assert _friction_power(POSES[1], np.array([0.0, 0.0, 0.0, 0.0, -0.05])) < -1e-3


def test_the_velocity_of_a_moved_peg() -> None:
    before = np.array([[1e-4, 0.0, 5e-3, 0.0, 2 * DEG]])
    now = before + np.array([[0.0, 0.0, 5e-6, 0.0, 1e-4]])  # 5 µm deeper, turned 1e-4 rad about y
    v = np.empty((1, 5))
    peg_velocity(now, before, np.array([PAIR.peg_radius]), 1e3, v)
    assert v[0, 4] == pytest.approx(0.1, rel=1e-3)  # 1e-4 rad in 1 ms
    assert abs(v[0, 3]) < 1e-12
    # the tip centre, at depth l cos(θ) - r sin(θ), goes down by the 5 µm less what the turn
    # lifts it: (l sin(θ) + r cos(θ)) 1e-4
    l, tilt, r = 5e-3, 2 * DEG, PAIR.peg_radius
    down = 5e-6 * math.cos(tilt) - (l * math.sin(tilt) + r * math.cos(tilt)) * 1e-4
    assert v[0, 2] == pytest.approx(-down * 1e3, rel=1e-3)


def test_a_velocity_of_the_wrong_shape_is_refused() -> None:
    with pytest.raises(InputError, match="slide"):
        PAIR.response(POSES[0], slide=[0.0, 0.0, 1.0, 0.0])
    with pytest.raises(InputError, match="slide"):
        PAIR.response(POSES[0], slide=[0.0, 0.0, math.nan])


def test_in_the_model_plant_the_bore_rubs_against_the_pegs_own_motion() -> None:
    """A peg pressed sideways against the bore by its grip, moved along the axis by the hand:
    pushed in, the wall drags the hole down with μ times its push; pulled out, it holds the peg
    back as hard (eq. 11 would still push it down); stopped, the peg stays put."""
    grip = Holder(5e4, 30.0)
    dt = 1e-3
    plant = ModelContact(1, [PAIR], grip, dt)
    offset = (PAIR.hole_radius - PAIR.peg_radius) + 10.0 / grip.lateral  # 10 N of its spring
    hand = np.array([[offset, 0.0, 3e-3, 0.0, 0.0]])

    def move(speed: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
        for _ in range(steps):
            hand[0, 2] += speed * dt
            features, wrench = plant.touch(hand)
        return features[0], wrench[0]

    _, pushed = move(5e-3, 100)
    rubbing = PAIR.friction * abs(pushed[0])  # one-point contact: |Fx| is the whole push
    assert abs(pushed[0]) > 1.0
    assert pushed[2] == pytest.approx(rubbing, rel=0.05)
    _, pulled = move(-5e-3, 100)
    assert pulled[2] == pytest.approx(-PAIR.friction * abs(pulled[0]), rel=0.05)
    before, _ = move(0.0, 1)
    after, held = move(0.0, 50)
    assert abs(after[2] - before[2]) < 1e-6  # a micron in 50 ms: it sticks
    assert abs(held[2]) < rubbing
