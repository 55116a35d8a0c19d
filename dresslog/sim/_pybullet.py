"""pybullet, without the build-time banner its C code prints on import.

A command's output is one summary line or one error line; the banner would break that.
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

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


with _silenced_c_output():
    import pybullet as pb
