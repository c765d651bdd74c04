"""ROS isolation for the node tests: a domain id of our own per test run, discovery on this
machine only (PLATFORM.md)."""

from __future__ import annotations

import os

import pytest


@pytest.fixture(scope="session", autouse=True)
def ros_isolation() -> None:
    os.environ["ROS_DOMAIN_ID"] = str(100 + os.getpid() % 100)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
