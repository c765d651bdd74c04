"""What the online contact-state filter costs the cell's loop (docs/nodes.md, "The contact state
online"): the bench's 4 s loop (``harness.loop_bench.measure``, one process, the recorder on),
with the filter's topic recorded (so its process runs) and without, interleaved:

    .venv/bin/python scripts/studies/online_filter_cost.py [--runs 3]

One line per run: delivered, the cell's nodes with the whole executor [core], the p99 latency.
"""

from __future__ import annotations

import argparse

from fbcc_ros.cli.bench import CELL_NODES, machine_seconds
from fbcc_ros.harness import loop_bench
from fbcc_ros.nodes import bringup
from fbcc_ros.ros import topics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    shipped = bringup.recorded_topics
    print(f"machine: 10^7 Python additions in {machine_seconds():.2f} s")
    for _ in range(args.runs):
        for with_filter in (True, False):
            def recorded(conventions: str, arm_sensing: bool = False,
                         on: bool = with_filter) -> list[str]:  # fmt: skip
                extra = [topics.CONTACT_STATE_ESTIMATE] if on else []
                return shipped(conventions, arm_sensing) + extra

            bringup.recorded_topics = recorded  # what loop_bench records
            run = loop_bench.measure("fbcc", 4.0, recorder=True)
            cell = sum(v for k, v in run.cpu.items() if k in CELL_NODES)
            print(f"filter {'on ' if with_filter else 'off'}: delivered {run.delivered:.1%}, "
                  f"cell {cell:.2f} of a core, p99 {run.latency_p99_us / 1e3:.1f} ms",
                  flush=True)  # fmt: skip
    bringup.recorded_topics = shipped


if __name__ == "__main__":
    main()
