"""The robust law's loop gain k / k̂ on interference parts (docs/reproduction.md, "The margin
as it runs"): the contact model's finite-difference slope of the dx and theta_x rows over the
stiffness the law uses, at 5, 7.5 and 10 mm and 0.5 s after the depth is reached. The parts: 0.2
µm of interference, mu 0.2, offsets 20/-10 µm, tilts 0.23°/-0.17°; an ideal robot (the pose is
the command) and the default sensor noise; the law knows only the nominal clearance pair.

    .venv/bin/python scripts/studies/identification_gain.py
"""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import apply_direction
from fbcc_ros.core.control.robust import RobustFbcc
from fbcc_ros.core.control.robust_params import RobustParams

NOMINAL = PegHole(5.05e-3, 5.04e-3, 0.01, 0.005, 0.3, 1.84e8)
SAMPLES = (1000, 1500, 2000, 2500)  # steps at 1 kHz


def slope(ph: PegHole, x: np.ndarray, f: int, h: float) -> float:
    """d (A(l) F)_f / d x_f of the true contact, A from the nominal pair (as the law has it)."""
    a, b = x.copy(), x.copy()
    a[f] += h
    b[f] -= h
    u = [apply_direction(ph.response(p)[None], np.array([x[2]]), NOMINAL)[0, f] for p in (a, b)]
    return float((u[0] - u[1]) / (2 * h))


def main() -> None:
    rng = np.random.default_rng(0)
    noise = np.array(RobustParams().sensor_noise)
    print("k [GPa]  depth [mm]: k/k̂ of dx, theta_x")
    for k in (1e8, 1e9, 1e10, 4e10):
        ph = PegHole(5.0398e-3, 5.04e-3, 0.01, 0.005, 0.2, k)
        law = RobustFbcc(NOMINAL, RobustParams())
        x = np.array([2e-5, -1e-5, 0.0, 0.004, -0.003])
        law.reset(x)
        cells = []
        for n in range(SAMPLES[-1] + 1):
            x = law.step(ph.response(x) + noise * rng.standard_normal(5), x, 1e-3)
            if n in SAMPLES:
                used = law.estimate().stiffness
                cells.append(f"{x[2] * 1e3:4.1f}: {slope(ph, x, 0, 1e-9) / used[0]:.2f}, "
                             f"{slope(ph, x, 3, 1e-7) / used[2]:.2f}")  # fmt: skip
        print(f"{k / 1e9:7.1f}  " + " | ".join(cells))


if __name__ == "__main__":
    main()
