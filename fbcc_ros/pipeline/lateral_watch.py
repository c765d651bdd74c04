"""Whether the controller sees the lateral forces it corrects with.

The boundary mapping reads the lateral response (Fx, Fy, Mx, My) against the axial force; a dead
band in the wrench's path (ours, ``deadband``, or the source's: the LBR stack's estimated wrench
zeroes every component under 2 N and 0.5 N·m) can hide all of it, and the law then corrects
nothing while it pushes in. Such a band leaves exact zeros, which no sensor's noise does: while
the peg is in contact (an axial force over :data:`CONTACT_FORCE`), the share of samples in which
a lateral component is exactly zero says it, component by component.
"""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.arrays import FloatArray

#: An axial force no sensor's noise reaches at rest [N]: the peg is in contact.
CONTACT_FORCE = 5.0
#: Contact samples judged together.
WINDOW = 100
#: The share of them with a component exactly zero that is reported.
BLIND_SHARE = 0.5
#: The lateral components of a response (Fx, Fy, Fz, Mx, My), and their names.
LATERAL = [0, 1, 3, 4]
NAMES = ("Fx", "Fy", "Mx", "My")


class LateralWatch:
    """Counts, over each :data:`WINDOW` contact samples, those in which each lateral component
    is exactly zero; :meth:`warning` names the components zero in more than
    :data:`BLIND_SHARE` of the last full window."""

    def __init__(self) -> None:
        self._contact = 0
        self._zeros = np.zeros(4, dtype=int)
        #: the share of exact zeros of Fx, Fy, Mx, My in the last full window (None before)
        self.blind_share: FloatArray | None = None

    def sample(self, response: FloatArray) -> None:
        """One response ``(Fx, Fy, Fz, Mx, My)`` the law takes."""
        if abs(response[2]) <= CONTACT_FORCE:
            return
        self._contact += 1
        self._zeros += response[LATERAL] == 0.0
        if self._contact == WINDOW:
            self.blind_share = self._zeros / WINDOW
            self._contact = 0
            self._zeros[:] = 0

    def warning(self) -> str:
        """What is wrong, or ``""``."""
        if self.blind_share is None or not (self.blind_share > BLIND_SHARE).any():
            return ""
        hidden = ", ".join(f"{name} in {share:.0%}"
                           for name, share in zip(NAMES, self.blind_share, strict=True)
                           if share > BLIND_SHARE)  # fmt: skip
        return (f"lateral components read exactly 0 in contact ({hidden} of the samples): a "
                "dead band (deadband, or the wrench source's own) hides the forces the law "
                "corrects with")
