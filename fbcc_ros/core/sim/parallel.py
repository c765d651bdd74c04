"""Run independent tasks on a local process pool or on an existing Dask cluster, same results.

:func:`run_tasks` calls ``fn(*args)`` once per tuple of ``args_list`` and returns the results in
the order of ``args_list``. Where the calls run is the only choice:

* ``scheduler=None`` (default): on this machine, ``workers`` processes of a
  :class:`concurrent.futures.ProcessPoolExecutor` (default :func:`os.cpu_count`); ``workers=1``
  runs every task in this process, without a pool (for debugging and profiling).
* ``scheduler="tcp://host:8786"`` (any address :class:`distributed.Client` accepts): on the
  workers of a Dask cluster that is already running. This module connects a client, submits the
  tasks, gathers the results and closes its client; it never starts or stops the cluster.

The results are identical whichever way they run, because

* each task carries everything it depends on in its arguments, its random seed included (a task
  never draws from a generator shared with other tasks or seeded by the process), so a task's
  result does not depend on which process runs it nor on what ran there before;
* the results are placed by the index of their task in ``args_list``, never in the order the
  tasks finish.

Requirements on ``fn``: it must be picklable by reference, i.e. a module-level function of an
importable module (not a lambda or a closure), and on a cluster every worker must run the same
environment (same fbcc_ros, numpy, ... as here). An exception raised by a task is raised again
here, the remaining tasks are cancelled.

Starting a cluster (Dask is an optional dependency: ``pip install dask distributed``)::

    dask scheduler                      # prints "Scheduler at: tcp://10.0.0.5:8786"
    dask worker tcp://10.0.0.5:8786 --nworkers N --nthreads 1   # on each machine

One thread per worker process: the tasks are CPU-bound Python/numba code, processes give the
parallelism. Then pass ``scheduler="tcp://10.0.0.5:8786"``. Dask is imported only when a
scheduler is given, so the local mode needs nothing beyond the standard library.
"""

from __future__ import annotations

import concurrent.futures
import os
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from fbcc_ros.core.errors import ConfigError

T = TypeVar("T")

#: Seconds to wait for a Dask scheduler to answer before giving up.
DEFAULT_TIMEOUT = 10.0

Progress = Callable[[int, int], object]


def run_tasks(
    fn: Callable[..., T],
    args_list: Sequence[tuple[Any, ...]],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Progress | None = None,
    timeout: float = DEFAULT_TIMEOUT,
) -> list[T]:
    """``[fn(*args) for args in args_list]``, computed in parallel, in the order of ``args_list``.

    Args:
        fn: A module-level function (it is pickled by reference to reach the workers).
        args_list: One tuple of positional arguments per task.
        workers: Local processes (``scheduler=None``); default :func:`os.cpu_count`, 1 runs the
            tasks in this process. Ignored with a scheduler: the cluster's workers run the tasks.
        scheduler: Address of a running Dask scheduler, e.g. ``"tcp://10.0.0.5:8786"``; None
            runs locally.
        progress: Called as ``progress(done, total)`` in this thread each time a task finishes,
            ``done`` going 1, 2, ..., ``total``.
        timeout: Seconds to wait for the scheduler to answer.

    Raises:
        ConfigError: A bad argument, Dask missing, or no scheduler answering at ``scheduler``.
        Exception: Whatever a task raised, raised again here.
    """
    if not callable(fn):
        raise ConfigError("fn", fn, "a callable (a module-level function)")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        raise ConfigError("workers", workers, "an integer >= 1, or None for os.cpu_count()")
    if scheduler is not None and not (isinstance(scheduler, str) and scheduler.strip()):
        raise ConfigError(
            "scheduler",
            scheduler,
            "None (run locally) or a Dask scheduler address like 'tcp://host:8786'",
        )
    if progress is not None and not callable(progress):
        raise ConfigError("progress", progress, "None or a callable progress(done, total)")
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, int | float)
        or not timeout > 0  # also rejects NaN
    ):
        raise ConfigError("timeout", timeout, "a number of seconds > 0")
    tasks = list(args_list)
    for i, args in enumerate(tasks):
        if not isinstance(args, tuple | list):
            raise ConfigError(
                f"args_list[{i}]", args, "a tuple of positional arguments for fn, e.g. (seed,)"
            )

    if scheduler is not None:
        return _run_on_cluster(fn, tasks, scheduler.strip(), progress, timeout)
    if workers is None:
        workers = os.cpu_count() or 1
    if workers == 1:
        return _run_here(fn, tasks, progress)
    return _run_on_pool(fn, tasks, workers, progress)


def _run_here(
    fn: Callable[..., T], tasks: list[tuple[Any, ...]], progress: Progress | None
) -> list[T]:
    results = []
    for done, args in enumerate(tasks, start=1):
        results.append(fn(*args))
        if progress is not None:
            progress(done, len(tasks))
    return results


def _run_on_pool(
    fn: Callable[..., T], tasks: list[tuple[Any, ...]], workers: int, progress: Progress | None
) -> list[T]:
    if not tasks:
        return []
    results: list[Any] = [None] * len(tasks)
    with concurrent.futures.ProcessPoolExecutor(max_workers=min(workers, len(tasks))) as pool:
        index = {pool.submit(fn, *args): i for i, args in enumerate(tasks)}
        try:
            for done, future in enumerate(concurrent.futures.as_completed(index), start=1):
                results[index[future]] = future.result()
                if progress is not None:
                    progress(done, len(tasks))
        except BaseException:
            # Drop the queued tasks; leaving the block then waits for the running ones only.
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    return results


def _run_on_cluster(
    fn: Callable[..., T],
    tasks: list[tuple[Any, ...]],
    scheduler: str,
    progress: Progress | None,
    timeout: float,
) -> list[T]:
    try:
        import distributed
        from distributed.comm.addressing import get_address_host_port, parse_address
    except ImportError as exc:
        raise ConfigError(
            "scheduler",
            scheduler,
            "None: running on a Dask cluster needs dask and distributed "
            f"installed (pip install dask distributed), and they are not ({exc})",
        ) from exc
    # Check the address before distributed.Client sees it: a Client whose constructor fails on
    # a malformed address is left half-built and stalls the interpreter's exit for 2 s.
    try:
        if parse_address(scheduler)[0] != "inproc":
            get_address_host_port(scheduler)
    except ValueError as exc:
        raise ConfigError(
            "scheduler", scheduler, f"a Dask scheduler address like 'tcp://host:8786' ({exc})"
        ) from exc
    if not tasks:
        return []
    try:
        client = distributed.Client(scheduler, timeout=timeout, set_as_default=False)
    except (OSError, ValueError) as exc:  # TimeoutError is an OSError
        raise ConfigError(
            "scheduler",
            scheduler,
            f"the address of a running Dask scheduler, but none answered "
            f"at {scheduler} within {timeout:g} s ({exc}); start one with `dask scheduler` and "
            f"workers with `dask worker {scheduler} --nworkers N --nthreads 1`",
        ) from exc
    try:
        futures = [client.submit(fn, *args, pure=False) for args in tasks]
        index = {future.key: i for i, future in enumerate(futures)}
        results: list[Any] = [None] * len(tasks)
        # loop=: the client is not the process-wide default, as_completed would look for that.
        finished = distributed.as_completed(futures, loop=client.loop)
        for done, future in enumerate(finished, start=1):
            results[index[future.key]] = future.result()
            if progress is not None:
                progress(done, len(tasks))
        return results
    finally:
        # Releases this client's futures (the scheduler then drops unfinished tasks); the
        # cluster keeps running.
        client.close()
