"""ROS isolation for the node tests: discovery on this machine only, and a ROS domain of its own
for each test (PLATFORM.md), so that no test ever hears another's nodes. A latched phase from an
earlier test's cell did reach a later one when they shared a domain.

Domains: a block of 10 per test run (chosen from the pid), cycled test by test; rclpy reads
``ROS_DOMAIN_ID`` when a context is initialised, and node subprocesses inherit it.
"""

from __future__ import annotations

import itertools
import os

import pytest

_BLOCK = 100 + (os.getpid() % 10) * 10
_NEXT = itertools.cycle(range(_BLOCK, _BLOCK + 10))


@pytest.fixture(autouse=True)
def ros_isolation() -> None:
    os.environ["ROS_DOMAIN_ID"] = str(next(_NEXT))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
