"""The trial file: MCAP (profile ros2, CDR) read and written with typed ROS 2 messages.

`writer.TrialWriter` and `reader.TrialReader` (context managers) are the only ways in and
out; `cdr` is the numpy codec compiled from `schemas/` (`msgdefs`), `well_known` names
the topics and types, `files` writes atomically, `summary` describes a trial for `info`.
``from dresslog.io import TrialReader, TrialWriter`` imports them on first use, so the
modules that only need `files` or `well_known` do not load mcap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dresslog.io.reader import TrialReader
    from dresslog.io.writer import TrialWriter

__all__ = ["TrialReader", "TrialWriter"]

_LAZY = {"TrialReader": "dresslog.io.reader", "TrialWriter": "dresslog.io.writer"}


def __getattr__(name: str) -> object:
    """The reader and writer, imported when first asked for (PEP 562)."""
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
