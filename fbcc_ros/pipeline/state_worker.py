"""The contact state online: the deviation filter
(:mod:`fbcc_ros.core.control.deviation_filter`) along the running insertion, in a process of its
own, fed at every n-th control period.

One update of the filter costs 0.3–1.4 ms (500–4000 particles): up to two 1 kHz periods. In the
controller's process it would hold the loop, since the interpreter runs one thread at a time.
So the filter runs in a child interpreter, scheduled from its first line only where the loop
leaves a core idle (:data:`LOWEST`: its start-up and its work yield to the loop), and the loop
only writes it what the feed hands over: a pickled frame of ~440 bytes on a pipe. The
pipes are non-blocking both ways: a frame under PIPE_BUF is written whole or not at all, so a
child that falls too far behind costs dropped samples (counted), never a blocked loop. The
child answers every sample, in order, with P(state) per plane. A sample comes every 5 ms; an
update takes about 1 ms until the cloud has converged (4000 particles) and 0.3 ms after (500),
so given a core the child keeps up, and on a busy machine it falls behind.

:class:`~fbcc_ros.core.control.state_feed.StateFeed` makes what it gets, as
:func:`~fbcc_ros.core.control.deviation_filter.along` makes it from the same insertion: at every
``every``-th period from the first one in contact or in the hole after the start, the mean
response of the periods since the last and their features. The filter is seeded, so both give the
same probabilities.
"""

from __future__ import annotations

import os
import pickle
import select
import struct
import subprocess
import sys
import time
from typing import Any, BinaryIO

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control.state_feed import FeedSample

#: What the child is sent besides samples: a new insertion.
_RESET = "reset"
#: The child's scheduling: only on a core the control loop leaves idle (Linux's SCHED_IDLE;
#: elsewhere the lowest niceness), since it answers late, not the loop. On this two-vCPU VM
#: it still costs the loop: with it running, the cell's p99 latency (recorder on) was 2.7-4.5
#: ms instead of 0.8-2.0 ms, at niceness 10 as at SCHED_IDLE (docs/nodes.md).
LOWEST = ("os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))"
          if hasattr(os, "SCHED_IDLE") else "os.nice(19)")  # fmt: skip
#: How long closing waits for the child before it is killed [s].
CLOSE_TIMEOUT = 2.0
#: How long a stopping controller waits for the answers still owed [s] (:meth:`StateWorker.drain`):
#: the child, idle-scheduled, gets the cores once the loop stops; on a two-core machine busy
#: with the whole cell it had answered none of ~800 samples when a 4 s insertion ended.
DRAIN_WITHIN = 10.0
#: The pipes' size [bytes]: ~4000 samples, 20 s of them at 200 Hz, where the default 64 KiB
#: held 1.3 s and a loaded machine's filter fell further behind than that in its first second
#: (samples were dropped).
PIPE_BYTES = 1 << 20
#: A frame: its length, then a pickle.
_LENGTH = struct.Struct("!I")


def _frame(item: Any) -> bytes:
    data = pickle.dumps(item, protocol=pickle.HIGHEST_PROTOCOL)
    return _LENGTH.pack(len(data)) + data


def _widen(fd: int) -> None:
    """Make a pipe hold :data:`PIPE_BYTES` where the system allows (Linux's F_SETPIPE_SZ;
    elsewhere, or above the system's limit, it keeps its size)."""
    try:
        import fcntl

        fcntl.fcntl(fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), PIPE_BYTES)
    except (ImportError, OSError):
        pass


def _read_exactly(stream: BinaryIO, n: int) -> bytes | None:
    data = b""
    while len(data) < n:
        chunk = stream.read(n - len(data))
        if not chunk:
            return None  # the parent closed the pipe
        data += chunk
    return data


def serve(inbox: BinaryIO, outbox: BinaryIO) -> None:
    """The child: the nominal pair and the filter's options first, then one filter per
    insertion and an answer per sample, until its input closes."""
    from fbcc_ros.core.control.deviation_filter import DeviationFilter

    def receive() -> Any:
        head = _read_exactly(inbox, _LENGTH.size)
        body = None if head is None else _read_exactly(inbox, _LENGTH.unpack(head)[0])
        return None if body is None else pickle.loads(body)

    def send(item: Any) -> None:
        outbox.write(_frame(item))
        outbox.flush()

    start = receive()
    if start is None:
        return
    nominal, options = start
    # compile (or load) the filter's kernels before the first sample comes
    DeviationFilter(nominal, particles=100, converged_particles=100).update(
        np.zeros(5), np.zeros((2, 5)))  # fmt: skip
    send(_RESET)  # ready
    filt = DeviationFilter(nominal, **options)
    while (item := receive()) is not None:
        if item == _RESET:
            filt = DeviationFilter(nominal, **options)
            continue
        insertion, stamp, sample = item  # FeedSample's response and window in one array
        send((insertion, stamp, filt.update(sample[:5], sample[5:].reshape(-1, 5))))


class StateWorker:
    """The deviation filter in a child process (module doc).

    Args:
        nominal: The controller's nominal pair.
        stiffness: The filter's range of the part's k [Pa] (default: the nominal k;
            :class:`~fbcc_ros.core.control.deviation_filter.DeviationFilter`).
    """

    def __init__(self, nominal: PegHole, stiffness: tuple[float, float] | None = None) -> None:
        # the lowest scheduling before anything is imported: the child's start-up yields to
        # the loop too; the answers go on a copy of stdout, and stdout itself to stderr, so
        # that nothing printed in the child can break a frame
        code = (f"import os; {LOWEST}; answers = os.fdopen(os.dup(1), 'wb'); "
                "os.dup2(2, 1); import sys; from fbcc_ros.pipeline.state_worker import serve; "
                "serve(sys.stdin.buffer, answers)")  # fmt: skip
        self._process = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, close_fds=True)  # fmt: skip
        assert self._process.stdin is not None and self._process.stdout is not None
        self._in, self._out = self._process.stdin.fileno(), self._process.stdout.fileno()
        for fd in (self._in, self._out):  # room for the backlog of the 4000-particle phase
            _widen(fd)
        #: what the child's filters are built with besides the nominal pair
        self.options = {} if stiffness is None else {"stiffness": tuple(stiffness)}
        os.write(self._in, _frame((nominal, self.options)))  # before non-blocking: whole
        os.set_blocking(self._in, False)
        os.set_blocking(self._out, False)
        self._buffer = b""
        self.ready = False  # the child has loaded the filter
        self._insertion = 0
        self._reset = False  # a new insertion's reset still to be written
        #: samples handed over, answers taken, and samples dropped (the pipe full), this
        #: insertion
        self.sent = 0
        self.answered = 0
        self.dropped = 0

    @property
    def behind(self) -> int:
        """Samples handed over that have no answer yet."""
        return self.sent - self.answered

    def _write(self, item: Any) -> bool:
        """One frame, whole or not at all (non-blocking; a frame under PIPE_BUF is atomic)."""
        try:
            return os.write(self._in, _frame(item)) > 0
        except (BlockingIOError, BrokenPipeError):
            return False

    def start_insertion(self) -> None:
        """A new insertion: a new filter (its samples wait for the reset to be written)."""
        self._insertion += 1
        self.sent = self.answered = self.dropped = 0
        self._reset = not self._write(_RESET)

    def put(self, stamp: float, sample: FeedSample) -> None:
        """Hand the filter what the feed took at the sample of ``stamp``."""
        # one array pickles faster than two
        item = (self._insertion, stamp, np.concatenate([sample.response, sample.window.ravel()]))
        if self._reset:
            self._reset = not self._write(_RESET)
        if not self._reset and self._write(item):
            self.sent += 1
        else:
            self.dropped += 1

    def answers(self, most: int = 1 << 30) -> list[tuple[float, FloatArray]]:
        """At most ``most`` of the answers come since the last call, oldest first, without
        waiting: (the sample's stamp, P(state) per plane (2, 9))."""
        while True:
            try:
                chunk = os.read(self._out, 1 << 16)
            except BlockingIOError:
                break
            if not chunk:
                break
            self._buffer += chunk
        out: list[tuple[float, FloatArray]] = []
        while len(out) < most and len(self._buffer) >= _LENGTH.size:
            (n,) = _LENGTH.unpack_from(self._buffer)
            if len(self._buffer) < _LENGTH.size + n:
                break
            item = pickle.loads(self._buffer[_LENGTH.size:_LENGTH.size + n])
            self._buffer = self._buffer[_LENGTH.size + n:]
            if isinstance(item, str):  # the child is ready
                self.ready = True
            elif item[0] == self._insertion:  # an earlier insertion's late answer is dropped
                self.answered += 1
                out.append(item[1:])
        return out

    def drain(self, timeout: float = DRAIN_WITHIN) -> list[tuple[float, FloatArray]]:
        """Every answer still to come for what was handed over, waiting up to ``timeout`` for
        the child's backlog (a stopping controller: the insertion's estimates are all sent)."""
        out = self.answers()
        end = time.monotonic() + timeout
        while self.behind > 0 and self.alive and (left := end - time.monotonic()) > 0:
            select.select([self._out], [], [], min(left, 0.1))
            out += self.answers()
        return out

    @property
    def alive(self) -> bool:
        return self.exit_code is None

    @property
    def exit_code(self) -> int | None:
        """The child's exit status once it has ended (None while it runs)."""
        return self._process.poll()

    def close(self) -> None:
        """Stop the child now, any backlog unanswered (killed if it does not end within
        CLOSE_TIMEOUT; :meth:`drain` first to have it)."""
        assert self._process.stdin is not None and self._process.stdout is not None
        try:
            self._process.stdin.close()
        except OSError:
            pass
        self._process.terminate()
        try:
            self._process.wait(CLOSE_TIMEOUT)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(CLOSE_TIMEOUT)
        self._process.stdout.close()
