"""What every node's process does before anything heavy is imported: SIGINT and SIGTERM are
taken (a Ctrl-C while the modules load, or while a node waits for its robot model, ends the
process cleanly, not with a KeyboardInterrupt), and its DDS participant gets a short lease
(``fastdds.xml``: a process that dies without a goodbye leaves the graph within 3 s).

The nodes' console scripts and ``python -m fbcc_ros.nodes NODE`` come here first; the node
module is imported after.
"""

from __future__ import annotations

import importlib
import os
import signal
from pathlib import Path

#: The Fast DDS profile our nodes' participants use unless the user names one of their own.
LEASE_PROFILE = Path(__file__).with_name("fastdds.xml")
#: The environment variable Fast DDS reads its default profile from.
PROFILE_VARIABLE = "FASTRTPS_DEFAULT_PROFILES_FILE"
#: How long a node stopping while it moves the arm waits for its hold to be acknowledged by
#: its subscribers [s] (reliable QoS; a subscriber already gone is not waited for longer).
ACKED_WITHIN = 0.2
#: The signals that end a node cleanly.
SIGNALS = (signal.SIGINT, signal.SIGTERM)

_stop: list[int] = []
_caught = False


class StopSignalError(Exception):
    """A node's start-up was ended by SIGINT or SIGTERM (its process exits 0)."""


def catch_signals() -> list[int]:
    """From now on SIGINT and SIGTERM are noted, not raised (idempotent). Returns the list the
    signals are appended to: a node's loop ends between callbacks when it is not empty."""
    global _caught
    if not _caught:
        for sig in SIGNALS:
            signal.signal(sig, lambda number, _: _stop.append(number))
        _caught = True
    return _stop


def stopping() -> bool:
    """Whether SIGINT or SIGTERM came since :func:`catch_signals`."""
    return bool(_stop)


def short_lease(environ: dict[str, str] | os._Environ[str] = os.environ) -> None:
    """Our participant profile, unless the user set one (theirs is left alone)."""
    environ.setdefault(PROFILE_VARIABLE, str(LEASE_PROFILE))


def start(node: str) -> None:
    """Runs ``fbcc_ros.nodes.<node>``'s ``main()`` with the signals caught first."""
    catch_signals()
    short_lease()
    module = importlib.import_module(f"fbcc_ros.nodes.{node}")
    if stopping():
        raise SystemExit(0)
    module.main()


def _entry(node: str):  # type: ignore[no-untyped-def]
    def main() -> None:
        start(node)

    main.__name__ = node
    return main


#: The nodes run this way (``fbcc_replay`` is a command-line tool).
NODES = ("dynamic_compensation", "kinematics", "fbcc_controller", "mock_cell", "fbcc_record")
dynamic_compensation = _entry("dynamic_compensation")
kinematics = _entry("kinematics")
fbcc_controller = _entry("fbcc_controller")
mock_cell = _entry("mock_cell")
fbcc_record = _entry("fbcc_record")
