"""Whether the controller sees the lateral forces it corrects with.

The boundary mapping reads the lateral response (Fx, Fy, Mx, My) against the axial force; a dead
band in the wrench's path (ours, ``deadband``, or the source's: the LBR stack's estimated wrench
zeroes every component under 2 N and 0.5 N·m) can hide all of it, and the law then corrects
nothing while it pushes in. Such a band leaves exact zeros, which no sensor's noise does: while
the peg is in contact (an axial force over :data:`CONTACT_FORCE`), the share of samples in which
a lateral component is exactly zero says it, component by component.

Before a run, :func:`deadband_warning` compares a dead band with the lateral forces an insertion
must still read at its end: it ends aligned with at most :data:`RESOLVE_FORCE` of lateral force
(the goal of the robust law's studies, ``docs/reproduction.md``), and a moment of that force
over the peg's radius; a band over either hides the last of the alignment. The LBR stack's
estimate (2 N, 0.5 N·m) is 4 and 100 times over them for a 10 mm peg, and its rehearsal does not
assemble (``docs/integration.md``).

While inserting, a blind window faults the controller (:class:`~fbcc_ros.pipeline.controller.
ControllerStage`): a law that cannot see the lateral forces pushes the peg in against them (with
a band of 200 N the robust law reached the depth with 200 N of lateral load it never saw).
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


#: The lateral force an insertion ends with, at most [N]: what a dead band must stay under.
RESOLVE_FORCE = 0.5


def deadband_warning(band: tuple[float, float], radius: float | None, where: str) -> str:
    """What a dead band of ``band`` (force [N], moment [N·m]) on the wrench ``where`` hides,
    or ``""``: a force band over :data:`RESOLVE_FORCE`, a moment band over that force at the
    peg's ``radius`` [m] (not judged without it)."""
    force, moment = band
    over = []
    if force > RESOLVE_FORCE:
        over.append(f"{force:g} N > {RESOLVE_FORCE:g} N")
    if radius is not None and moment > RESOLVE_FORCE * radius:
        over.append(f"{moment:g} N·m > {RESOLVE_FORCE * radius:.3g} N·m "
                    f"({RESOLVE_FORCE:g} N at the peg's radius {radius * 1e3:g} mm)")  # fmt: skip
    if not over:
        return ""
    return (f"the dead band of {where} ({'; '.join(over)}) hides the lateral forces an "
            "insertion ends with: the law cannot align the peg below it")


class LateralWatch:
    """Counts, over each :data:`WINDOW` contact samples, those in which each lateral component
    is exactly zero; :meth:`warning` names the components zero in more than
    :data:`BLIND_SHARE` of the last full window."""

    def __init__(self) -> None:
        self._contact = 0
        self._zeros = np.zeros(4, dtype=int)
        #: the share of exact zeros of Fx, Fy, Mx, My in the last full window (None before)
        self.blind_share: FloatArray | None = None

    def sample(self, response: FloatArray) -> bool:
        """One response ``(Fx, Fy, Fz, Mx, My)`` the law takes; whether it completed a window
        in which a lateral component was blind (:meth:`warning` says which)."""
        if abs(response[2]) <= CONTACT_FORCE:
            return False
        self._contact += 1
        self._zeros += response[LATERAL] == 0.0
        if self._contact < WINDOW:
            return False
        self.blind_share = self._zeros / WINDOW
        self._contact = 0
        self._zeros[:] = 0
        return bool((self.blind_share > BLIND_SHARE).any())

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
