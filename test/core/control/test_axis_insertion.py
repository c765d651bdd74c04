"""The laws' coordinates (fbcc_ros.core.control.axis_insertion): the depth in the hole's estimated
frame is the true depth of an aligned peg in a tilted hole, depth moves along the peg's axis,
and the estimate keeps the dither out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fbcc_ros.core.contact.features import pose_from_features
from fbcc_ros.core.control.axis_insertion import AXIS_TIME_CONSTANT, AxisInsertion
from test.core.contact.test_features import R, believed

DT = 1e-3


def _settled(axis: AxisInsertion, pose: np.ndarray) -> np.ndarray:
    """The law's coordinates of a peg held at ``pose`` (1, 5) for 20 time constants."""
    for _ in range(round(20 * AXIS_TIME_CONSTANT / DT)):
        rows = axis.measured(pose, DT)
    return rows


@pytest.mark.parametrize("tilts", [(0.0, 0.0349066), (-0.0349066, 0.0), (0.02, -0.03)])
def test_an_aligned_peg_reads_its_true_depth_in_a_tilted_hole(tilts: tuple[float, float]) -> None:
    """The hole tilted by up to 2° in either plane and displaced by 50 µm: once the estimate
    has settled, λ is the true depth to 1 nm; command and measurement are inverses."""
    deviation = np.array([5e-5, -3e-5, 0.0, *tilts])
    for depth in (0.002, 0.01):
        pose = believed(np.array([2e-6, -1e-6, depth, 0.0, 0.0]), deviation)[None]
        axis = AxisInsertion(R)
        axis.reset(np.zeros((1, 5)))
        rows = _settled(axis, pose)
        assert rows[0, 2] == pytest.approx(depth, abs=1e-9)
        assert abs(pose[0, 2] - depth) > 0.1 * 2 * R * math.hypot(*tilts)  # l itself is not
        moved = rows + np.array([1e-6, -2e-6, 1e-4, 1e-3, -2e-3])
        np.testing.assert_allclose(axis.measured(axis.command(moved), 0.0), moved, atol=1e-12)


def test_the_residual_misalignment_errs_by_at_most_about_2r_delta() -> None:
    """A peg tilted by delta within the true hole (tilted 2°): the estimate takes the peg's
    axis for the hole's, and λ errs by at most about 2 r |delta|, a bound it reaches."""
    deviation = np.array([3e-5, -2e-5, 0.0, 0.0, math.radians(2.0)])
    for delta in (1e-3, 5e-3):
        errors = []
        for signed in (delta, -delta):
            for tilt in ([signed, 0.0], [0.0, signed]):  # across and within the hole's tilt
                pose = believed(np.array([1e-5, 0.0, 0.008, *tilt]), deviation)[None]
                axis = AxisInsertion(R)
                axis.reset(np.zeros((1, 5)))
                errors.append(abs(_settled(axis, pose)[0, 2] - 0.008))
        assert 0.9 * 2 * R * delta < max(errors) < 1.1 * 2 * R * delta, (delta, errors)


def test_an_untilted_aligned_peg_is_unchanged() -> None:
    x = np.array([[1e-5, -2e-5, 0.007, 0.0, 0.0]])
    axis = AxisInsertion(R)
    np.testing.assert_array_equal(axis.reset(x), x)
    np.testing.assert_array_equal(axis.measured(x, DT), x)
    np.testing.assert_array_equal(axis.command(x), x)


def test_depth_moves_the_peg_along_its_own_axis() -> None:
    """Advancing the commanded λ at fixed lateral coordinates moves the tilted peg rigidly by
    that much along its axis (tip and all), however the hole is estimated."""
    start = np.array([[2e-5, -1e-5, 0.003, 0.02, -0.03]])
    axis = AxisInsertion(R)
    axis.reset(np.zeros((1, 5)))
    rows = _settled(axis, start)
    before = axis.command(rows)
    rows[0, 2] += 1e-3
    after = axis.command(rows)
    (rot0, tip0), (rot1, tip1) = (pose_from_features(x[0], R) for x in (before, after))
    np.testing.assert_allclose(rot1, rot0, atol=1e-15)
    upward = -rot0[:, 2]
    np.testing.assert_allclose(tip1 - tip0, -1e-3 * upward, atol=1e-12)
    # and back: the drift is a path integral that returns with the depth
    rows[0, 2] -= 1e-3
    np.testing.assert_allclose(axis.command(rows), before, atol=1e-15)


def test_the_estimate_keeps_the_tilt_dither_out() -> None:
    """The law dithers its tilts (0.2 mrad at about 300 rad/s): the hole's estimate moves by
    less than a tenth of that, and the aligned peg's λ by less than 0.2 µm (a tenth of the
    2 r |θ| it would move if the estimate followed the tilt)."""
    axis = AxisInsertion(R)
    pose = np.array([[0.0, 0.0, 0.005, 0.0, 0.0]])
    axis.reset(pose)
    lam = []
    for k in range(2000):
        dithered = pose.copy()
        dithered[0, 4] = 2e-4 * math.sin(300.0 * k * DT)
        lam.append(axis.measured(dithered, DT)[0, 2])
        if k >= 1000:
            assert abs(axis.hole_tilts[0, 1]) < 2e-5
    assert np.ptp(lam[1000:]) < 0.1 * 2 * R * 2e-4
