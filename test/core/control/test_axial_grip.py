"""The grip's axial compression (``RobustParams.axial_stiffness``): the law reads the arm's depth,
and a push of F_z compresses what holds the peg by F_z / k, so a press fit driven to the arm's
depth ends short of it. Told the grip's stiffness, the law takes the arm that much deeper."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest

from fbcc_ros.core.control.robust_params import RobustParams
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario
from fbcc_ros.core.sim.holder import AXIAL
from fbcc_ros.core.sim.simulation import simulate

ROOT = Path(__file__).resolve().parents[3]


def _press_fit(axial_stiffness: float) -> dict[str, Any]:
    """The rim study's press fit (10 µm interference, a 0.3 mm chamfer, the hole's bottom at the
    depth), stiffer and rougher than the file's pair, in the simulator's grip (axial AXIAL)."""
    sc = scenario.load(ROOT / "config/scenarios/rim_interference.yaml")
    part = dataclasses.replace(sc.geometry, stiffness=5.3e8, friction=0.45)
    sc = dataclasses.replace(sc, geometry=part,
                             params=RobustParams(axial_stiffness=axial_stiffness))  # fmt: skip
    assert sc.holder is not None and sc.holder.axial == AXIAL
    outcome, _ = simulate(sc, "fbcc", record=False)
    return outcome.summary(0)  # type: ignore[no-any-return]


def test_told_the_grips_axial_stiffness_a_press_fit_reaches_the_depth() -> None:
    """Rigid (0, the default), the arm stops at the depth and the part, held by its fit, ends
    short by about F_z / k (143 N: tens of microns); told the grip (AXIAL), it is assembled as
    the arm arrives; told twice the grip's stiffness, it arrives short and is assembled no
    sooner (the model's fit lets it creep in)."""
    depth = scenario.load(ROOT / "config/scenarios/rim_interference.yaml").insertion.depth
    rigid, told, stiffer = (_press_fit(k) for k in (0.0, AXIAL, 2 * AXIAL))
    assert not rigid["success"], rigid
    assert depth - rigid["final_features"]["l"] > 3e-5, rigid
    assert told["success"] and not told["stop_reason"], told
    assert stiffer["insertion_time"] is None or stiffer["insertion_time"] > told["insertion_time"]


@pytest.mark.parametrize("share", [0.5, 0.25])
def test_a_grip_stated_too_soft_stops_on_the_bottom(share: float) -> None:
    """Told a fraction of the grip's stiffness, the law believes the peg short when it already
    sits on the hole's bottom, and would push on until fz_back_off; the peg it believes then
    falls back, and the arm stops: a few newtons over the run told the grip."""
    told, soft = _press_fit(AXIAL), _press_fit(AXIAL * share)
    assert soft["success"] and not soft["force_limited"], soft
    assert soft["peak_fz"] < told["peak_fz"] + 20.0, (soft["peak_fz"], told["peak_fz"])


@pytest.mark.parametrize("value", [-1.0, float("inf"), float("nan"), True])
def test_a_bad_axial_stiffness_is_refused_with_its_value(value: Any) -> None:
    with pytest.raises(ConfigError, match="axial_stiffness"):
        RobustParams(axial_stiffness=value)
