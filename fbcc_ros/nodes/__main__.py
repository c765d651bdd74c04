"""``python -m fbcc_ros.nodes NODE [--ros-args ...]``: a node as its console script runs it
(``ros2 run fbcc_ros NODE``), the signals caught before its modules load
(:mod:`fbcc_ros.ros.process`)."""

import sys

from fbcc_ros.ros.process import NODES, start

if len(sys.argv) < 2 or sys.argv[1] not in NODES:
    print(f"usage: python -m fbcc_ros.nodes {{{','.join(NODES)}}} [--ros-args ...]",
          file=sys.stderr)
    raise SystemExit(2)
start(sys.argv[1])
