"""What the contact-state filter (:mod:`fbcc_ros.core.control.deviation_filter`) is handed of
an insertion, the same offline (``deviation_filter.along``, ``fbcc-report``) and online (the
controller's :mod:`fbcc_ros.pipeline.state_worker`).

One update of the filter costs 0.3-1.4 ms, so it is updated at every n-th sample (200 Hz at
1 kHz) and handed the mean response of the n samples since its last update, with their
features: the sensor's noise on an update falls by √n, where one sample in n would waste the
others. The likelihood is taken at the window's mean features, the state read at the last
sample's: the law's dither carries the peg across a state's band within a window.

The mean response of a window is not the response at its mean features: the contact model is
not linear in them, and the dither moves the peg by about a band within a window.
:func:`window_gap` is that difference for one hole. The filter takes it for its cloud's weighted
mean particle and adds it to every particle's prediction, in proportion to the particle's Fz,
where that particle's part is an interference fit and it touches at every sample of the window.
A peg in an interference touches all around, every particle alike, and its response is smooth
in the features. In a clearance the peg touches one wall, or none, each particle its own at its
own place: across a contact's edge the mean particle's gap says nothing of another's, and
carried to the clearance's particles the gap lost more insertions than it saved.
``docs/boundary-mapping.md`` has what each does to the share named right, and the windows tried
instead of the mean of every one.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import true_features
from fbcc_ros.core.contact.model import ContactBatch
from fbcc_ros.core.contact.segmentation import FZ_MIN
from fbcc_ros.core.errors import ConfigError


class FeedSample(NamedTuple):
    """What the filter is handed at an update (:class:`StateFeed`): the mean compensated
    response (5,) of the samples since the last update and their measured features (n, 5)."""

    response: FloatArray
    window: FloatArray

    @property
    def features(self) -> FloatArray:
        """The window's mean features (5,), where the likelihood is taken."""
        return self.window.mean(axis=0)  # type: ignore[no-any-return]

    @property
    def now(self) -> FloatArray:
        """The last sample's features (5,), where the state is read."""
        return self.window[-1]


class StateFeed:
    """At every ``every``-th sample from the first in contact (Fz over
    :data:`~fbcc_ros.core.contact.segmentation.FZ_MIN`) or in the hole, what the filter is
    handed (:class:`FeedSample`; module doc)."""

    def __init__(self, every: int) -> None:
        if every < 1:
            raise ConfigError("every", every, "a row count >= 1")
        self.every = int(every)
        self.start_insertion()

    def start_insertion(self) -> None:
        self._touched = False
        self._periods = 0
        self._sum = np.zeros(5)  # Σ response since the last update
        self._rows: list[FloatArray] = []  # their features
        #: samples handed over this insertion
        self.sent = 0

    def take(self, features: ArrayLike, response: ArrayLike) -> FeedSample | None:
        """This sample's features and response (both (5,)); what the filter is handed now, or
        None."""
        f, w = np.asarray(features, dtype=float), np.asarray(response, dtype=float)
        if not self._touched:
            if not (w[2] > FZ_MIN or f[2] > 0):
                return None
            self._touched = True
        self._sum += w
        self._rows.append(f.copy())
        take = self._periods % self.every == 0
        self._periods += 1
        if not take:
            return None
        sample = FeedSample(self._sum / len(self._rows), np.array(self._rows))
        self._sum[:] = 0.0
        self._rows = []
        self.sent += 1
        return sample

    def samples(self, features: FloatArray,
                responses: FloatArray) -> tuple[np.ndarray, list[FeedSample]]:  # fmt: skip
        """Of a recorded insertion (features and responses, both (T, 5)): the rows at which the
        filter is updated, and what it is handed there."""
        rows, handed = [], []
        for k in range(len(features)):
            if (sample := self.take(features[k], responses[k])) is not None:
                rows.append(k)
                handed.append(sample)
        return np.array(rows, dtype=int), handed


def window_gap(window: FloatArray, deviation: FloatArray, pair: FloatArray, peg_top: bool,
               n_angles: int, peg_radius: float) -> tuple[FloatArray, FloatArray]:
    """Of a hole at ``deviation`` (5,) and the contact model's pair ``pair`` (TABLE_ROWS, 1,
    :class:`~fbcc_ros.core.contact.model.ContactBatch`'s table): the mean response over the
    measured features ``window`` (n, 5) less the response at their mean, (5,), and the
    responses at each row and at the mean, (n + 1, 5) (module doc):

    .. math::
        \\bar h - h(\\bar x) = \\frac{1}{n}\\sum_i h(x_i) - h\\Big(\\frac{1}{n}\\sum_i x_i\\Big).
    """
    rows = np.vstack([window, window.mean(axis=0)])
    x = true_features(rows, deviation, peg_radius)
    np.maximum(x[:, 2], 0.0, out=x[:, 2])  # above the hole: at its top face
    h = ContactBatch(pair, peg_top, n_angles).response(x)
    return h[:-1].mean(axis=0) - h[-1], h
