"""The phases of an insertion, one name each for the laws, the supervisor, the topics and the
bags (``fbcc/phase`` carries the value, with the reason after a colon).

``idle`` (nothing commanded, or not ready) ⇄ ``armed`` (a ``start`` would be accepted: recent
features and compensated wrench, nothing to acknowledge) → ``start`` → ``inserting`` →
``inserted`` (the depth ramp reached L; the law keeps adjusting); ``force_limit`` (Algorithm 1's
stop), ``aborted`` and ``fault`` end an insertion and hold (a fault or a force limit where the
arm is measured: the *holding* states, with the reason). After ``force_limit`` or ``fault`` a
new ``start`` is refused until ``reset`` acknowledges it (back to ``idle`` or ``armed``); after
``aborted`` (and ``inserted``, once aborted) a new insertion may start at once. A law reports
only the three of a running insertion (:data:`LAW_PHASES`); the supervisor adds the others.
"""

from __future__ import annotations

import enum


class Phase(enum.StrEnum):
    IDLE = "idle"
    ARMED = "armed"
    INSERTING = "inserting"
    INSERTED = "inserted"
    FORCE_LIMIT = "force_limit"
    ABORTED = "aborted"
    FAULT = "fault"


#: The phases in which the controller commands motion.
ACTIVE = (Phase.INSERTING, Phase.INSERTED)
#: The phases of no insertion yet, or since a reset: ``armed`` when a start would be accepted.
WAITING = (Phase.IDLE, Phase.ARMED)
#: The phases a ``start`` is refused from until ``reset`` acknowledges them.
NEEDS_RESET = (Phase.FORCE_LIMIT, Phase.FAULT)
#: What a law reports for each trial.
LAW_PHASES = (Phase.INSERTING, Phase.INSERTED, Phase.FORCE_LIMIT)
