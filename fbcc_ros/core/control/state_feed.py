"""What the contact-state filter (:mod:`fbcc_ros.core.control.deviation_filter`) is handed of
an insertion, the same offline (``deviation_filter.along``, ``fbcc-report``) and online (the
controller's :mod:`fbcc_ros.pipeline.state_worker`).

One update of the filter costs 0.7-3 ms, so it is updated at every n-th sample (200 Hz at
1 kHz) and handed the mean of the n samples since its last update: the sensor's noise on an
update falls by √n, where one sample in n would waste the others. The likelihood is taken at
the window's mean features, the state read at the last sample's: the law's dither carries the
peg across a state's band within a window. ``docs/boundary-mapping.md`` has what each does to
the share named right, and the windows tried instead of the mean of every one.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.segmentation import FZ_MIN
from fbcc_ros.core.errors import ConfigError


class FeedSample(NamedTuple):
    """What the filter is handed at an update (:class:`StateFeed`): the mean compensated
    response (5,) and the mean measured features (5,) of the samples since the last update, and
    the features of the last of them (5,), where the state is read."""

    response: FloatArray
    features: FloatArray
    now: FloatArray


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
        self._sum = np.zeros(10)  # Σ (features, response) since the last update
        self._count = 0
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
        self._sum[:5] += f
        self._sum[5:] += w
        self._count += 1
        take = self._periods % self.every == 0
        self._periods += 1
        if not take:
            return None
        mean = self._sum / self._count
        self._sum[:] = 0.0
        self._count = 0
        self.sent += 1
        return FeedSample(mean[5:], mean[:5], f.copy())

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
