"""The estimators scored on each plant's truth: one insertion per plant, scored in the hole."""

from __future__ import annotations

import pytest

from fbcc_ros.studies.estimators_on_mujoco import METHODS, estimators_on_plants, main


def test_each_plant_scores_the_estimators_on_its_own_truth() -> None:
    results = estimators_on_plants(trials=1)
    assert set(results) == {"model", "mujoco"}
    for r in results.values():
        for method in METHODS:
            assert r[method]["samples"] > 100 and 0.0 <= r[method]["accuracy"] <= 1.0
    # on the model it was designed on, the estimator's history names more states right than
    # one response; on MuJoCo's wedged insertion (docs/plant.md) than the boundary mapping only
    model, mujoco = results["model"], results["mujoco"]
    assert model["estimator, history"]["accuracy"] > model["estimator, one response"]["accuracy"]
    assert mujoco["estimator, history"]["accuracy"] > mujoco["boundary mapping"]["accuracy"]


@pytest.mark.parametrize(("argv", "said"), [
    (["--trials", "0"], "--trials 0: expected an integer >= 1"),
    (["--seed", "-1"], "--seed -1: expected an integer >= 0")])  # fmt: skip
def test_bad_input_is_refused_naming_it(argv: list[str], said: str,
                                        capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert said in capsys.readouterr().err
