"""The contact state along an insertion from where the hole is
(fbcc_ros.core.control.deviation_filter): on simulated insertions of drawn parts, the hole's
deviation is found, the states are named right at least 90 % of the time (interference), and
what it states as near-certain is right; bad settings are refused."""

from __future__ import annotations

import numpy as np
import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import FZ_MIN, STATES, feature_state
from fbcc_ros.core.control.contact_state import most_probable
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.deviation_filter import (
    ENTRY_DEPTH,
    SPREAD_OUT,
    UNKNOWN_STIFFNESS,
    DeviationFilter,
    StateFeed,
)
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim import scenario as scenario_io
from fbcc_ros.core.sim.simulation import simulate


@pytest.fixture(scope="module")
def insertions() -> tuple:
    """Three robust-law insertions of drawn interference parts at 0.5 GPa, deviations drawn
    over the ranges."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_interference.yaml"))
    unc = Uncertainty()
    rng = np.random.default_rng(21)
    parts = [unc.part(sc.geometry.replace(stiffness=5e8), rng) for _ in range(3)]
    lateral = rng.uniform(-1, 1, (3, 4)) * [unc.max_offset, unc.max_offset, unc.max_tilt,
                                            unc.max_tilt]  # fmt: skip
    dev = np.column_stack([lateral[:, :2], np.zeros(3), lateral[:, 2:]])
    _, traj = simulate(sc, "fbcc", initial=dev, geometries=parts, seed=21)
    return sc, unc, parts, dev, traj


def test_the_deviation_is_found_and_the_states_named(insertions: tuple) -> None:
    """The filter told the parts' k as a user states it (0.5 GPa; each part is within 2^±1 of
    it)."""
    sc, unc, parts, dev, traj = insertions
    stated = sc.geometry.replace(stiffness=5e8)
    right = total = sure = sure_right = 0
    for i in range(len(parts)):
        f = DeviationFilter(stated, unc, seed=i)
        for k in range(0, len(traj.t), 5):
            x, pose = traj.features[k, i], traj.pose[k, i]
            if x[2] <= 0 and pose[2] <= 0:
                continue
            named, p = most_probable(f.update(traj.measured[k, i], pose))
            if x[2] > 0:
                truth = feature_state(x, parts[i])
                hits = [named[j] == truth[j] for j in range(2)]
                right += sum(hits)
                total += 2
                sure += int((p > 0.99).sum())
                sure_right += sum(h for h, q in zip(hits, p, strict=True) if q > 0.99)
        mean, _ = f.deviation()
        error = np.abs(mean[:4] - dev[i, [0, 1, 3, 4]])
        assert (error[:2] < 1e-6).all() and (error[2:] < 1e-4).all(), error  # 1 µm, 0.1 mrad
    assert right / total >= 0.9, right / total
    assert sure_right / sure >= 0.95, (sure, sure_right)


def _cloud(nominal: PegHole, n: int = 500) -> np.ndarray:
    """n particles at the believed hole with the nominal μ, gap and k: (dx, dy, θx, θy, μ, g,
    ln k)."""
    theta = np.zeros((n, 7))
    theta[:, 4] = nominal.friction
    theta[:, 6] = np.log(nominal.stiffness)
    return theta


def test_before_any_contact_the_state_is_open() -> None:
    """No contact yet: no particle pressing is favoured over another, and no state of a
    contact is named with certainty."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    f = DeviationFilter(sc.geometry, particles=500)
    p = f.update(np.zeros(5), np.array([0.0, 0.0, 1e-3, 0.0, 0.0]))
    assert p.shape == (2, len(STATES)) and np.allclose(p.sum(axis=1), 1.0)
    assert (p.max(axis=1) < 0.99).all()


def test_a_cloud_every_particle_of_which_is_contradicted_is_spread_out() -> None:
    """A clearance cloud collapsed on a contact (every particle has the peg against the wall)
    while the sensor reads nothing: the weights alone cannot move it; it is spread out, and
    then the particles that leave the wall carry the state."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    nominal = sc.geometry.replace(stiffness=1e10)  # a steel pair: 1 µm presses
    f = DeviationFilter(nominal, particles=500, anneal=0, seed=3)
    gap = nominal.hole_radius - nominal.peg_radius
    theta = _cloud(nominal)
    theta[:, 0] = gap + 1e-6  # each particle: the hole 1 µm past the wall, along x
    f._theta = theta.copy()
    features = np.array([0.0, 0.0, 3e-3, 0.0, 0.0])
    pressing = f.true_features(features)
    assert (np.abs(pressing[:, 0]) > gap).all()  # all in contact
    f.update(np.zeros(5), features)  # the sensor: no contact
    assert f.spread_outs == 1
    spread = f._theta - theta
    assert np.allclose(spread.std(axis=0)[:4], SPREAD_OUT[:4], rtol=0.2)
    assert np.allclose(f.weights, 1.0 / 500)  # weighed afresh
    for _ in range(5):  # the particles that rest in the clearance are favoured
        p = f.update(np.zeros(5), features)
    assert f.spread_outs == 1 and p[0, STATES.index("P0")] > 0.5


def test_a_reading_within_the_noise_is_no_contact() -> None:
    """Half the cloud has the peg free in the clearance, half pressed 1 µm into the wall. A
    reading of 2 noise deviations in Fz is noise (CONTACT_SIGMAS = 3): the pressed half loses;
    one of 8 deviations, pushing the peg back from +x, is a contact: the free half loses."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    nominal = sc.geometry.replace(stiffness=1e10)
    gap = nominal.hole_radius - nominal.peg_radius
    theta = _cloud(nominal)
    theta[:250, 0] = gap + 1e-6  # pressed against the wall along +x
    features = np.array([0.0, 0.0, 3e-3, 0.0, 0.0])
    noise_fz = Uncertainty().noise[2]
    for fz, fx, winners in ((2 * noise_fz, 0.0, slice(250, None)),
                            (8 * noise_fz, -1.0, slice(None, 250))):  # fmt: skip
        f = DeviationFilter(nominal, particles=500, anneal=0, seed=3)
        f._theta = theta.copy()
        f.update(np.array([fx, 0.0, fz, 0.0, 0.0]), features)
        assert f.weights[winners].sum() > 0.99, (fz, f.weights[winners].sum())


def test_in_the_hole_a_particle_that_touches_at_all_is_in_contact() -> None:
    """3 mm in, a particle that overlaps the wall by 0.1 µm, with a k that makes it predict far
    less than FZ_MIN, is in contact when the sensor reads one, and beats a particle that puts
    the peg free; at the entry (ENTRY_DEPTH) it is not told apart from it."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    nominal = sc.geometry
    gap = nominal.hole_radius - nominal.peg_radius
    theta = _cloud(nominal)
    theta[:250, 0] = gap + 1e-7  # touching the wall along +x by 0.1 µm
    reading = np.array([-1.0, 0.0, 8 * Uncertainty().noise[2], 0.0, 0.0])
    for depth, touching_wins in ((3e-3, True), (ENTRY_DEPTH / 2, False)):
        f = DeviationFilter(nominal, particles=500, anneal=0, seed=3)
        f._theta = theta.copy()
        features = np.array([0.0, 0.0, depth, 0.0, 0.0])
        pressed = nominal.response(f.true_features(features)[0])
        assert 0.0 < pressed[2] < FZ_MIN  # it touches, below FZ_MIN at its k
        f.update(reading, features)
        share = f.weights[:250].sum()
        assert share > 0.99 if touching_wins else share == pytest.approx(0.5), (depth, share)


def test_a_particles_stiffness_says_whether_its_touch_shows() -> None:
    """Two halves of a cloud touch the wall alike, one as a soft part (0.1 GPa), one as steel
    (100 GPa), by the least overlap at which steel reads 10 N. No reading: the steel half,
    whose touch would show, loses. The steel half's own reading: the soft half, which predicts
    a thousandth of it, loses."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    nominal = sc.geometry
    gap = nominal.hole_radius - nominal.peg_radius
    depth = 3e-3
    steel_at = nominal.replace(stiffness=1e11).response
    dx = next(gap + d for d in np.geomspace(1e-10, 1e-6, 400)
              if steel_at([gap + d, 0, depth, 0, 0])[2] >= 10.0)
    steel = steel_at([dx, 0, depth, 0, 0])
    soft = steel / 1e3  # the model is linear in k
    assert soft[2] < Uncertainty().noise[2] < 10.0 <= steel[2] < 11.0  # only steel shows
    theta = _cloud(nominal)
    theta[:, 0] = dx  # the true features are the deviation's at the believed centre
    theta[:250, 6] = np.log(1e8)
    theta[250:, 6] = np.log(1e11)
    features = np.array([0.0, 0.0, depth, 0.0, 0.0])
    for reading, winners in ((np.zeros(5), slice(None, 250)), (steel, slice(250, None))):
        f = DeviationFilter(nominal, particles=500, anneal=0, seed=3)
        f._theta = theta.copy()
        f.update(reading, features)
        assert f.weights[winners].sum() > 0.99, (reading, f.weights[winners].sum())


def test_k_is_the_stated_one_or_drawn_over_a_stated_range() -> None:
    """By default every particle has the nominal (stated) k; a user who does not know k gives a
    range, over which the particles' k are log-uniform."""
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    nominal = sc.geometry.replace(stiffness=1e10)
    for options, (lo, hi) in (({}, (1e10, 1e10)), ({"stiffness": UNKNOWN_STIFFNESS},
                                                   UNKNOWN_STIFFNESS)):  # fmt: skip
        k = np.exp(DeviationFilter(nominal, particles=1000, **options)._theta[:, 6])
        assert np.isclose(k.min(), lo, rtol=0.1) and np.isclose(k.max(), hi, rtol=0.1), options
        assert lo * (1 - 1e-12) <= k.min() and k.max() <= hi * (1 + 1e-12)
        if lo < hi:  # log-uniform: as many below the geometric mean as above
            assert abs(np.mean(k < np.sqrt(lo * hi)) - 0.5) < 0.05


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"particles": 10}, r"particles=10.*at least 100"),
    ({"anneal": -1}, r"anneal=-1.*>= 0"),
    ({"stiffness": (1e9, 1e8)}, r"stiffness=\[1000000000.0, 100000000.0\].*0 < low <= high"),
])  # fmt: skip
def test_bad_settings_are_refused(kwargs: dict, match: str) -> None:
    sc = scenario_io.load(scenario_io.find("config/scenarios/robust_clearance.yaml"))
    with pytest.raises(ConfigError, match=match):
        DeviationFilter(sc.geometry, **kwargs)


def test_the_feed_starts_at_the_first_contact_and_takes_every_nth_period() -> None:
    feed = StateFeed(3)
    above = np.array([0.0, 0.0, -1e-3, 0.0, 0.0])
    assert not any(feed.take(above, np.zeros(5)) for _ in range(10))  # free, above the hole
    touching = np.array([0.0, 0.0, 5.0, 0.0, 0.0])  # Fz: on the top face
    taken = [feed.take(above, touching)] + [feed.take(above, np.zeros(5)) for _ in range(6)]
    assert taken == [True, False, False, True, False, False, True]
    feed.start_insertion()  # a new insertion waits for its own first contact
    assert not feed.take(above, np.zeros(5)) and feed.sent == 0
