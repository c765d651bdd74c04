"""The hole's rim in the contact model (top face, chamfer, bottom): against 1-D integrals of
the same penetration over the hole's polar coordinates, statics, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.contact.model import ContactBatch, PegHole
from fbcc_ros.core.contact.rim import FACE_DEPTH
from fbcc_ros.core.errors import ConfigError, InputError

DEG = math.pi / 180
#: The MuJoCo study's pair: 10 µm radial clearance, steel-like eq. 8 k.
PAIR = PegHole(5.05e-3, 5.04e-3, 0.01, 0.005, 0.3, 1e11, rim=True)


def _over_rays(pair: PegHole, offset: float, start: float, c0: float, c1: float,
               n: int = 200_000) -> tuple[float, float]:
    """(∫ p dA, ∫ x p dA) over an aligned peg's end face offset along +x, in the hole's polar
    coordinates, for the penetration ``c0 + c1 rho`` from ``rho = start`` out: along each ray
    at alpha the face reaches ``rho_max``, and the integrals along it are exact (a reference
    independent of the kernel's rays about the peg's centre)."""
    alpha = -math.pi + (np.arange(n) + 0.5) * (2 * math.pi / n)
    hi = offset * np.cos(alpha) + np.sqrt(pair.peg_radius**2 - (offset * np.sin(alpha)) ** 2)
    lo = np.minimum(start, hi)

    def power(k: int) -> np.ndarray:  # ∫ rho^k drho from lo to hi
        return (hi ** (k + 1) - lo ** (k + 1)) / (k + 1)

    per_ray = c0 * power(1) + c1 * power(2)  # ∫ g rho drho
    per_ray_x = (c0 * power(2) + c1 * power(3)) * np.cos(alpha)  # ∫ g rho cos(alpha) rho drho
    w = pair.stiffness / FACE_DEPTH * (2 * math.pi / n)
    return float(w * per_ray.sum()), float(w * per_ray_x.sum())


def test_a_peg_beside_the_hole_stands_on_the_top_face() -> None:
    # aligned, 0.1 mm off a 10 µm hole, pressed 0.2 µm into the face
    press = 2e-7
    w = PAIR.response([1e-4, 0.0, press, 0.0, 0.0])
    # the face carries the crescent but for its inner 0.2 µm, nearer the wall than the face
    fz, x_fz = _over_rays(PAIR, 1e-4, PAIR.hole_radius + press, press, 0.0)
    # 48 rays over a crescent that thins to nothing
    assert w[2] == pytest.approx(fz, rel=2e-3)
    # the wall presses only at the crescent's tips, where the overlap is under twice the
    # 0.2 µm the peg has sunk into the face (eq. 5-13 alone push it with its whole overlap)
    assert abs(w[0]) < 1e-3 * w[2]
    assert abs(PAIR.replace(rim=False).response([1e-4, 0.0, press, 0.0, 0.0])[0]) > 1.0
    # the support's moment about the hole bottom: the force on the hole is (0, 0, -Fz) at
    # the crescent's centroid, about 0.8 r out toward +x
    assert w[4] == pytest.approx(x_fz, rel=2e-3)
    assert 0.75 * PAIR.peg_radius < w[4] / w[2] < 0.9 * PAIR.peg_radius


def test_nothing_above_the_face_or_inside_the_bore() -> None:
    assert not PAIR.response([1e-4, 0.0, -1e-6, 0.0, 0.0]).any()  # above the face
    assert not PAIR.response([0.0, 0.0, 5e-3, 0.0, 0.0]).any()  # centred in the bore
    assert not PAIR.response([0.0, 0.0, 1e-6, 0.0, 0.0]).any()  # at the mouth


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_a_peg_on_the_chamfer_slides_toward_the_axis(mu: float) -> None:
    # (the bore's wall starts 0.3 mm down, under the chamfer: it is not touched here)
    width = 3e-4
    pair = PAIR.replace(chamfer=width, friction=mu)
    offset, depth = 2e-4, 1.15e-4  # its edge 5.24 mm out, 5 µm under the cone's surface
    down = [0.0, 0.0, -5e-3]  # sliding in at 5 mm/s
    w = pair.response([offset, 0.0, depth, 0.0, 0.0], slide=down)
    # the depth under the cone along its normal, (rho - (R + W - depth)) / √2
    start = pair.hole_radius + width - depth
    normal, _ = _over_rays(pair, offset, start, -start * math.sqrt(0.5), math.sqrt(0.5))
    # frictionless, the cone pushes at 45°: on the hole Fx = Fz = N / √2 (less the arc's spread)
    assert w[2] == pytest.approx(normal * math.sqrt(0.5) * (1 + mu), rel=2e-3)
    # sliding down, the friction turns it by atan(mu): Fx / Fz = tan(45° - atan mu)
    assert w[0] / w[2] == pytest.approx(math.tan(math.pi / 4 - math.atan(mu)), rel=5e-3)


def test_the_faces_friction_opposes_the_sliding() -> None:
    f = [1e-4, 0.0, 2e-7, 0.0, 0.0]
    still = PAIR.response(f)
    for v, side in (([1e-3, 0.0, 0.0], 0), ([0.0, -1e-3, 0.0], 1)):
        w = PAIR.response(f, slide=v)
        assert w[2] == pytest.approx(still[2])
        # the peg drags the hole along its motion with mu N
        drag = w[side] - still[side]
        assert drag == pytest.approx(math.copysign(PAIR.friction * w[2], sum(v)), rel=1e-9)
    # below SLIDE_EPS the friction fades with the speed
    slow = PAIR.response(f, slide=[1e-5, 0.0, 0.0])
    assert slow[0] - still[0] == pytest.approx(0.1 * PAIR.friction * still[2], rel=1e-9)


def test_the_bottom_stops_the_peg() -> None:
    press = 1e-7
    w = PAIR.response([0.0, 0.0, PAIR.hole_depth + press, 0.0, 0.0])
    area = math.pi * PAIR.peg_radius**2
    assert w[2] == pytest.approx(PAIR.stiffness / FACE_DEPTH * press * area, rel=1e-6)
    assert np.abs(w[[0, 1, 3, 4]]).max() < 1e-9 * w[2]


def test_a_tilted_peg_stands_on_its_low_edge() -> None:
    # leaning 5° with its top toward +x, so its low edge is at +x: 0.3 mm off, that edge
    # stands on the face 2 µm deep, the rest of its end face over the hole
    tilt = 5 * DEG
    f = [3e-4, 0.0, 2e-6 / math.cos(tilt), 0.0, tilt]
    w = PAIR.response(f)
    assert w[2] > 0
    # the force on the hole (0, 0, -Fz) acts near the low edge, about r + 0.3 mm out
    assert w[4] / w[2] == pytest.approx(PAIR.peg_radius + 3e-4, abs=0.2e-3)
    assert abs(w[0]) < 1e-2 * w[2]  # the wall: only where the ellipse just crosses it


def test_pairs_with_and_without_the_rim_in_one_batch() -> None:
    rows = np.array([[1e-4, 0.0, 2e-7, 0.0, 0.0]] * 2)
    batch = ContactBatch.of([PAIR, PAIR.replace(rim=False)])
    both = batch.response(rows)
    np.testing.assert_array_equal(both[0], PAIR.response(rows[0]))
    np.testing.assert_array_equal(both[1], PAIR.replace(rim=False).response(rows[1]))


def test_the_end_face_cuts_eq_5s_slices() -> None:
    # the wall's normal pressure: eq. 5-13's without their friction (with the rim the wall's
    # friction follows the peg's sliding; at rest there is none)
    plain = PAIR.replace(rim=False, friction=0.0)
    # an aligned peg deep in the bore: the same wall as eq. 5-13
    f = [5e-5, 0.0, 5e-3, 0.0, 0.0]
    np.testing.assert_array_equal(PAIR.response(f), plain.response(f))
    # tilted 2° with its top toward +x, its end face's low corner is at +x: pressed against
    # +x it touches the wall as eq. 5's whole ellipses say ...
    f = [1e-4, 0.0, 5e-3, 0.0, 2 * DEG]
    np.testing.assert_array_equal(PAIR.response(f), plain.response(f))
    # ... pressed against -x, with its high corner, whose lowest 2 r sin(2°) = 0.35 mm eq. 5
    # fills with material that is not there: less force
    f = [-5e-5, 0.0, 5e-3, 0.0, 2 * DEG]
    cut, whole = PAIR.response(f), plain.response(f)
    assert 0.7 * abs(whole[0]) < abs(cut[0]) < 0.95 * abs(whole[0])


def test_bad_rim_settings_are_refused() -> None:
    with pytest.raises(ConfigError, match="chamfer"):
        PAIR.replace(rim=False, chamfer=1e-4)
    with pytest.raises(ConfigError, match="chamfer"):
        PAIR.replace(chamfer=-1e-4)
    with pytest.raises(ConfigError, match="chamfer"):
        PAIR.replace(chamfer=PAIR.hole_depth)
    with pytest.raises(ConfigError, match="rim"):
        PAIR.replace(rim="yes")
    with pytest.raises(InputError, match=r"features\.l"):
        PAIR.replace(rim=False).response([0.0, 0.0, -1e-6, 0.0, 0.0])
    with pytest.raises(InputError, match="slide"):
        PAIR.response([0.0, 0.0, 1e-3, 0.0, 0.0], slide=[1.0, 0.0])
    with pytest.raises(InputError, match="slide"):
        PAIR.response([0.0, 0.0, 1e-3, 0.0, 0.0], slide=[math.nan, 0.0, 0.0])
