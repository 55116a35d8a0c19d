"""The signals that stop a command as Ctrl-C does, so what it was writing is removed.

A kill (SIGTERM) always does; a closed terminal (SIGHUP) does unless the command was
started to outlive it: `nohup` leaves SIGHUP ignored, and so must we.
"""

from __future__ import annotations

import signal


def stop_signals() -> tuple[signal.Signals, ...]:
    """SIGTERM, and SIGHUP where it exists and is not ignored."""
    hangup = getattr(signal, "SIGHUP", None)
    if hangup is None or signal.getsignal(hangup) is signal.SIG_IGN:
        return (signal.SIGTERM,)
    return (signal.SIGTERM, hangup)
