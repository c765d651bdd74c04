"""fbcc-recover: makes a bag whose recorder was killed (or cut by a full disk) whole again.

    fbcc-recover BAG [--out NEW_FOLDER]

BAG is a bag folder (or its ``.mcap``) that rosbags or mcap's indexed reader refuse: no summary
or footer, perhaps a chunk written in part at the end, a metadata.yaml that lags the file or
is missing. The whole records go into a new bag folder, NEW_FOLDER (default:
``<BAG>_recovered`` beside it; it must be new or empty, nothing is ever overwritten), written
as the recorder writes a bag it closes (:mod:`fbcc_ros.bag.recover` says what is kept). Prints
the messages per topic, the time span and the bytes dropped at the tail.

A bag that is already complete (its summary and footer there, and a metadata.yaml that counts
what the file holds) is said to be so and left alone: nothing is written, with or without
``--out`` (a copy of a complete bag is ``cp -r``).

Exit status 0, also for a complete bag; 2 on bad input (a missing folder, no ``.mcap`` in it,
a file that is not mcap, an ``--out`` that exists and is not empty), with one line saying
what and no traceback.
"""

from __future__ import annotations

import argparse
from datetime import UTC, datetime
from pathlib import Path

from fbcc_ros.bag.recover import Recovery, recover
from fbcc_ros.core.errors import command


def _time(ns: int) -> str:
    return datetime.fromtimestamp(ns / 1e9, UTC).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]


def describe(result: Recovery) -> list[str]:
    """What was recovered, a line per fact."""
    total = sum(result.counts.values())
    lines = [f"recovered {result.source} into {result.bag}: {total} messages"]
    width = max((len(topic) for topic in result.counts), default=0)
    lines += [f"  {topic:<{width}}  {n}" for topic, n in result.counts.items()]
    if result.start_ns is not None:
        lines.append(f"time span: {_time(result.start_ns)} to {_time(result.end_ns)} UTC "
                     f"({(result.end_ns - result.start_ns) / 1e9:.3f} s)")  # fmt: skip
    lines.append(f"dropped {result.dropped_bytes} bytes (kept {result.kept_bytes}): "
                 f"{result.truncated or 'the file was whole'}")  # fmt: skip
    if result.copied:
        lines.append(f"copied beside it: {', '.join(result.copied)}")
    return lines


@command("fbcc-recover")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fbcc-recover", description=__doc__.splitlines()[0])
    parser.add_argument("bag", type=Path, help="bag folder (or its .mcap) to recover")
    parser.add_argument("--out", type=Path, default=None,
                        help="new bag folder (default: <bag>_recovered beside it)")  # fmt: skip
    args = parser.parse_args(argv)
    result = recover(args.bag, args.out)
    if result is None:
        print(f"{args.bag} is complete (summary, footer, metadata.yaml in step, every chunk "
              "reads): nothing to recover, nothing written")  # fmt: skip
        return 0
    print("\n".join(describe(result)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
