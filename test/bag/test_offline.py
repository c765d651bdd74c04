"""Offline replay: the committed bag's raw wrenches and joint states through the compensation,
kinematics and controller core reproduce the commands the cell recorded (a regression test:
``test/data/make_bags.py`` makes the bag)."""

from __future__ import annotations

import dataclasses
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml

from fbcc_ros.bag.offline import node_parameters, replay_offline
from fbcc_ros.bag.reader import read_bag
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.nodes.fbcc_replay import TOLERANCE

BAG = Path(__file__).resolve().parents[1] / "data" / "bags" / "short_interference"


@pytest.fixture(scope="module")
def bag():
    return read_bag(BAG)


def _without(bag, topic: str):
    """The bag as if ``topic`` had not been recorded (a copy: the module's bag is shared)."""
    messages = [m for m in bag.messages if m.topic != topic]
    return dataclasses.replace(bag, messages=messages, counts=Counter(m.topic for m in messages))


def test_the_recorded_commands_are_reproduced_within_the_tolerance(bag) -> None:
    result = replay_offline(bag, node_parameters(BAG))
    # every recorded command answered, none invented, nothing the live nodes dropped ignored
    assert result.counts["stepped"] == bag.counts["/fbcc/command"] > 500, result.counts
    assert np.isfinite(result.recorded).all()
    assert result.counts["bias"] == "recorded"
    assert (result.max_error() <= TOLERANCE).all(), result.max_error()
    assert result.phase == "inserted"
    # the run moved: the check is not one of a command that stood still
    assert np.ptp(result.commands[:, 2]) > 1e-3


def test_another_law_or_gain_gives_other_commands(bag) -> None:
    """What offline replay is for: the same session under other parameters. That the commands
    then differ also shows the regression check above can fail."""
    given = node_parameters(BAG)
    admittance = {**given, "fbcc_controller": {**given["fbcc_controller"], "law": "admittance"}}
    assert (replay_offline(bag, admittance).max_error() > 1e-6).any()


def test_without_the_recorded_bias_the_tare_is_redone_from_the_bag(bag) -> None:
    recorded = replay_offline(bag, node_parameters(BAG))
    result = replay_offline(_without(bag, "/ft_sensor/bias"), node_parameters(BAG))
    assert result.counts["bias"] == "retared" and result.counts["tare_in_bag"] == 200
    # the same 200 readings as the live tare, or a near miss when it missed some under load:
    # a missed reading moves the mean by about its noise / 200 (a tare under load would be off
    # by newtons)
    retared, live = (np.array(r.counts["bias_used"]) for r in (result, recorded))
    np.testing.assert_allclose(retared[:3], live[:3], atol=5e-3)  # [N]
    np.testing.assert_allclose(retared[3:], live[3:], atol=5e-4)  # [N·m]
    if np.array_equal(retared, live):  # the live tare missed none: the very same commands
        assert (result.max_error() <= TOLERANCE).all(), result.max_error()


def test_a_bag_without_the_raw_wrench_is_refused_by_name(bag) -> None:
    with pytest.raises(InputError, match="/ft_sensor/raw"):
        replay_offline(_without(bag, "/ft_sensor/raw"), node_parameters(BAG))


def test_parameter_files_are_checked_as_the_nodes_check_them(bag, tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"fbcc_controller": {"ros__parameters": {"lawz": "fbcc"}}}))
    with pytest.raises(ConfigError, match="lawz"):
        replay_offline(bag, node_parameters(BAG, [bad]))
    bad.write_text(yaml.safe_dump({"fbcc_controller": {"ros__parameters": {"rate_hz": 0.5}}}))
    with pytest.raises(ConfigError, match="rate_hz"):
        replay_offline(bag, node_parameters(BAG, [bad]))
    bad.write_text("a: [unclosed")
    with pytest.raises(ConfigError, match=r"bad\.yaml"):
        node_parameters(BAG, [bad])


def _under(bag, namespace: str):
    """The bag as if its cell had run in ``namespace`` (every topic moved under it)."""
    messages = [dataclasses.replace(m, topic=namespace + m.topic) for m in bag.messages]
    return dataclasses.replace(bag, messages=messages,
                               topics={namespace + t: k for t, k in bag.topics.items()},
                               counts=Counter(m.topic for m in messages))  # fmt: skip


def test_a_cell_recorded_in_a_namespace_is_replayed_under_it(bag) -> None:
    """The namespace is that of the bag's one joint_states, or the one given; two cells in one
    bag need it given, and a namespace the bag lacks is named."""
    moved = _under(bag, "/lbr")
    result = replay_offline(moved, node_parameters(BAG))
    assert result.counts["stepped"] == bag.counts["/fbcc/command"]
    assert (result.max_error() <= TOLERANCE).all(), result.max_error()
    both = dataclasses.replace(moved, messages=moved.messages + bag.messages,
                               topics={**moved.topics, **bag.topics},
                               counts=moved.counts + bag.counts)  # fmt: skip
    with pytest.raises(InputError, match=r"not \['/joint_states', '/lbr/joint_states'\]"):
        replay_offline(both, node_parameters(BAG))
    chosen = replay_offline(both, node_parameters(BAG), namespace="lbr")
    assert (chosen.max_error() <= TOLERANCE).all() and chosen.counts["stepped"] > 500
    with pytest.raises(InputError, match="/arm/joint_states"):
        replay_offline(moved, node_parameters(BAG), namespace="/arm")
