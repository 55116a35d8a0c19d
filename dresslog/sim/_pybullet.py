"""pybullet, loaded at its first use and without the build-time banner it prints then.

A command's output is one summary line or one error line; the banner would break that.
Loading it at its first use, not on import, keeps it out of the processes that only
draw specs or hand out trials (`generate`'s and `sweep`'s parents).
"""

from __future__ import annotations

import ctypes
import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["pb"]


@contextmanager
def _silenced_c_output() -> Iterator[None]:
    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in saved:
            os.dup2(devnull, fd)
        yield
        ctypes.CDLL(None).fflush(None)  # what C buffered goes to /dev/null too
    finally:
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


_module: Any = None
_loading = threading.Lock()


def _load() -> Any:
    """pybullet, imported once per process, the banner silenced while it loads.

    Under a lock: two threads silencing and restoring the output at once could leave it
    pointing at /dev/null for good.
    """
    global _module
    with _loading:
        if _module is None:
            with _silenced_c_output():
                import pybullet

            _module = pybullet
    return _module


class _Pybullet:
    """Stands for the pybullet module; imports it at the first attribute asked for."""

    def __getattr__(self, name: str) -> Any:
        value = getattr(_load(), name)
        setattr(self, name, value)  # found directly from now on
        return value


pb: Any = _Pybullet()
