"""The signals that stop a command as Ctrl-C does, so what it was writing is removed.

A kill (SIGTERM) always does; a closed terminal (SIGHUP) does unless the command was
started to outlive it: `nohup` leaves SIGHUP ignored, and so must we.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


def hangup() -> signal.Signals | None:
    """SIGHUP where it exists (not on Windows) and is not ignored (as under `nohup`)."""
    number = getattr(signal, "SIGHUP", None)
    return None if number is None or signal.getsignal(number) is signal.SIG_IGN else number


def stop_signals() -> tuple[signal.Signals, ...]:
    """SIGTERM, and SIGHUP where it exists and is not ignored."""
    return (signal.SIGTERM,) if (number := hangup()) is None else (signal.SIGTERM, number)


@contextlib.contextmanager
def ignored_in_children() -> Iterator[None]:
    """Ignore Ctrl-C, kill and hang-up while worker processes are started, which inherit it.

    A terminal's Ctrl-C reaches the whole group; a worker still importing when it came
    printed its own KeyboardInterrupt traceback. The parent alone stops them. Off the main
    thread (where no handler can be set) this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    names = ("SIGINT", "SIGTERM", "SIGHUP")
    numbers = [getattr(signal, n) for n in names if hasattr(signal, n)]
    before = {n: signal.signal(n, signal.SIG_IGN) for n in numbers}
    try:
        yield
    finally:
        for number, handler in before.items():
            signal.signal(number, handler)
