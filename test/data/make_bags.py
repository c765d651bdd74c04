"""Makes the committed test bag ``test/data/bags/short_interference``: one short assembly of the
hardware-free cell, recorded by ``fbcc_bringup`` as a user's session would be (the nodes in one
process, the recorder in its own). Run from the repository root:

    .venv/bin/python test/data/make_bags.py

The offline replay test (test/bag/test_offline.py) reproduces this bag's recorded commands from
its raw wrenches and joint states; rerun this script after a change that is meant to change the
commands (the law, the compensation, the kinematics), and commit the new bag with it.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from fbcc_ros.nodes.bringup import main as bringup

HERE = Path(__file__).resolve().parent
BAG = HERE / "bags" / "short_interference"
SCENARIO = "test/data/short_interference.yaml"  # relative: the bag's parameters stay portable


def main() -> int:
    shutil.rmtree(BAG, ignore_errors=True)
    return bringup([SCENARIO, "--bag", str(BAG)])


if __name__ == "__main__":
    sys.exit(main())
