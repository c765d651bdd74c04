"""The test and benchmark harness: a closed CellRun releases what it held."""

from __future__ import annotations

import os
from pathlib import Path

from fbcc_ros.harness.cell_run import CellRun, NodeSpec
from fbcc_ros.nodes.mock_cell import MockCellNode


def _dds_threads() -> int:
    """This process's DDS threads (Fast DDS names them ``dds.*``)."""
    tasks = Path(f"/proc/{os.getpid()}/task")
    return sum((t / "comm").read_text().startswith("dds.") for t in tasks.iterdir())


def test_a_closed_run_leaves_no_dds_participant_behind() -> None:
    """Each run's context holds a DDS participant; left alive after the run, its threads kept
    receiving every later run's traffic (in a bench of 16 runs, 0.95 of a core)."""
    def one_run() -> None:
        with CellRun([NodeSpec("mock_cell", MockCellNode)]) as run:
            run.spin_for(0.3, lambda _: None)
            assert _dds_threads() > before  # the run's participant is up

    before = 0
    one_run()  # the first participant also starts the process's shared DDS threads
    before = _dds_threads()
    for _ in range(2):
        one_run()
    assert _dds_threads() == before
