"""How long the hardware-free cell gives an insertion: the scenario's duration, and longer when
the loop did not deliver its cycles.

The controller's law steps by its samples' stamps, at most the longest period it resolves a
sample (6 ms for the robust law: it does not extrapolate further), so a loop starved of cycles
(a slow or busy machine, a node restarting) inserts slower than the clock. A run still
inserting when the duration has passed goes on until the loop has delivered the duration's
cycles (``rate_hz · duration`` joint commands since it started), at most :data:`MAX_STRETCH`
times the duration, and ends :data:`SETTLE` after the insertion does (inserted, or stopped
for any reason). On a loop that delivers its cycles nothing changes.

A cell whose mock is its clock (a plant slower than real time: mock_cell's ``publish_clock``)
delivers every cycle by construction, however slowly: its insertion runs for the duration of
the plant's time (the truth's stamps), and at most :data:`MAX_PLANT_WAIT` durations of the
wall's.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from fbcc_ros.core.control.phase import Phase

#: The longest a starved insertion is given, in durations (a loop delivering 25 % of its cycles).
MAX_STRETCH = 4.0
#: The longest a cell on its plant's clock is given, in durations of the wall's clock (MuJoCo
#: in a wedge runs at about a fifth of real time, docs/plant.md).
MAX_PLANT_WAIT = 20.0
#: How long a run that went on goes on once the insertion ended [s]: the arm settles on the
#: held command (a run ended at ``inserted`` was 27 µm short of the depth it then held).
SETTLE = 1.0


def spin_insertion(run: Any, duration: float, rate_hz: float,
                   every_second: Callable[[float], None], plant_clock: bool = False) -> None:
    """Spins the cell ``run`` (a :class:`~fbcc_ros.harness.cell_run.CellRun`) for ``duration``
    seconds, and on while its insertion runs on a starved loop (module doc); says once why.
    ``plant_clock``: the mock is the cell's clock, and ``duration`` is of its time."""
    if plant_clock:
        _spin_plant_time(run, duration, every_second)
        return
    observer = run.observer
    first = observer.counts["commands"]
    said, ended = False, -1.0  # ended: when the insertion ended, once it went on

    def longer(elapsed: float) -> bool:
        nonlocal said, ended
        if elapsed >= MAX_STRETCH * duration:
            return False
        if observer.phase != Phase.INSERTING:  # ended: the arm settles, as in a full run
            ended = elapsed if ended < 0 else ended
            return said and elapsed < ended + SETTLE
        delivered = observer.counts["commands"] - first
        if delivered >= rate_hz * duration:
            return False
        if not said:
            said, share = True, delivered / (rate_hz * elapsed)
            given = min(duration / max(share, 1e-9), MAX_STRETCH * duration)
            print(f"  the loop delivered {share:.0%} of its {rate_hz:g} Hz cycles and the "
                  f"insertion runs on: it is given up to {given:.1f} s (a starved loop "
                  "inserts slower than the clock)", flush=True)  # fmt: skip
        return True

    start = time.monotonic()
    run.spin_for(duration, every_second, longer)
    if said:
        print(f"  the insertion ended its run after {time.monotonic() - start:.1f} s "
              f"(phase {observer.phase})", flush=True)  # fmt: skip


def progress_line(observer: Any, plant_clock: bool = False) -> Callable[[float], None]:
    """Says the insertion's phase and true depth each second (``every_second`` of
    :func:`spin_insertion`), from the truth's rows on from now; on the plant's clock with the
    plant's time too."""
    truth, first = observer.truth, len(observer.truth)

    def progress(elapsed: float) -> None:
        depth = truth[-1][3] * 1e3 if truth else float("nan")
        own = f" (the plant's {_span(truth, first):.2f} s)" if plant_clock else ""
        print(f"  t = {elapsed:4.1f} s{own}  phase {observer.phase:10s} depth {depth:.3f} mm",
              flush=True)  # fmt: skip

    return progress


def _spin_plant_time(run: Any, duration: float, every_second: Callable[[float], None]) -> None:
    """Spins ``run`` until the truth's stamps span ``duration`` (module doc)."""
    truth, first = run.observer.truth, len(run.observer.truth)

    def plant_time() -> float:
        return _span(truth, first)

    start = time.monotonic()
    run.spin_for(0.0, every_second,
                 lambda wall: wall < MAX_PLANT_WAIT * duration and plant_time() < duration)
    wall = time.monotonic() - start
    print(f"  the cell ran {plant_time():.2f} s of the plant's time in {wall:.1f} s "
          f"({plant_time() / wall:.2f}x real time; the mock is its clock)", flush=True)


def _span(truth: list[tuple[float, ...]], first: int) -> float:
    """The plant's time [s] the truth's rows span from row ``first`` on (0 before two)."""
    return truth[-1][0] - truth[first][0] if len(truth) > first else 0.0
