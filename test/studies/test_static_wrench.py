"""The static-wrench study: its poses cover the nine states of both planes, a rigidly held peg
on the model sits in the state its pose names, and MuJoCo's wall pushes back against the
offset."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.contact.segmentation import SIGNS, STATES
from fbcc_ros.core.paper import paper_pair
from fbcc_ros.studies import static_wrench
from fbcc_ros.studies.static_wrench import PLANES, Poses, wrench_table

PAIR = paper_pair("clearance")
ONE_POINT = Poses(tilt=0.002)  # a tilt that alone does not reach the wall at 3 mm


def test_the_poses_cover_the_nine_states_of_both_planes() -> None:
    names, hands = Poses().hands(PAIR)
    assert names == [(plane, state) for plane in PLANES for state in STATES]
    for (plane, state), hand in zip(names, hands, strict=True):
        d, t = SIGNS[STATES.index(state)]
        lateral, tilt, other = ((hand[0], hand[4], hand[[1, 3]]) if plane == "XOZ"
                                else (hand[1], hand[3], hand[[0, 4]]))  # fmt: skip
        assert np.sign(lateral) == d and np.sign(tilt) == t and not other.any()
        assert hand[2] == Poses().depth


def test_on_the_model_a_rigidly_held_peg_sits_in_the_state_its_pose_names(
        monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    monkeypatch.setattr(static_wrench, "PLANT_NAMES", ("model",))
    rows = wrench_table(PAIR, None, ONE_POINT)
    assert len(rows) == 18
    for row in rows:
        d, _ = SIGNS[STATES.index(row.state)]
        expected = "P0" if d == 0 else row.state  # a tilt alone leaves a clearance
        assert row.feature_state == expected


def test_on_mujoco_the_wall_pushes_back_against_the_offset(
        monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    monkeypatch.setattr(static_wrench, "PLANT_NAMES", ("mujoco",))
    for row in wrench_table(PAIR, None, ONE_POINT):
        d, _ = SIGNS[STATES.index(row.state)]
        lateral = row.response[0 if row.plane == "XOZ" else 1]
        if d == 0:
            assert abs(lateral) < 1e-6
        else:
            assert np.sign(lateral) == d and abs(lateral) > 0.5
