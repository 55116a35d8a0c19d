"""The signals that stop a command as Ctrl-C does, so what it was writing is removed.

A kill (SIGTERM) always does; a closed terminal (SIGHUP) does unless the command was
started to outlive it: `nohup` leaves SIGHUP ignored, and so must we.
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator


def hangup() -> signal.Signals | None:
    """SIGHUP where it exists (not on Windows) and is not ignored (as under `nohup`)."""
    number = getattr(signal, "SIGHUP", None)
    return None if number is None or signal.getsignal(number) is signal.SIG_IGN else number


def stop_signals() -> tuple[signal.Signals, ...]:
    """SIGTERM, and SIGHUP where it exists and is not ignored."""
    return (signal.SIGTERM,) if (number := hangup()) is None else (signal.SIGTERM, number)


def _stops() -> list[signal.Signals]:
    """Ctrl-C, kill and hang-up, those this platform has."""
    names = ("SIGINT", "SIGTERM", "SIGHUP")
    return [getattr(signal, n) for n in names if hasattr(signal, n)]


@contextlib.contextmanager
def deferred_in_children() -> Iterator[None]:
    """Block Ctrl-C, kill and hang-up while worker processes are started; they inherit it.

    A terminal's Ctrl-C reaches the whole group: a worker still importing when it came
    printed its own KeyboardInterrupt traceback. Blocked, not ignored, a signal waits:
    this process takes its own as the block ends, a worker that handles its stops takes
    them once it calls `unblock_stops` (after its imports), and one that never does is
    stopped by its parent (multiprocessing starts its resource tracker the same way).
    Where signals cannot be blocked (Windows) this does nothing.
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, _stops())
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def unblock_stops() -> None:
    """Take the stops blocked since `deferred_in_children` started this process."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _stops())


def leave_stops_to_the_parent() -> None:
    """In a worker started under `deferred_in_children` whose parent stops it: ignore
    Ctrl-C and hang-up (the parent takes them), keep kill's default (a broken pool
    terminates its other workers so; blocked, they outlived it and its join waited
    forever), then take the block off."""
    for name in ("SIGINT", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_IGN)
    unblock_stops()
