"""The identification against each plant's truth: the probes leave a run as it was, the table
has its rows, and MuJoCo's true slope is the series stiffness of its grip and contact."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.control.compliance import ComplianceParams
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.laws import make_law
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.plants.mujoco_scene import RIGID
from fbcc_ros.core.sim.simulation import simulate
from fbcc_ros.core.sim.state_study import drawn_insertions
from fbcc_ros.studies.identification_on_mujoco import (
    EstimateLog,
    identification_on_plants,
    main,
    markdown,
    run_probed,
    study_scenario,
)


def test_the_probes_leave_a_mujoco_run_as_it_was() -> None:
    sc = study_scenario("mujoco", duration=0.4)
    parts, dev = drawn_insertions(sc, Uncertainty(), sc.geometry.stiffness, 1, seed=0)
    contact, log, probed = run_probed(sc, parts, dev, seed=0, stride=10)
    plain, _ = simulate(sc, "fbcc", initial=dev, geometries=parts, seed=0, record=False)
    np.testing.assert_array_equal(probed.final_features, plain.final_features)
    np.testing.assert_array_equal(probed.peak_fz, plain.peak_fz)
    assert len(contact.truth) == len(log.estimates) == 39  # periods 10, 20, ..., 390


def test_each_plant_is_compared_with_its_own_truth() -> None:
    results = identification_on_plants(trials=1, duration=0.8, noise=(True,))
    assert set(results) == {"model", "mujoco"}
    for r in results.values():
        for row in ("k_offset", "k_tilt"):
            assert r[row]["samples"] > 5 and r[row]["truth"]["median"] > 0.0
        assert r["friction"]["of"] == r["lever"]["of"] == 1
    # MuJoCo's offset row is the grip (1e6 N/m) in series with the contact: no stiffer
    assert results["mujoco"]["k_offset"]["truth"]["p90"] < 1.02 * RIGID.lateral
    # on the model it was designed on, the fit finds the offset rows' slope to a factor of 2
    assert 0.5 < results["model"]["k_offset"]["fit"]["median"] < 2.0
    table = markdown(results)
    assert table.count("| model |") == 2 and table.count("| mujoco |") == 2


def test_only_the_robust_law_has_an_estimate_to_log() -> None:
    sc = study_scenario("model")
    law = make_law("fbcc", sc.geometry, ComplianceParams(), sc.insertion)
    with pytest.raises(ConfigError, match="controller"):
        EstimateLog(law)


@pytest.mark.parametrize(("argv", "said"), [
    (["--trials", "0"], "--trials 0: expected an integer >= 1"),
    (["--seed", "-1"], "--seed -1: expected an integer >= 0"),
    (["--duration", "0"], "--duration 0.0: expected more than 0.1 s")])  # fmt: skip
def test_bad_input_is_refused_naming_it(argv: list[str], said: str,
                                        capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert said in capsys.readouterr().err
