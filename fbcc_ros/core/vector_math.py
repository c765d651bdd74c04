"""Functions for the deviation filter's compiled loops over particles, in arithmetic alone: a
libm call (``erfc``, ``atan2``, ~10-20 ns) is most of such a loop's time, and a loop that makes
one does not vectorise. The contact model and the plant keep libm's, so that their results
reproduce to the bit.

- :func:`normal_cdf`, Φ(z): a table of Φ and its density φ on a grid, with cubic Hermite
  interpolation between its nodes (arithmetic and table look-ups, which AVX-512 gathers eight
  rows at a time). Its error is under ``h^4 max|Φ''''| / 384`` with h the grid step: under
  2e-15 at h = 1/1024. Beyond ±:data:`TAIL` deviations Φ is exactly 0 or 1 (under 1e-18 off).
- :func:`arctan`: Cephes' rational approximation (S. Moshier, ``atan.c``) on the argument
  reduced to [0, 0.66], within 2 ulp of libm's.

``test/core/test_vector_math.py`` pins both against libm.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Beyond this many deviations Φ is exactly 0 or 1.
TAIL = 9.0
#: Nodes per unit of z.
PER_UNIT = 1024
_Z = np.arange(-TAIL * PER_UNIT, TAIL * PER_UNIT + 1) / PER_UNIT
#: Φ and h φ at the nodes (h φ: the derivative in the node's own unit, as Hermite needs it).
_PHI = np.array([0.5 * math.erfc(-z / math.sqrt(2.0)) for z in _Z])
_SLOPE = np.exp(-0.5 * _Z**2) / math.sqrt(2.0 * math.pi) / PER_UNIT


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def normal_cdf(z: float) -> float:
    """Φ(z), branch-free (selects), for loops that vectorise; NaN for NaN."""
    clipped = z if z > -TAIL else -TAIL  # NaN too: the look-ups stay within the table
    clipped = clipped if clipped < TAIL else TAIL
    u = (clipped + TAIL) * PER_UNIT  # in nodes from -TAIL
    k = min(int(u), _PHI.shape[0] - 2)
    s = u - k
    # cubic Hermite on [k, k + 1] with values Φ and slopes h φ at both ends
    s2, r2 = s * s, (1.0 - s) * (1.0 - s)
    value = (_PHI[k] * (1.0 + 2.0 * s) * r2 + _SLOPE[k] * s * r2
             + _PHI[k + 1] * s2 * (3.0 - 2.0 * s) + _SLOPE[k + 1] * s2 * (s - 1.0))  # fmt: skip
    value = 0.0 if z < -TAIL else (1.0 if z > TAIL else value)
    return value if z == z else z


#: Cephes' coefficients of atan(x) = x + x^3 P(x^2) / Q(x^2) on [0, 0.66].
_P = (-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
      -1.228866684490136173410e2, -6.485021904942025371773e1)  # fmt: skip
_Q = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
      4.853903996359136964868e2, 1.945506571482613964425e2)  # fmt: skip
_TAN_3PI_8 = 2.41421356237309504880
#: pi/2 less its double: the reductions add it back (half of it to pi/4)
_PI_2_LOW = 6.123233995736765886130e-17


@numba.njit(cache=True, error_model="numpy", inline="always")  # type: ignore[misc]
def arctan(x: float) -> float:
    """atan(x), branch-free (selects): reduced by atan(x) = pi/2 - atan(1/x) beyond
    tan(3 pi/8) and by atan(x) = pi/4 + atan((x - 1)/(x + 1)) beyond 0.66."""
    a = abs(x)
    far, mid = a > _TAN_3PI_8, (a > 0.66) & (a <= _TAN_3PI_8)
    base = math.pi / 2 if far else (math.pi / 4 if mid else 0.0)
    low = _PI_2_LOW if far else (0.5 * _PI_2_LOW if mid else 0.0)
    r = -1.0 / a if far else ((a - 1.0) / (a + 1.0) if mid else a)
    z = r * r
    p = (((_P[0] * z + _P[1]) * z + _P[2]) * z + _P[3]) * z + _P[4]
    q = ((((z + _Q[0]) * z + _Q[1]) * z + _Q[2]) * z + _Q[3]) * z + _Q[4]
    value = base + (r * z * p / q + r + low)
    return math.copysign(value, x)
