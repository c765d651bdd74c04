"""The peg on the rim on both plants (fbcc_ros/studies/rim_wrench.py): what a real part does
there, on the model with its rim and on MuJoCo alike."""

from __future__ import annotations

import pytest

from fbcc_ros.studies import rim_wrench as rw

BY_NAME = {c.name: c for c in rw.CASES}


@pytest.mark.parametrize("plant", rw.PLANT_NAMES)
def test_a_peg_off_by_more_than_the_clearance_stands_on_the_face(plant: str) -> None:
    s = rw.settle(plant, BY_NAME["face, 0.3 mm off"])
    assert s.features[2] < 10e-6  # microns into the face, not in the bore
    # pressed by the grip's axial spring about as hard as when the hand stopped (it rocks a
    # little toward the hole meanwhile)
    assert 0.8 * rw.Descent().push < s.response[2] < 1.5 * rw.Descent().push
    # held up on the crescent toward the peg's side of the hole: My = x Fz with 0 < x < r
    assert 0.0 < s.response[4] / s.response[2] < rw.PAIR.peg_radius


@pytest.mark.parametrize("plant", rw.PLANT_NAMES)
def test_the_chamfer_guides_a_peg_off_by_less_than_its_width_into_the_bore(plant: str) -> None:
    s = rw.settle(plant, BY_NAME["chamfer, 0.2 mm off"])
    clearance = rw.PAIR.hole_radius - rw.PAIR.peg_radius
    assert s.features[2] > 1e-3  # in the bore, past the 0.3 mm chamfer
    # the tip against the wall on the side it came from, tilted in its grip
    assert 0.0 < s.features[0] < 2 * clearance


def test_the_plants_agree_where_the_chamfer_guides_the_peg() -> None:
    model, mujoco = (rw.settle(p, BY_NAME["chamfer, 0.2 mm off"]) for p in rw.PLANT_NAMES)
    assert model.features[0] == pytest.approx(mujoco.features[0], abs=1e-6)
    assert model.features[4] == pytest.approx(mujoco.features[4], rel=0.05)
    assert model.response[0] == pytest.approx(mujoco.response[0], rel=0.1)


@pytest.mark.parametrize("plant", rw.PLANT_NAMES)
def test_a_peg_leaning_toward_the_hole_sinks_its_low_corner_into_it(plant: str) -> None:
    s = rw.settle(plant, BY_NAME["tilted 2° toward, 0.3 mm off"])
    # the corner 0.3 mm off reaches the bore; the end face then meets the edge about
    # (r + offset - R) tan(2°) ... 2 r tan(2°) lower: 0.1-0.35 mm
    assert 0.1e-3 < s.features[2] < 0.35e-3
