"""How long the cell gives an insertion (fbcc_ros.harness.insertion_time): the duration on a
loop that delivers its cycles; on a starved one, on until it has delivered the duration's
cycles (at most MAX_STRETCH durations), and SETTLE after the insertion ends; on the plant's
clock, the duration of the plant's time."""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest

from fbcc_ros.harness import insertion_time
from fbcc_ros.harness.insertion_time import MAX_STRETCH, spin_insertion

#: judged on the wall clock: run alone (test/conftest.py)
pytestmark = pytest.mark.realtime

RATE = 1000.0
DURATION = 0.2


class FakeRun:
    """A cell whose loop delivers ``share`` of its cycles, its insertion ending ``ends_after``
    seconds after the start (None: never); it spins as CellRun.spin_for does."""

    def __init__(self, share: float, ends_after: float | None) -> None:
        self.share, self.ends_after = share, ends_after
        self.observer = self
        self.phase, self.counts = "inserting", {"commands": 7}  # counts from before the start
        self.start = time.monotonic()

    def spin_for(self, seconds: float, every_second: Callable[[float], None],
                 longer: Callable[[float], bool]) -> None:  # fmt: skip
        start = time.monotonic()
        while (elapsed := time.monotonic() - start) < seconds or longer(elapsed):
            time.sleep(0.002)
            now = time.monotonic() - self.start
            self.counts["commands"] = 7 + int(self.share * RATE * now)
            if self.ends_after is not None and now >= self.ends_after:
                self.phase = "inserted"


def _spun(run: FakeRun) -> float:
    spin_insertion(run, DURATION, RATE, lambda _: None)
    return time.monotonic() - run.start


@pytest.fixture(autouse=True)
def short_settle(monkeypatch) -> None:
    monkeypatch.setattr(insertion_time, "SETTLE", 0.1)


def test_a_loop_that_delivers_its_cycles_runs_the_duration() -> None:
    assert DURATION <= _spun(FakeRun(1.0, None)) < 1.5 * DURATION


def test_an_insertion_that_ended_in_time_is_not_given_more(capsys) -> None:
    assert _spun(FakeRun(0.3, 0.1)) < 1.5 * DURATION
    assert capsys.readouterr().out == ""


def test_a_starved_insertion_runs_until_the_durations_cycles_are_delivered(capsys) -> None:
    spun = _spun(FakeRun(0.5, None))  # half the cycles: twice the duration
    assert 2 * DURATION <= spun < 2.5 * DURATION
    said = capsys.readouterr().out
    assert "delivered 50% of its 1000 Hz cycles" in said and "ended its run" in said


def test_a_starved_insertion_that_ends_settles_then_stops() -> None:
    spun = _spun(FakeRun(0.3, 0.3))  # given up to DURATION / 0.3 = 0.67 s
    assert 0.3 + 0.1 <= spun < 0.6


def test_a_loop_that_delivers_nothing_is_given_at_most_max_stretch() -> None:
    spun = _spun(FakeRun(0.0, None))
    assert MAX_STRETCH * DURATION <= spun < (MAX_STRETCH + 0.5) * DURATION


class PlantClockRun(FakeRun):
    """A cell whose mock is its clock, its plant running at ``factor`` of real time: the truth
    is stamped with the plant's time (rows from before the start are not counted)."""

    def __init__(self, factor: float) -> None:
        super().__init__(1.0, None)
        self.factor, self.truth = factor, [(100.0,), (100.001,)]

    def spin_for(self, seconds: float, every_second: Callable[[float], None],
                 longer: Callable[[float], bool]) -> None:  # fmt: skip
        start = time.monotonic()
        while (elapsed := time.monotonic() - start) < seconds or longer(elapsed):
            time.sleep(0.002)
            self.truth.append((200.0 + self.factor * (time.monotonic() - self.start),))


@pytest.mark.parametrize("factor", [0.2, 2.0])
def test_on_the_plants_clock_the_duration_is_the_plants_time(factor: float, capsys) -> None:
    run = PlantClockRun(factor)
    spin_insertion(run, DURATION, RATE, lambda _: None, plant_clock=True)
    spun = time.monotonic() - run.start
    assert DURATION / factor <= spun < DURATION / factor + 0.1  # not the wall's duration
    assert run.truth[-1][0] - run.truth[2][0] >= DURATION
    assert "the mock is its clock" in capsys.readouterr().out


def test_a_plant_clock_that_stands_still_is_given_at_most_max_plant_wait(monkeypatch) -> None:
    monkeypatch.setattr(insertion_time, "MAX_PLANT_WAIT", 3.0)  # the shipped one: longer
    run = PlantClockRun(0.0)
    spin_insertion(run, DURATION, RATE, lambda _: None, plant_clock=True)
    assert 3.0 * DURATION <= time.monotonic() - run.start < 3.5 * DURATION
