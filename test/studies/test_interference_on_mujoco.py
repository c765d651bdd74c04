"""The interference study: eq. 5-13's push-in force follows the material's k, MuJoCo's follows
its own contact parameters and not k, and a peg pushed from above stands on the top face."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import AXIAL
from fbcc_ros.core.sim.plants.mujoco_scene import Contact, Part
from fbcc_ros.studies.interference_on_mujoco import (
    REFERENCE_K,
    changes_table,
    held,
    interference_pair,
    main,
    model_fz,
    push,
)

CHANGES = (("reference", REFERENCE_K, Contact(), Part()),
           ("k 100 GPa", 1.0e11, Contact(), Part()),
           ("solref 1 ms", REFERENCE_K, Contact(timeconst=1.0e-3), Part()))  # fmt: skip


def test_the_models_force_follows_k_and_mujocos_does_not() -> None:
    reference, stiff, slow = changes_table((0.001,), CHANGES)
    # eq. 13: F_z = mu 2 pi delta l k, in proportion to k
    np.testing.assert_allclose(stiff.model[0] / reference.model[0], 100.0, rtol=1e-9)
    # MuJoCo never sees k: the same forces to the last bit
    assert stiff.mujoco == reference.mujoco
    # ... but its solref moves them: the force of a penetration scales as 1 / timeconst^2
    assert reference.mujoco[0] > 10.0 * slow.mujoco[0] > 0.0
    assert slow.model == reference.model


def test_the_models_force_is_eq_13_and_grows_with_depth() -> None:
    pair = interference_pair(REFERENCE_K)
    for depth in (0.001, 0.003):
        np.testing.assert_allclose(model_fz(pair, depth), pair.push_in_force(depth), rtol=0.02)
    assert model_fz(pair, -1e-4) == 0.0


def test_a_peg_pushed_from_above_stands_on_the_top_face() -> None:
    pair = interference_pair()
    hand, peg, fz = push(pair, -1.0e-4, 4.0e-4)[-1]
    assert peg < 1e-6  # not in: at most a micrometre into the top face
    # the axial force is what the grip's spring holds over the hand's lead, not eq. 13
    np.testing.assert_allclose(fz, AXIAL * (hand - peg), rtol=0.02)
    assert fz > 10.0 * model_fz(pair, hand)


def test_bad_input_is_refused_naming_it(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(ConfigError, match="depth"):
        held(interference_pair(), 0.02)
    with pytest.raises(SystemExit) as exc:
        main(["--travel-mm", "0"])
    assert exc.value.code == 2
    assert "--travel-mm 0.0: expected a length in (0, 5] mm" in capsys.readouterr().err
