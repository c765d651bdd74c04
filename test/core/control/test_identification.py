"""The lever's friction (identification module doc): read on one sliding contact, refused on a
wedge, and taken as the lower envelope of runs of samples under the bound."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control import identification as ident
from fbcc_ros.core.sim import scenario

ROOT = Path(__file__).resolve().parents[3]
NOMINAL = scenario.load(ROOT / "config" / "scenarios" / "robust_clearance.yaml").geometry


def _sample(part: PegHole, features: list[float]) -> float:
    """What the law reads of the contact model's wrench at ``features``, with the nominal
    pair's lever (its μ 0.3): the wall's mean height without the friction term."""
    depth = features[2]
    wall = float(NOMINAL.boundary_lever(depth)) - NOMINAL.friction * NOMINAL.hole_radius
    w = part.response(np.array(features, dtype=float))
    return float(ident.one_contact_friction(w, depth, wall, NOMINAL.hole_radius))


@pytest.mark.parametrize("mu", [0.15, 0.45])
@pytest.mark.parametrize("depth", [3e-4, 1e-3, 3e-3])
def test_one_contact_reads_the_parts_friction(mu: float, depth: float) -> None:
    """A peg pressed on one side of a 7 µm clearance, sliding in: Fz/|F_lat| is the part's μ
    (within the pressure's spread over an arc, 3 % here), in any direction."""
    part = dataclasses.replace(NOMINAL, hole_radius=5.0475e-3, peg_radius=5.0402e-3,
                               friction=mu, stiffness=4e10)  # fmt: skip
    push = part.hole_radius - part.peg_radius + 1e-6
    for dx, dy in ((0.0, push), (-push, 0.0), (push / math.sqrt(2), -push / math.sqrt(2))):
        assert _sample(part, [dx, dy, depth, 0.0, 0.0]) == pytest.approx(mu, rel=0.05)


def test_a_larger_peg_on_one_contact_is_read_too() -> None:
    """On a 10 mm peg the ratio's reading over μ (the pressure's spread over an arc) moves the
    contact height by that excess times R: a peg pressed on one side while tilted 1.9° in the
    other plane (a draw of a 10 mm study) reads 11 % over μ and 0.43 mm off the wall, past
    the 0.3 mm that suffices at 5 mm; the margin in proportion to R reads it, and still
    refuses that peg's wedges."""
    nominal = dataclasses.replace(NOMINAL, hole_radius=10.02e-3, peg_radius=10.0e-3,
                                  hole_depth=15e-3)  # fmt: skip
    part = dataclasses.replace(nominal, hole_radius=10.0175e-3, friction=0.425,
                               stiffness=3e10)  # fmt: skip
    features = np.array([-23e-6, -12.2e-6, 1.1e-4, 0.03394, 0.00614])
    depth = features[2]
    wall = float(nominal.boundary_lever(depth)) - nominal.friction * nominal.hole_radius
    w = part.response(features)
    ratio = w[2] / math.hypot(w[0], w[1])
    lever = (w[4] * w[0] - w[3] * w[1]) / (w[0] ** 2 + w[1] ** 2)
    assert abs(lever - ratio * nominal.hole_radius - wall) > depth / 2 + ident.LEVER_MARGIN
    sample = ident.one_contact_friction(w, depth, wall, nominal.hole_radius)
    assert sample == pytest.approx(0.425, rel=0.12)
    # a wedge of that peg (0.2 µm of clearance, tilted 0.3-0.5°) is still refused
    tight = dataclasses.replace(nominal, hole_radius=10.0002e-3, friction=0.3, stiffness=8e10)
    for depth, tilt_deg in ((5e-4, 0.5), (1e-3, 0.3)):
        wedge = tight.response(np.array([0.0, 0.0, depth, math.radians(tilt_deg), 0.0]))
        assert wedge[2] / math.hypot(wedge[0], wedge[1]) > 1.5 * 0.3
        wall = float(nominal.boundary_lever(depth)) - nominal.friction * nominal.hole_radius
        assert ident.one_contact_friction(wedge, depth, wall, nominal.hole_radius) == -1.0


@pytest.mark.parametrize("mu", [0.11, 0.3])
@pytest.mark.parametrize(("depth", "tilt_deg"), [(3e-4, 0.2), (5e-4, 0.5), (1e-3, 0.3)])
def test_a_wedged_peg_is_not_read_as_friction(mu: float, depth: float, tilt_deg: float) -> None:
    """A tilted peg within 0.2 µm of line-to-line touches both sides: Fz = μ (N1 + N2) over
    |F_lat| = |N1 - N2| reads 3-11 times μ, and its moment puts no single contact on the wall."""
    part = dataclasses.replace(NOMINAL, hole_radius=5.0402e-3, peg_radius=5.04e-3,
                               friction=mu, stiffness=8e10)  # fmt: skip
    features = [0.0, 0.0, depth, math.radians(tilt_deg), 0.0]
    w = part.response(np.array(features))
    assert w[2] / math.hypot(w[0], w[1]) > 3 * mu  # the case is a wedge
    assert _sample(part, features) == -1.0


def test_the_estimate_is_the_envelope_of_runs_under_the_bound() -> None:
    s = np.zeros(ident.N_LEVER)
    dt = 1e-3
    for _ in range(50):  # a wedge's ratio over the bound is not friction
        ident.lever_friction_update(s, 1.2, dt, 0.8)
    assert s[0] == 0.0
    ident.lever_friction_update(s, -1.0, dt, 0.8)
    for _ in range(ident.LEVER_SAMPLES - 1):
        ident.lever_friction_update(s, 0.4, dt, 0.8)
    assert s[0] == 0.0  # a run too short says nothing
    ident.lever_friction_update(s, 0.4, dt, 0.8)
    assert s[0] == pytest.approx(0.4)
    ident.lever_friction_update(s, -1.0, dt, 0.8)  # a sample off one contact ends the run
    for value in (0.2,) * (ident.LEVER_SAMPLES - 1):
        ident.lever_friction_update(s, value, dt, 0.8)
    assert s[0] == pytest.approx(0.4)
    for _ in range(100):
        ident.lever_friction_update(s, 0.2, dt, 0.8)
    assert s[0] == pytest.approx(0.2, rel=1e-3)
    for _ in range(100):  # the envelope: a higher run does not raise it
        ident.lever_friction_update(s, 0.5, dt, 0.8)
    assert s[0] == pytest.approx(0.2, rel=1e-3)
