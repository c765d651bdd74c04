"""The loop benchmark's bare chain, in both shapes, over real DDS."""

from __future__ import annotations

import pytest

from fbcc_ros.harness.loop_bench import BARE, measure


@pytest.mark.flaky(reruns=2)
def test_the_bare_chain_runs_as_processes_as_the_cell_does() -> None:
    """With each node in its own process, the bare chain's nodes run in their own processes
    too (``python -m fbcc_ros.harness.loop_bench NAME``): each process does work, the chain
    answers the mock's samples with commands, and the latency is measured end to end."""
    run = measure("bare", 1.5, processes=True)
    assert set(BARE) <= set(run.cpu), run.cpu  # a process each, timed as processes are
    assert all(run.cpu[name] > 0.01 for name in BARE), run.cpu
    assert run.delivered > 0.3, run.delivered  # the machine's speed decides how many more
    assert 0.0 < run.latency_p50_us <= run.latency_p99_us, run
