"""Shared fixtures: the paper's simulated peg-hole pairs (Section IV); which tests are
real-time; a ROS domain of its own for each pytest-xdist worker."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.paper import paper_pair

# the workers of a parallel run never hear each other's nodes (test/nodes has its own domains,
# 100-219, for the real-time tests run alone)
if (_worker := os.environ.get("PYTEST_XDIST_WORKER", "")).startswith("gw"):
    os.environ["ROS_DOMAIN_ID"] = str(40 + int(_worker[2:]) % 50)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


@pytest.fixture(params=["clearance", "interference"])
def pair(request: pytest.FixtureRequest) -> PegHole:
    return paper_pair(request.param)


@pytest.fixture
def clearance() -> PegHole:
    return paper_pair("clearance")


@pytest.fixture
def interference() -> PegHole:
    return paper_pair("interference")


#: The tests judged on the wall clock: live cells and nodes over DDS. scripts/test.sh runs the
#: others on every core (pytest-xdist) and these after, one at a time, on an otherwise idle
#: machine: a live 1 kHz cell beside a busy worker delivers a fraction of its cycles.
REALTIME_DIRS = ("nodes",)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    here = Path(__file__).parent
    for item in items:
        where = item.path.relative_to(here).parts
        if (where[0] in REALTIME_DIRS or item.get_closest_marker("flaky") is not None
                or item.path.name == "test_launch_file.py"):
            item.add_marker(pytest.mark.realtime)
