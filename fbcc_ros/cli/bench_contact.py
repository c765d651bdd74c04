"""``fbcc-bench``'s figures for the contact-state estimators (issue "know the contact"): what
each costs per 1 kHz sample along a simulated insertion, against the 100 µs a sample the
estimator may take."""

from __future__ import annotations

import time

import numpy as np

from fbcc_ros.core.control.contact_state import ContactStateEstimator
from fbcc_ros.core.control.deviation_filter import DeviationFilter
from fbcc_ros.core.control.state_feed import StateFeed
from fbcc_ros.core.paper import paper_scenario
from fbcc_ros.core.sim.scenario import Scenario, validate
from fbcc_ros.core.sim.simulation import Trajectory, simulate

#: The estimator's budget per 1 kHz sample [µs].
STATE_BUDGET_US = 100.0
#: The deviation filter updates at every this many samples (200 Hz at 1 kHz, as the study and
#: ``fbcc-report`` run it).
FILTER_EVERY = 5


def paper_assembly() -> tuple[Scenario, Trajectory]:
    """The paper's interference assembly, simulated once for the benchmarks that replay its
    samples."""
    sc = validate(paper_scenario("interference"))
    _, trajectory = simulate(sc, "fbcc", record=True)
    assert trajectory is not None  # record=True
    return sc, trajectory


def bench_contact_state(sc: Scenario, trajectory: Trajectory, steps: int
                        ) -> dict[str, tuple[float, float]]:  # fmt: skip
    """Per 1 kHz sample [µs], (median, p99) for one response's posterior, and (mean, p99 of
    one update) for the deviation filter updated every FILTER_EVERY samples, along the first
    ``steps`` samples of an assembly (:func:`paper_assembly`)."""
    measured = trajectory.measured[:steps, 0, :]
    pose = trajectory.pose[:steps, 0, :]
    estimator = ContactStateEstimator(sc.geometry)
    estimator.probabilities(measured[:1], pose[:1, 2])  # compiled before timing
    one = []
    for k in range(len(measured)):
        t0 = time.perf_counter()
        estimator.probabilities(measured[k : k + 1], pose[k : k + 1, 2])
        one.append(time.perf_counter() - t0)
    history = DeviationFilter(sc.geometry)
    updates = []
    for sample in StateFeed(FILTER_EVERY).samples(pose, measured)[1]:
        t0 = time.perf_counter()
        history.update(*sample)
        updates.append(time.perf_counter() - t0)
    return {
        "one response": (float(np.median(one)) * 1e6, float(np.percentile(one, 99)) * 1e6),
        f"deviation filter, an update per {FILTER_EVERY}": (
            float(np.sum(updates)) / len(measured) * 1e6,
            float(np.percentile(updates, 99)) * 1e6),
        "online, the loop's share": _online(sc, measured, pose),
    }


def _online(sc: Scenario, measured: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    """What the controller's loop pays for the online filter per 1 kHz sample [µs]: the feed's
    choice and the write to the filter's process (:mod:`fbcc_ros.pipeline.state_worker`),
    (mean, p99); the filter's own work is in its process."""
    from fbcc_ros.pipeline.state_worker import StateWorker

    worker, feed = StateWorker(sc.geometry), StateFeed(FILTER_EVERY)
    try:
        worker.start_insertion()
        costs = []
        for k in range(len(measured)):
            t0 = time.perf_counter()
            if (sample := feed.take(pose[k], measured[k])) is not None:
                worker.put(float(k), sample)
            costs.append(time.perf_counter() - t0)
    finally:
        worker.close()
    return float(np.mean(costs)) * 1e6, float(np.percentile(costs, 99)) * 1e6
