"""The state study's tallies: a share's interval over insertions, and tallies pooled."""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.sim.state_study import Tally


def _tally(shares: list[float], samples: int = 100) -> Tally:
    """A tally of insertions of ``samples`` samples each, ``share`` of each named right (P0
    right, P1 named for P0 otherwise)."""
    t = Tally()
    for share in shares:
        right = round(share * samples)
        truth = np.array(["P0"] * samples, dtype=object)
        named = np.array(["P0"] * right + ["P1"] * (samples - right), dtype=object)
        t.add(truth, named, insertion=True)
    return t


def test_the_interval_is_over_insertions_and_narrows_with_more_of_them() -> None:
    alike = _tally([0.9] * 8)
    assert alike.interval() == (0.9, 0.9)  # the insertions agree: nothing to resample
    shares = [0.95, 0.97, 0.6, 0.93, 0.96, 0.7, 0.94, 0.98]
    few, many = _tally(shares), _tally(shares * 4)
    lo, hi = few.interval()
    assert lo < few.accuracy < hi and lo < 0.85 and hi > 0.92  # two lost insertions in 8
    lo4, hi4 = many.interval()
    assert lo4 < many.accuracy < hi4 and hi4 - lo4 < 0.6 * (hi - lo)  # ~1/√4 as wide
    assert few.interval() == (lo, hi)  # seeded: a study's table is reproducible
    assert _tally([0.9]).interval() is None
    # pooled, each part keeps its count in every draw: a stratum all right and one all
    # wrong pool to no spread at all (drawn freely, 8 of the 8 would spread)
    assert Tally.pooled([_tally([1.0] * 4), _tally([0.0] * 4)]).interval() == (0.5, 0.5)
    empty = Tally()  # an insertion with no scored sample is not one
    empty.add(np.array([], dtype=object), np.array([], dtype=object), insertion=True)
    assert empty.insertions == []
    plain = Tally()  # samples not added as insertions have no interval
    plain.add(np.array(["P0", "P1"], dtype=object), np.array(["P0", "P0"], dtype=object))
    assert plain.interval() is None and plain.as_dict()["interval"] is None


def test_pooled_tallies_count_every_sample_and_insertion_once() -> None:
    a, b = _tally([1.0, 0.5]), _tally([0.8], samples=300)
    p = Tally.pooled([a, b])
    assert p.confusion.sum() == 500 and [i[:2] for i in p.insertions] == [
        i[:2] for i in a.insertions + b.insertions]
    assert [i[2] for i in p.insertions] == [0, 0, 1]  # each tally a stratum
    assert p.accuracy == (100 + 50 + 240) / 500
    assert a.confusion.sum() == 200  # the parts are left as they were
    assert p.as_dict()["insertions"] == 3
