"""The controller stage takes its law and rate from its scenario unless told otherwise."""

from __future__ import annotations

from pathlib import Path

import yaml

from fbcc_ros.core.control.laws import AdmittanceController, FbccController
from fbcc_ros.pipeline import controller
from fbcc_ros.pipeline.parameters import resolve

ROOT = Path(__file__).resolve().parents[2]


def test_law_and_rate_default_to_the_scenarios(tmp_path: Path) -> None:
    data = yaml.safe_load((ROOT / "config/scenarios/fig9_clearance.yaml").read_text())
    data["controller"]["type"] = ["admittance", "fbcc"]
    data["rate_hz"] = 500
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))

    def stage(**given: object) -> controller.ControllerStage:
        return controller.ControllerStage(
            resolve("fbcc_controller", controller.TABLE, {"scenario": str(path), **given}))

    default = stage()
    assert isinstance(default.sup.law, AdmittanceController) and default.sup.dt == 1 / 500
    chosen = stage(law="fbcc", rate_hz=1000.0)
    assert isinstance(chosen.sup.law, FbccController) and chosen.sup.dt == 1 / 1000
