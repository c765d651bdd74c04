"""A brute-force quadrature of eq. (5)-(13), written literally and independently of contact.py.

Midpoint rule on a fine (s, alpha) grid; the paper's variables (theta, phi) are used directly.
Slow by design: it is the yardstick for the fast model, not a second implementation to ship.
"""

from __future__ import annotations

import math

import numpy as np

from fbcc_ros.core.contact.model import PegHole


def reference_response(ph: PegHole, features, n_s: int = 1200, n_alpha: int = 2400) -> np.ndarray:
    dx, dy, l, thx, thy = (float(v) for v in features)
    R, r, mu, k, L, H = (
        ph.hole_radius,
        ph.peg_radius,
        ph.friction,
        ph.stiffness,
        ph.hole_depth,
        ph.base_thickness,
    )
    # Total tilt theta and lean direction phi from the projected tilts (eq. 3, right-hand theta_x).
    theta = math.atan(math.hypot(math.tan(thy), math.tan(thx)))
    phi = math.atan2(-math.tan(thx), math.tan(thy))
    s_u = l * math.cos(theta)
    s_l = max(0.0, s_u - L)
    if s_u <= s_l:
        return np.zeros(5)
    ds = (s_u - s_l) / n_s
    s = s_l + (np.arange(n_s) + 0.5) * ds
    da = 2 * math.pi / n_alpha
    alpha = -math.pi + (np.arange(n_alpha) + 0.5) * da
    S, A = np.meshgrid(s, alpha, indexing="ij")
    # eq. (5)
    lever5 = l / 2 + r * math.sin(theta) - S / math.cos(theta)
    opx = dx - lever5 * math.sin(theta) * math.cos(phi)
    opy = dy - lever5 * math.sin(theta) * math.sin(phi)
    # eq. (7) rotated by phi: point q on the ray, in ellipse axes (u along phi, v across)
    cu, su_ = math.cos(phi), math.sin(phi)
    dux = np.cos(A) * cu + np.sin(A) * su_
    dvx = -np.cos(A) * su_ + np.sin(A) * cu
    ou = opx * cu + opy * su_
    ov = -opx * su_ + opy * cu
    c2 = math.cos(theta) ** 2
    qa = dux**2 * c2 + dvx**2
    qb = dux * ou * c2 + dvx * ov
    qc = ou**2 * c2 + ov**2 - r**2
    disc = qb**2 - qa * qc
    og = np.where(disc >= 0, (qb + np.sqrt(np.maximum(disc, 0))) / qa, 0.0)
    # eq. (8)
    p = np.where(og >= R, k * (og - R) / R, 0.0)
    dA = R * da * ds
    # eq. (9)-(13); Mx with the right-hand sign (DESIGN §5), lever for the hole-bottom point.
    assert ph.acting_point == "hole_bottom"
    lever = L + H - s_u + S + mu * R
    fx = np.sum(p * np.cos(A)) * dA
    fy = np.sum(p * np.sin(A)) * dA
    ff = np.sum(mu * p) * dA
    mx = -np.sum(lever * p * np.sin(A)) * dA
    my = np.sum(lever * p * np.cos(A)) * dA
    return np.array([fx, fy, ff, mx, my])
