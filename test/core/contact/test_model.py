"""The contact model (eq. 5-13) against a brute-force quadrature, physics and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from fbcc_ros.core.contact.model import ContactBatch, PegHole, lame_stiffness
from fbcc_ros.core.errors import ConfigError, InputError
from fbcc_ros.core.paper import paper_pair
from test.core.contact.reference_contact import reference_response

DEG = math.pi / 180

# (dx, dy, l, theta_x, theta_y): untilted, XOZ only, YOZ only, both planes, marginal contact,
# a deep one past L/2, and a short one.
CASES = [
    (3e-5, 0.0, 5e-3, 0.0, 0.0),
    (5e-5, 0.0, 5e-3, 0.0, 2 * DEG),
    (-5e-5, 0.0, 10e-3, 0.0, 2 * DEG),
    (0.0, 5e-5, 5e-3, -2 * DEG, 0.0),
    (5e-5, -3e-5, 8e-3, 1 * DEG, -1.5 * DEG),
    (1.2e-5, 0.0, 10e-3, 0.0, 0.02 * DEG),
    (-8e-5, 6e-5, 2e-3, 0.5 * DEG, 1.7 * DEG),
    (1e-4, 1e-4, 9.5e-3, -2 * DEG, 2 * DEG),
]


@pytest.mark.parametrize("features", CASES)
def test_within_one_percent_of_brute_force_quadrature(pair: PegHole, features) -> None:
    fast = pair.response(np.array(features))
    ref = reference_response(pair, features)
    assert np.linalg.norm(ref[:3]) > 0, "the case must be in contact to be a test"
    # relative to the size of the force and of the moment vectors
    assert np.linalg.norm(fast[:3] - ref[:3]) <= 0.01 * np.linalg.norm(ref[:3])
    assert np.linalg.norm(fast[3:] - ref[3:]) <= 0.01 * np.linalg.norm(ref[3:])


def test_batch_equals_rows(pair: PegHole) -> None:
    rng = np.random.default_rng(3)
    f = np.column_stack(
        [
            rng.uniform(-1e-4, 1e-4, 1200),
            rng.uniform(-1e-4, 1e-4, 1200),
            rng.uniform(0, 12e-3, 1200),
            rng.uniform(-0.04, 0.04, 1200),
            rng.uniform(-0.04, 0.04, 1200),
        ]
    )
    batch = pair.response(f)
    assert batch.shape == (1200, 5)
    rows = np.array([pair.response(x) for x in f[::97]])
    np.testing.assert_allclose(batch[::97], rows, rtol=1e-12, atol=1e-9)


def test_the_vectorised_kernel_gives_each_row_what_it_gives_it_alone(pair: PegHole) -> None:
    """kernel.py runs the rows of a batch side by side (SIMD); each row's response is the one
    it gets alone, to the last bit, untilted rows (an infinite contact interval), rows out of
    contact, both acting points and a pair per row included."""
    rng = np.random.default_rng(5)
    f = np.column_stack([rng.uniform(-2e-5, 2e-5, (600, 2)), rng.uniform(0, 12e-3, 600),
                         rng.uniform(-2e-3, 2e-3, (600, 2))])  # fmt: skip
    f[:60, 3:] = 0.0
    f[60:90, 2] = 0.0
    pairs = [pair.replace(hole_radius=pair.hole_radius + d, friction=m)
             for d, m in zip(rng.uniform(-3e-6, 3e-6, 600), rng.uniform(0.1, 0.5, 600),
                             strict=True)]
    for acting_point in ("hole_bottom", "peg_top"):
        at = [p.replace(acting_point=acting_point) for p in (pair, *pairs)]
        batch = ContactBatch.of(at[:1]).response(f)
        assert (batch[:, 2] > 0).any() and (batch[:, 2] == 0).any()  # in and out of contact
        alone = np.array([ContactBatch.of(at[:1]).response(x[None])[0] for x in f])
        assert (alone == batch).all()
        alone = np.array([ContactBatch.of([p]).response(x[None])[0]
                          for p, x in zip(at[1:], f, strict=True)])
        assert (ContactBatch.of(at[1:]).response(f) == alone).all()


def test_zero_depth_and_no_overlap_give_an_exact_zero_wrench(pair: PegHole, clearance) -> None:
    assert np.all(pair.response([1e-5, 2e-5, 0.0, 0.01, -0.02]) == 0.0)
    # a centred peg in a clearance hole touches nothing, at any depth
    assert np.all(clearance.response([0.0, 0.0, 7e-3, 0.0, 0.0]) == 0.0)
    assert np.all(clearance.response([4e-6, -3e-6, 7e-3, 0.0, 0.0]) == 0.0)


def test_interference_fit_loads_a_centred_peg_symmetrically(interference) -> None:
    w = interference.response([0.0, 0.0, 5e-3, 0.0, 0.0])
    assert w[2] > 0
    np.testing.assert_allclose(w[[0, 1, 3, 4]], 0.0, atol=1e-9 * w[2])
    # closed form: uniform penetration r - R around the wall: Fz = mu k 2 pi (r - R) l
    ph = interference
    expected = ph.friction * ph.stiffness * 2 * math.pi * (ph.peg_radius - ph.hole_radius) * 5e-3
    np.testing.assert_allclose(w[2], expected, rtol=1e-9)


def test_rotation_by_90_degrees_about_z_rotates_the_wrench(pair: PegHole) -> None:
    f = np.array([4e-5, -2e-5, 6e-3, 0.6 * DEG, 1.4 * DEG])
    dx, dy, l, thx, thy = f
    # peg offset and lean rotate with the frame: (dx, dy) -> (-dy, dx); theta_y' = theta_x,
    # theta_x' = -theta_y (right-hand tilts)
    rotated = np.array([-dy, dx, l, -thy, thx])
    w, wr = pair.response(f), pair.response(rotated)
    fx, fy, fz, mx, my = w
    np.testing.assert_allclose(wr, [-fy, fx, fz, -my, mx], rtol=1e-9, atol=1e-9)


def test_mirror_in_x_flips_fx_and_my(pair: PegHole) -> None:
    f = np.array([4e-5, 1e-5, 6e-3, 0.3 * DEG, 1.4 * DEG])
    w = pair.response(f)
    wm = pair.response(f * [-1, 1, 1, 1, -1])
    np.testing.assert_allclose(wm, w * [-1, 1, 1, 1, -1], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("depth", [1e-3, 5e-3, 10e-3, 12e-3])
def test_untilted_response_lies_on_eq24_line(pair: PegHole, depth: float) -> None:
    """theta_y = 0: every slice is the same, so My / Fx = -l/2 + L + H + mu R exactly."""
    w = pair.response([3e-5, 0.0, depth, 0.0, 0.0])
    assert abs(w[0]) > 1.0
    np.testing.assert_allclose(w[4] / w[0], pair.boundary_lever(depth), rtol=1e-9)
    if depth > pair.hole_depth:  # no wall below L: the lever stops moving
        np.testing.assert_allclose(pair.boundary_lever(depth), pair.boundary_lever(10e-3))


@pytest.mark.parametrize("tilt_deg", [0.5, 1.0, 2.0])
@pytest.mark.parametrize("depth", [5e-3, 10e-3])
def test_eq20_holds_only_to_first_order(pair: PegHole, tilt_deg: float, depth: float) -> None:
    """Fx vanishes at dx = r sin(theta) tan(theta), not at dx = 0: the r sin(theta) of eq. 5."""
    th = tilt_deg * DEG
    root = brentq(lambda d: pair.response([d, 0.0, depth, 0.0, th])[0], -3e-5, 3e-5, xtol=1e-13)
    predicted = pair.peg_radius * math.sin(th) * math.tan(th)
    np.testing.assert_allclose(root, predicted, rtol=0.02)
    assert pair.response([0.0, 0.0, depth, 0.0, th])[0] < 0  # dx = 0 reads as a negative offset


def test_clearance_no_contact_region_matches_eq15(clearance) -> None:
    """The model's own no-contact region is the rhombus of eq. (15), within 0.1 µm."""
    ph = clearance
    for depth in (2e-3, 10e-3):
        for th in (0.0, 0.02 * DEG, 0.05 * DEG):
            edge = ph.hole_radius - depth * math.sin(th) / 2 - ph.peg_radius * math.cos(th)
            inside = ph.response([edge - 1e-7, 0.0, depth, 0.0, th])
            outside = ph.response([edge + 1e-7, 0.0, depth, 0.0, th])
            assert inside[2] == 0.0
            assert outside[2] > 0.0


@pytest.mark.parametrize("depth", [3e-3, 8e-3])
def test_peg_top_acting_point_moves_moments_by_the_lever(pair: PegHole, depth: float) -> None:
    """M_top = M_bottom + (p_bottom - p_top) x F, with F the physical force on the hole."""
    top = pair.replace(acting_point="peg_top", peg_length=0.06)
    f = np.array([3e-5, 0.0, depth, 0.0, 0.0])  # untilted: the peg top is above (dx, dy)
    w_b, w_t = pair.response(f), top.response(f)
    np.testing.assert_allclose(w_t[:3], w_b[:3], rtol=1e-12)
    force = np.array([w_b[0], w_b[1], -w_b[2]])  # friction drags the hole along -z
    p_bottom = np.array([0.0, 0.0, -(pair.hole_depth + pair.base_thickness)])
    p_top = np.array([f[0], f[1], 0.06 - depth])
    expected = w_b[3:] + np.cross(p_bottom - p_top, force)[:2]
    np.testing.assert_allclose(w_t[3:], expected, rtol=1e-9, atol=1e-12 * abs(expected).max())
    np.testing.assert_allclose(w_t[4] / w_t[0], top.boundary_lever(depth), rtol=1e-3)


def test_lame_stiffness_hand_values() -> None:
    # b = 2R, both ABS (E 2.2 GPa, nu 0.35): 1/k = ((4+1)/(4-1) + 0.35)/E + (1 - 0.35)/E
    np.testing.assert_allclose(lame_stiffness(5e-3, 10e-3), 2.2e9 / (5 / 3 + 0.35 + 0.65))
    # a very thick wall: 1/k -> (1 + nu_h)/E + (1 - nu_p)/E = 2/E
    np.testing.assert_allclose(lame_stiffness(5e-3, 5.0), 2.2e9 / 2, rtol=1e-5)
    ph = PegHole.from_materials(5.03e-3, 5.04e-3, 10e-3, 5e-3, 0.3, outer_radius=10e-3)
    np.testing.assert_allclose(ph.stiffness, lame_stiffness(5.03e-3, 10e-3))
    with pytest.raises(ConfigError, match="outer_radius"):
        lame_stiffness(5e-3, 4e-3)
    with pytest.raises(ConfigError, match="poisson_hole"):
        lame_stiffness(5e-3, 10e-3, poisson_hole=0.5)


def test_fit_type(clearance, interference) -> None:
    assert clearance.fit == "clearance"
    assert interference.fit == "interference"


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [
        ("hole_radius", 0.0, "> 0"),
        ("peg_radius", -5e-3, "> 0"),
        ("stiffness", 0.0, "> 0"),
        ("hole_depth", float("nan"), "> 0"),
        ("friction", 1.0, "[0, 1)"),
        ("friction", -0.1, "[0, 1)"),
        ("base_thickness", -1e-3, ">= 0"),
        ("acting_point", "wrist", "hole_bottom"),
        ("n_angles", 30, "multiple of 4"),
    ],
)
def test_bad_geometry_names_field_value_and_what_is_allowed(
    clearance: PegHole, field: str, value: object, words: str
) -> None:
    with pytest.raises(ConfigError) as err:
        clearance.replace(**{field: value})
    msg = str(err.value)
    assert field in msg and repr(value) in msg and words in msg


@pytest.mark.parametrize(
    ("features", "field"),
    [
        ([0, 0, 5e-3, float("nan"), 0], "features"),
        ([0, 0, float("inf"), 0, 0], "features"),
        ([0, 0, -1e-3, 0, 0], "features.l"),
        ([0, 0, 5e-3, 0], "features"),
        (np.zeros((3, 4)), "features"),
    ],
)
def test_bad_features_are_rejected(clearance: PegHole, features, field: str) -> None:
    with pytest.raises(InputError) as err:
        clearance.response(features)
    assert str(err.value).startswith(f"{field}=")


feature_rows = st.tuples(
    st.floats(-2e-4, 2e-4),
    st.floats(-2e-4, 2e-4),
    st.floats(0.0, 15e-3),
    st.floats(-0.06, 0.06),
    st.floats(-0.06, 0.06),
)


@settings(max_examples=300, deadline=None)
@given(row=feature_rows, fit=st.sampled_from(["clearance", "interference"]))
def test_contact_force_is_never_negative_and_obeys_the_friction_bound(row, fit) -> None:
    """Fz >= 0, and |Fx|, |Fy| <= Fz / mu (Remark 1 of II.D, corrected: the bound is 1/mu)."""
    ph = paper_pair(fit)
    w = ph.response(np.array(row))
    assert np.all(np.isfinite(w))
    assert w[2] >= 0.0
    bound = w[2] / ph.friction * (1 + 1e-9) + 1e-12
    assert abs(w[0]) <= bound and abs(w[1]) <= bound
