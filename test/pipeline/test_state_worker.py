"""The contact state online (fbcc_ros.pipeline.state_worker): the filter in its child process
answers every sample it is handed with what the deviation filter along the same insertion
gives offline, starts again on a new insertion, and stops when closed."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.control.deviation_filter import UNKNOWN_STIFFNESS, along
from fbcc_ros.core.control.state_feed import FeedSample, StateFeed
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.simulation import simulate
from fbcc_ros.pipeline.state_worker import StateWorker

EVERY = 5


@pytest.fixture(scope="module")
def insertion() -> tuple[object, np.ndarray, np.ndarray]:
    """The first 0.4 s of a robust interference insertion: measured features and responses."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_interference.yaml"))
    _, traj = simulate(sc, "fbcc", seed=0)
    assert traj is not None
    return sc.geometry, traj.pose[:400, 0].copy(), traj.measured[:400, 0].copy()


@pytest.mark.parametrize("stiffness", [None, UNKNOWN_STIFFNESS])
def test_the_worker_answers_as_the_filter_along_the_insertion(insertion, stiffness) -> None:
    """With the nominal k, and with a range of k for a part whose k nobody knows."""
    nominal, features, responses = insertion
    options = {} if stiffness is None else {"stiffness": stiffness}
    rows, expected = along(features, responses, nominal, EVERY, **options)
    assert len(rows) > 20
    if stiffness is not None:  # the range matters: the answers are not the nominal k's
        assert not np.array_equal(expected, along(features, responses, nominal, EVERY)[1])
    worker, feed = StateWorker(nominal, stiffness), StateFeed(EVERY)

    def insert() -> None:
        worker.start_insertion()
        feed.start_insertion()
        for k in range(len(features)):
            if (sample := feed.take(features[k], responses[k])) is not None:
                worker.put(float(k), sample)

    try:
        insert()
        assert worker.sent == feed.sent == len(rows)
        got = worker.drain(timeout=60.0)  # all of them, the backlog waited for
        assert [stamp for stamp, _ in got] == [float(k) for k in rows]
        np.testing.assert_array_equal(np.array([p for _, p in got]), expected)
        assert worker.behind == 0 and worker.ready
        # a new insertion starts a new filter: the same samples give the same answers
        insert()
        again = worker.drain(timeout=60.0)
        np.testing.assert_array_equal(np.array([p for _, p in again]), expected)
    finally:
        worker.close()
    assert not worker.alive


def test_a_dead_child_drops_the_samples_and_never_blocks_the_loop(insertion) -> None:
    nominal, features, responses = insertion
    worker = StateWorker(nominal)
    try:
        worker._process.kill()
        worker._process.wait()
        worker.start_insertion()
        for k in range(2000):  # far more than a pipe holds
            worker.put(float(k), FeedSample(responses[k % 400], features[k % 400][None]))
        assert worker.sent == 0 and worker.dropped == 2000
        assert worker.answers() == [] and not worker.alive
    finally:
        worker.close()
