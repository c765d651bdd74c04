"""Running independent tasks here, on a local pool and on a Dask cluster
(fbcc_ros.core.sim.parallel): the same results in the same order every way, progress reports, and
clear errors."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator

import numpy as np
import pytest

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.parallel import run_tasks

#: Task i: (seed, draws, delay). The first tasks are the slowest, so that with two workers they
#: finish after later ones and a result placed by completion order would be caught.
TASKS = [(1000 + i, 5 + i, 0.02 * (8 - i)) for i in range(8)]


def draw(seed: int, n: int, delay: float) -> tuple[int, np.ndarray]:
    """A task: its process id and n normal draws from its own seed."""
    time.sleep(delay)
    return os.getpid(), np.random.default_rng(seed).standard_normal(n)


def fail(x: int) -> int:
    if x == 3:
        raise RuntimeError(f"task {x} failed")
    return x


def expected() -> list[np.ndarray]:
    return [np.random.default_rng(seed).standard_normal(n) for seed, n, _ in TASKS]


def check(results: list[tuple[int, np.ndarray]]) -> set[int]:
    """The draws equal, bit for bit and in input order, those made here; returns the pids."""
    assert len(results) == len(TASKS)
    for (_, got), want in zip(results, expected(), strict=True):
        assert got.dtype == want.dtype
        assert np.array_equal(got, want)
    return {pid for pid, _ in results}


class Recorder:
    def __init__(self) -> None:
        self.calls: list[tuple[int, int]] = []

    def __call__(self, done: int, total: int) -> None:
        self.calls.append((done, total))

    def check(self, total: int) -> None:
        assert self.calls == [(k, total) for k in range(1, total + 1)]


def test_in_process() -> None:
    progress = Recorder()
    assert check(run_tasks(draw, TASKS, workers=1, progress=progress)) == {os.getpid()}
    progress.check(len(TASKS))


def test_local_pool() -> None:
    progress = Recorder()
    pids = check(run_tasks(draw, TASKS, workers=2, progress=progress))
    assert len(pids) == 2 and os.getpid() not in pids
    progress.check(len(TASKS))


def test_default_workers_and_empty() -> None:
    check(run_tasks(draw, TASKS))
    assert run_tasks(draw, []) == []
    assert run_tasks(draw, [], scheduler="tcp://127.0.0.1:1") == []  # nothing to connect for


def test_task_error_is_raised_again() -> None:
    for workers in (1, 2):
        with pytest.raises(RuntimeError, match="task 3 failed"):
            run_tasks(fail, [(x,) for x in range(6)], workers=workers)


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_bad_workers(workers: object) -> None:
    with pytest.raises(ConfigError) as err:
        run_tasks(draw, TASKS, workers=workers)  # type: ignore[arg-type]
    assert err.value.field == "workers"


@pytest.mark.parametrize("scheduler", ["", "   ", 8786, b"tcp://127.0.0.1:8786"])
def test_bad_scheduler(scheduler: object) -> None:
    with pytest.raises(ConfigError) as err:
        run_tasks(draw, TASKS, scheduler=scheduler)  # type: ignore[arg-type]
    assert err.value.field == "scheduler"


@pytest.mark.parametrize(
    "scheduler", ["tcp://127.0.0.1", "tcp://127.0.0.1:port", "nope://127.0.0.1:8786"]
)
def test_malformed_scheduler_address(scheduler: str) -> None:
    with pytest.raises(ConfigError, match="like 'tcp://host:8786'") as err:
        run_tasks(draw, TASKS, scheduler=scheduler, timeout=0.5)
    assert err.value.field == "scheduler"


def test_unreachable_scheduler() -> None:
    start = time.monotonic()
    with pytest.raises(ConfigError) as err:
        run_tasks(draw, TASKS, scheduler="tcp://127.0.0.1:1", timeout=0.5)
    assert time.monotonic() - start < 5.0
    assert err.value.field == "scheduler"
    message = str(err.value)
    assert "tcp://127.0.0.1:1" in message
    assert "dask scheduler" in message and "dask worker tcp://127.0.0.1:1" in message


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"progress": 3}, "progress"),
        ({"timeout": 0}, "timeout"),
        ({"timeout": float("nan")}, "timeout"),
    ],
)
def test_other_bad_arguments(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ConfigError) as err:
        run_tasks(draw, TASKS, **kwargs)  # type: ignore[arg-type]
    assert err.value.field == field


def test_bad_args_list_item() -> None:
    with pytest.raises(ConfigError) as err:
        run_tasks(fail, [(1,), 2], workers=1)  # type: ignore[list-item]
    assert err.value.field == "args_list[1]"


def test_dask_missing(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # makes `import distributed` fail
    with pytest.raises(ConfigError, match="pip install dask distributed"):
        run_tasks(draw, TASKS, scheduler="tcp://127.0.0.1:1", timeout=0.5)


def test_imports_neither_dask_nor_rclpy() -> None:
    code = (
        "import sys, fbcc_ros.core.sim.parallel\n"
        "bad = {'dask', 'distributed', 'rclpy'} & set(sys.modules)\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# The cluster tests come last: the local pool forks, and forking is safer before the cluster's
# threads start in this process.


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        yield address


def test_dask_cluster(scheduler: str) -> None:
    progress = Recorder()
    pids = check(run_tasks(draw, TASKS, scheduler=scheduler, progress=progress))
    assert pids and os.getpid() not in pids
    progress.check(len(TASKS))


def test_dask_task_error_and_cluster_survives(scheduler: str) -> None:
    with pytest.raises(RuntimeError, match="task 3 failed"):
        run_tasks(fail, [(x,) for x in range(6)], scheduler=scheduler)
    # run_tasks closed its client only: the cluster still takes work.
    assert run_tasks(fail, [(0,), (1,)], scheduler=scheduler) == [0, 1]


def test_montecarlo_on_the_cluster_equals_the_local_run(scheduler: str) -> None:
    """fbcc-montecarlo's study on a Dask cluster: the same outcomes, trial by trial, as on
    local processes and in this process (the seeds travel with the tasks)."""
    from fbcc_ros.core.paper import paper_scenario
    from fbcc_ros.core.sim.montecarlo import draw_trials, run_montecarlo
    from fbcc_ros.core.sim.scenario import validate

    sc = validate({**paper_scenario("interference"), "duration": 0.5})
    trials = draw_trials(sc.geometry, 6, seed=3, stiffness=(1e8, 1e9), friction=(0.1, 0.5))
    here = run_montecarlo(sc, ["fbcc"], trials, workers=1, batch=2)["fbcc"]
    cluster = run_montecarlo(sc, ["fbcc"], trials, batch=2, scheduler=scheduler)["fbcc"]
    for field in ("peak_fz", "final_features", "residual_force", "success", "guard_trips"):
        np.testing.assert_array_equal(getattr(cluster, field), getattr(here, field))
