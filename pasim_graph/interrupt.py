"""Stopping a long command cleanly on SIGINT (Ctrl-C) and SIGTERM.

The first signal raises :class:`Stopped` in the main thread, where the command ends what it
was doing, releases what it holds and says in one line what was finished and how to go on;
its exit status is 128 + the signal's number (130, 143), as a shell reports a process killed
by it. Further signals while it stops are ignored, so pressing Ctrl-C twice never turns a
clean stop into a traceback.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

#: Set when a stop was asked for in this process: work already running in other threads
#: checks it and writes nothing more (a thread cannot be interrupted, only told).
STOPPING = threading.Event()


class _Held:
    """Signals held in the main thread (:func:`signals_held`): how deep, and the one held."""

    depth = 0
    signum: int | None = None


class Stopped(KeyboardInterrupt):
    """A command was asked to stop by a signal."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


class StopMessage(Exception):
    """A command that stopped, with what it finished: printed as one line, exit 128 + signal."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Stopped` (once) in this thread."""
    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers can only be set from the main thread
        return
    stopping = False

    def handler(signum: int, frame: Any) -> None:
        nonlocal stopping
        if stopping:
            return
        stopping = True
        STOPPING.set()
        if _Held.depth:
            _Held.signum = signum  # raised when the held steps end
            return
        raise Stopped(signum)

    unraisable = sys.unraisablehook

    def quiet(info: Any) -> None:
        # A stop that lands in a finaliser (a weak set dropping an object the collector freed
        # in this thread) cannot be raised there: Python prints it as "Exception ignored" with
        # a traceback. STOPPING is set all the same, and the run stops at its next check.
        if not isinstance(info.exc_value, Stopped):
            unraisable(info)

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    sys.unraisablehook = quiet
    STOPPING.clear()
    _Held.signum = None
    try:
        yield
    finally:
        sys.unraisablehook = unraisable
        for s, h in previous.items():
            # After a stop the command is ending: later signals are ignored, not turned into
            # a KeyboardInterrupt in the middle of its last message.
            signal.signal(s, signal.SIG_IGN if stopping else h)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Within the block, a stop signal waits: :class:`Stopped` is raised when the block ends.

    For the few steps that take or give back something another process would trip on (a
    store's lock file, between creating it and the caller's ``try`` that removes it): a stop
    landing in the middle of them would leave it behind. The block must be short; in other
    threads than the main one (which signals never interrupt) it changes nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _Held.depth += 1
    try:
        yield
    finally:
        _Held.depth -= 1
        if not _Held.depth and _Held.signum is not None:
            signum, _Held.signum = _Held.signum, None
            raise Stopped(signum)
