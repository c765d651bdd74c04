"""The feature vector <-> the peg's pose in {H} (fbcc_ros.core.contact.features): round trips, the
sign conventions of DESIGN §3, and agreement with the contact model's geometry (eq. 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fbcc_ros.core.contact.features import (
    R_ALIGNED,
    features_from_pose,
    hole_frames,
    pose_from_features,
    spin_of,
    true_features,
    true_rows_at,
)
from fbcc_ros.core.errors import InputError

R = 5.04e-3  # the paper's peg radius [m]

offsets = st.floats(-2e-4, 2e-4)
depths = st.floats(-0.02, 0.02)
tilts = st.floats(-0.3, 0.3)
spins = st.floats(-math.pi + 1e-6, math.pi - 1e-6)


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@settings(max_examples=300, deadline=None)
@given(offsets, offsets, depths, tilts, tilts, spins)
def test_features_pose_features_round_trip(dx, dy, depth, tx, ty, spin) -> None:
    features = np.array([dx, dy, depth, tx, ty])
    rotation, position = pose_from_features(features, R, spin)
    np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-14)
    assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(features_from_pose(rotation, position, R), features, atol=1e-15)
    assert spin_of(rotation) == pytest.approx(spin, abs=1e-12)


def test_aligned_peg_reads_as_tip_depth_and_tip_offset() -> None:
    # Hand-worked: aligned, the tip centre at (dx, dy, -l) in {H}.
    features = features_from_pose(R_ALIGNED, [3e-5, -2e-5, -4e-3], R)
    np.testing.assert_allclose(features, [3e-5, -2e-5, 4e-3, 0.0, 0.0], atol=1e-18)


def test_tilt_signs_follow_design_section_3() -> None:
    # theta_y > 0: right-hand rotation about y, the peg's top leans toward +x.
    rotation, _ = pose_from_features([0, 0, 0.005, 0.0, 0.1], R)
    up = -rotation[:, 2]
    np.testing.assert_allclose(up, _rot_y(0.1) @ [0, 0, 1], atol=1e-15)
    # theta_x > 0: right-hand rotation about x, the top leans toward -y.
    rotation, _ = pose_from_features([0, 0, 0.005, 0.1, 0.0], R)
    np.testing.assert_allclose(-rotation[:, 2], _rot_x(0.1) @ [0, 0, 1], atol=1e-15)
    assert -rotation[1, 2] < 0.0


def test_projected_tilts_of_eq_3() -> None:
    # A total tilt theta toward azimuth phi (the paper's (theta, phi) of eq. 1). Read with eq. 14
    # (DESIGN §5) the projected tilts are tan theta_y = tan theta cos phi, tan theta_x =
    # -tan theta sin phi, as in docs/contact-model.md.
    theta, phi = 0.2, 0.7
    up = np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )
    features = features_from_pose(_with_up_axis(up), [0.0, 0.0, -0.003], R)
    assert features[4] == pytest.approx(math.atan(math.tan(theta) * math.cos(phi)), abs=1e-14)
    assert features[3] == pytest.approx(math.atan(-math.tan(theta) * math.sin(phi)), abs=1e-14)


def _with_up_axis(up: np.ndarray) -> np.ndarray:
    """Any rotation whose z axis is -up (the approach direction)."""
    z = -up / np.linalg.norm(up)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


@pytest.mark.parametrize(
    "features",
    [
        [1e-4, -5e-5, 0.008, 0.03, -0.02],
        [0.0, 0.0, 0.002, 0.0, 0.035],
        [-2e-4, 1e-4, 0.01, -0.3, 0.2],
    ],
)
def test_pose_agrees_with_the_contact_models_slices_of_eq_5(features) -> None:
    """The peg posed by the features is the peg the contact model integrates over: its end
    face's lowest point at depth l cos(theta), and its axis at height s above that point at
    O_p(s) = (dx, dy) - (l/2 + r sin(theta) - s / cos(theta)) sin(theta) e (docs/contact-model.md).
    """
    dx, dy, depth, _, _ = features
    rotation, tip = pose_from_features(features, R, spin=0.4)
    up = -rotation[:, 2]
    cos_t, sin_t = up[2], math.hypot(up[0], up[1])
    lean = up[:2] / sin_t
    # The end face's rim, sampled finely: its lowest point.
    phi = np.linspace(0.0, 2.0 * math.pi, 200001)
    rim = tip[:, None] + R * (
        np.outer(rotation[:, 0], np.cos(phi)) + np.outer(rotation[:, 1], np.sin(phi))
    )
    lowest = rim[2].min()
    assert -lowest == pytest.approx(depth * cos_t, abs=1e-12)
    for s in (0.0, 0.3 * depth, depth * cos_t):
        # The axis point at height s above the lowest point.
        t = (lowest + s - tip[2]) / up[2]
        axis_point = tip[:2] + t * up[:2]
        expected = np.array([dx, dy]) - (depth / 2 + R * sin_t - s / cos_t) * sin_t * lean
        np.testing.assert_allclose(axis_point, expected, atol=1e-15)


def test_pointing_away_from_the_hole_is_refused() -> None:
    with pytest.raises(InputError, match=r"tilted 180\.0 deg"):
        features_from_pose(np.eye(3), [0, 0, 0], R)
    with pytest.raises(InputError, match="theta_x"):
        pose_from_features([0, 0, 0, 1.6, 0], R)


def _se3(features: np.ndarray, radius: float = R) -> np.ndarray:
    rotation, position = pose_from_features(features, radius)
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = rotation, position
    return t


def believed(true: np.ndarray, deviation: np.ndarray) -> np.ndarray:
    """Features in the believed hole of the peg at ``true`` features of the hole deviated by
    ``deviation``, by 4×4 products: T_HP = P(0) P(x_dev)^-1 P(x_true)."""
    t = _se3(np.zeros(5)) @ np.linalg.inv(_se3(deviation)) @ _se3(true)
    return features_from_pose(t[:3, :3], t[:3, 3], R)


deviations = st.tuples(offsets, offsets, st.floats(-0.06, 0.06), st.floats(-0.06, 0.06))


@settings(max_examples=200, deadline=None)
@given(deviations, offsets, offsets, depths, tilts, tilts)
def test_true_features_compose_the_deviated_hole(dev, dx, dy, depth, tx, ty) -> None:
    """The simulator's plant against the same composition by homogeneous matrices."""
    deviation = np.array([dev[0], dev[1], 0.0, dev[2], dev[3]])
    true = np.array([dx, dy, depth, tx, ty])
    in_believed = believed(true, deviation)
    np.testing.assert_allclose(true_features(in_believed, deviation, R)[0], true, atol=1e-15)
    # the peg at the believed features 0 has the true features x_dev
    np.testing.assert_allclose(true_features(np.zeros(5), deviation, R)[0], deviation,
                               atol=1e-15)  # fmt: skip


def test_the_filters_true_rows_are_the_plants_to_rounding() -> None:
    """true_rows_at (one pose in many holes, the tilts by vector_math.arctan) against the
    plant's exact true_features: offsets and depths to 1e-18 m, tilts to 1e-15 rad, over the
    deviation filter's prior (±0.1 mm, ±2°) and tilted poses."""
    rng = np.random.default_rng(4)
    dev = np.column_stack([rng.uniform(-1e-4, 1e-4, (2000, 2)), np.zeros(2000),
                           rng.uniform(-0.035, 0.035, (2000, 2))])  # fmt: skip
    frames, out = np.empty((6, 2000)), np.empty((5, 2000))
    hole_frames(dev, R, frames)
    for pose in ([0.0, 0.0, 0.0, 0.0, 0.0], [3e-5, -2e-5, 4e-3, 0.03, -0.02]):
        true_rows_at(np.array(pose), frames, R, R, out)
        out_rows = out.T
        exact = true_features(np.tile(pose, (2000, 1)), dev, R)
        np.testing.assert_allclose(out_rows[:, :3], exact[:, :3], rtol=0, atol=1e-18)
        np.testing.assert_allclose(out_rows[:, 3:], exact[:, 3:], rtol=0, atol=1e-15)
