"""The phases of an insertion, one name each for the laws, the supervisor, the topics and the
bags (``fbcc/phase`` carries the value, with the reason after a colon).

``idle`` (nothing commanded) → ``start`` → ``inserting`` → ``inserted`` (the depth ramp reached
L; the law keeps adjusting); ``force_limit`` (Algorithm 1's stop), ``aborted`` and ``fault`` end
an insertion and hold the last command. A law reports only the three of a running insertion
(:data:`LAW_PHASES`); the supervisor adds the others.
"""

from __future__ import annotations

import enum


class Phase(enum.StrEnum):
    IDLE = "idle"
    INSERTING = "inserting"
    INSERTED = "inserted"
    FORCE_LIMIT = "force_limit"
    ABORTED = "aborted"
    FAULT = "fault"


#: The phases in which the controller commands motion.
ACTIVE = (Phase.INSERTING, Phase.INSERTED)
#: What a law reports for each trial.
LAW_PHASES = (Phase.INSERTING, Phase.INSERTED, Phase.FORCE_LIMIT)
