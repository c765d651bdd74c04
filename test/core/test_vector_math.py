"""The deviation filter's libm-free functions (core/vector_math.py) against libm."""

from __future__ import annotations

import math

import numba
import numpy as np

from fbcc_ros.core.vector_math import TAIL, arctan, normal_cdf


@numba.njit(cache=True)  # type: ignore[misc]
def _each(f, x):  # type: ignore[no-untyped-def]
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        out[i] = f(x[i])
    return out


def test_normal_cdf_is_libms_to_2e15_and_exact_in_its_tails() -> None:
    z = np.concatenate([np.linspace(-10.0, 10.0, 400_001), [-TAIL, TAIL, 0.0, -0.0]])
    exact = np.array([0.5 * math.erfc(-v / math.sqrt(2.0)) for v in z])
    phi = _each(normal_cdf, z)
    assert np.abs(phi - exact).max() < 2e-15
    assert (phi[z < -TAIL] == 0.0).all() and (phi[z > TAIL] == 1.0).all()
    assert (np.diff(phi[:400_001]) >= -4e-15).all()  # monotone, to twice the error
    assert np.isnan(_each(normal_cdf, np.array([math.nan]))).all()


def test_arctan_is_within_2_ulp_of_libms() -> None:
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-3.0, 3.0, 200_000), 10.0 ** rng.uniform(-300, 300, 50_000),
                        -(10.0 ** rng.uniform(-300, 300, 50_000)),
                        [0.0, -0.0, 0.66, 2.414213562373095, math.inf, -math.inf]])  # fmt: skip
    exact = np.array([math.atan(v) for v in x])
    ulps = np.abs(_each(arctan, x) - exact) / np.spacing(np.abs(exact))
    assert np.nanmax(ulps) <= 2.0
    assert math.copysign(1.0, _each(arctan, np.array([-0.0]))[0]) == -1.0
