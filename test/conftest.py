"""Shared fixtures: the paper's simulated peg-hole pairs (Section IV)."""

from __future__ import annotations

import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.paper import paper_pair


@pytest.fixture(params=["clearance", "interference"])
def pair(request: pytest.FixtureRequest) -> PegHole:
    return paper_pair(request.param)


@pytest.fixture
def clearance() -> PegHole:
    return paper_pair("clearance")


@pytest.fixture
def interference() -> PegHole:
    return paper_pair("interference")
