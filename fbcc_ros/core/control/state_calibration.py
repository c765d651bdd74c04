"""The deviation filter's P(state) made to say how often it is right: its particles' vote per
plane raised to a power and normalised again (temperature scaling, Guo et al. 2017, "On
calibration of modern neural networks"),

.. math::
    p_s \\leftarrow p_s^{\\,a} \\big/ \\textstyle\\sum_{s'} p_{s'}^{\\,a},

which keeps the named state and moves only the probability stated for it.

An interference part's cloud stated its states too timidly: along the state study's insertions
(``scripts/studies/filter_along.py``, 16 a case at 0.184, 0.5 and 1 GPa, F/T under the hole),
those stated 0.7-0.9 were right 99 % of the time and those stated 0.5-0.7 84 %. Its power,
:data:`SHARPNESS`, is the one of least log-loss of the true state on seeds 2 and 3 (0.33 as a
temperature); checked on seeds 0, 5, 7 and 9 and at the wrist (``docs/boundary-mapping.md``).
A clearance's vote is left as it is: the same rule gives it 1.5, which on the other seeds
lowers the calibration error but raises the log-loss; its readout spread
(:data:`~fbcc_ros.core.control.deviation_filter.READOUT_SPREAD`) was chosen for its calibration.
"""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.arrays import FloatArray

#: The power of each fit's vote (a clearance's 1: left as it is).
SHARPNESS = {"clearance": 1.0, "interference": 3.0}


def calibrated(votes: FloatArray, fit: str) -> FloatArray:
    """``votes`` (..., 9), each row's P(state) summing to 1, of a part of the nominal ``fit``
    (``"clearance"`` or ``"interference"``), raised to its :data:`SHARPNESS` and normalised."""
    if fit not in SHARPNESS:
        raise ValueError(f"fit {fit!r}: expected one of {', '.join(SHARPNESS)}")
    power = SHARPNESS[fit]
    return votes if power == 1.0 else sharpened(votes, power)


def sharpened(votes: FloatArray, power: float) -> FloatArray:
    """``votes`` (..., 9) raised to ``power`` and normalised again, row by row."""
    sharp = np.power(votes, power)
    return sharp / sharp.sum(axis=-1, keepdims=True)  # type: ignore[no-any-return]
