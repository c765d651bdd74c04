"""The paper's numbers, in one place: Table I's gains, Table II's measured diameters, the pairs
of Section IV and the stiffness calibrated to Section V.C, and the cell dimensions the paper does
not give (chosen here, and said so).
"""

from __future__ import annotations

import math
from typing import Any

from fbcc_ros.core.contact.model import PegHole, lame_stiffness

#: Table I of the paper: (M_dp, K_dp, M_do, K_do, M_dl, K_dl) per label; D_d = sqrt(M_d K_d).
TABLE_I: dict[int, tuple[float, float, float, float, float, float]] = {
    1: (1e5, 1e7, 1e1, 1e3, 1e10, 1e12),
    2: (1e4, 1e6, 1e0, 1e2, 1e10, 1e12),
    3: (1e4, 1e6, 1e1, 1e3, 1e10, 1e12),
    4: (1e4, 1e6, 1e2, 1e4, 1e10, 1e12),
    5: (1e3, 1e5, 1e-1, 1e1, 1e10, 1e12),
}

#: Measured diameters of Table II [mm]: (peg, hole) per group.
TABLE_II_DIAMETERS_MM = (
    ((10.037, 10.031, 10.041, 10.035, 10.029), (10.033, 10.031, 10.027, 10.032, 10.031)),
    ((10.113, 10.056, 10.047, 10.072, 10.097), (10.149, 10.135, 10.145, 10.155, 10.156)),
    ((10.044, 10.050, 10.043, 10.050, 10.044), (10.021, 10.019, 10.018, 10.011, 10.018)),
)

#: Hole depth L, base thickness H [m], friction (ABS on ABS) and outer radius factor b/R used by
#: the demos: L = 10 mm is the paper's final insertion depth; H and b are not given in the paper.
DEMO_DEPTH = 10e-3
DEMO_BASE = 5e-3
DEMO_FRICTION = 0.3
DEMO_OUTER_FACTOR = 2.0


def paper_pair(fit: str, nominal_radius: float = 5e-3) -> PegHole:
    """The simulated pairs of Section IV: R 5.05 / r 5.04 mm (clearance), R 5.03 / r 5.04 mm
    (interference), shifted to another nominal radius as in Section IV.C."""
    shift = nominal_radius - 5e-3
    radii = {"clearance": (5.05e-3, 5.04e-3), "interference": (5.03e-3, 5.04e-3)}
    if fit not in radii:
        raise ValueError(f"fit={fit!r} is not allowed: expected one of {sorted(radii)}")
    hole, peg = (x + shift for x in radii[fit])
    k = lame_stiffness(hole, DEMO_OUTER_FACTOR * hole)
    return PegHole(hole, peg, DEMO_DEPTH, DEMO_BASE, DEMO_FRICTION, k)


#: k of eq. (8) [Pa] calibrated to the paper's own measurement (Section V.C): Fz ~ 50 N at 10 mm
#: for Table II group 3 (radial interference 14.4 um) with mu = 0.3 gives
#: k = Fz / (mu 2 pi delta l) = 1.84e8 Pa. The scenarios of config/scenarios use it.
PAPER_STIFFNESS = 1.84e8


def paper_scenario(fit: str, law: str = "fbcc", nominal_radius: float = 5e-3) -> dict[str, Any]:
    """The Section IV scenario (dx = dy = 0.05 mm, theta_x = theta_y = 2°, L = 10 mm) with the
    calibrated stiffness, as a scenario mapping (the shape of config/scenarios/*.yaml)."""
    ph = paper_pair(fit, nominal_radius)
    tilt = math.radians(2.0)
    return {
        "geometry": {"hole_radius": ph.hole_radius, "peg_radius": ph.peg_radius,
                     "hole_depth": ph.hole_depth, "base_thickness": ph.base_thickness,
                     "friction": ph.friction, "stiffness": PAPER_STIFFNESS},
        "controller": {"type": law},
        "initial": {"dx": 5e-5, "dy": 5e-5, "theta_x": tilt, "theta_y": tilt},
        "insertion": {"depth": DEMO_DEPTH, "speed": 5e-3},
    }  # fmt: skip
