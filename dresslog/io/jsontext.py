"""JSON read from a file: a trial's metadata record, a model's card, a dataset's manifest.

`loads` is `json.loads` with what would otherwise escape as a traceback, or pass as a
number, refused as a `ValueError` whose text says what is wrong: nesting deep enough to
exhaust Python's stack (`[` 200,000 times is a RecursionError in `json` and in whatever
walks the value after it), and `NaN` or `Infinity`, which are not JSON (Python writes
them, pydantic writes null). Each caller names its file in its own error.
"""

from __future__ import annotations

import json
from typing import Any

#: The deepest nesting read: dresslog's own files nest 6 levels at most (a manifest's
#: trial's spec's control points), and a value far deeper is no file of ours.
MAX_DEPTH = 100


def _not_json(constant: str) -> Any:
    raise ValueError(f"{constant} is not a JSON number")


def loads(text: str | bytes) -> Any:
    """The value of a JSON text; a `ValueError` (a `json.JSONDecodeError` for bad syntax)
    for text that is not JSON, that holds NaN or Infinity, or that nests over `MAX_DEPTH`."""
    too_deep = f"it nests more than {MAX_DEPTH} levels deep, as no dresslog file does"
    try:
        value = json.loads(text, parse_constant=_not_json)
    except RecursionError:
        raise ValueError(too_deep) from None
    if depth(value, MAX_DEPTH) > MAX_DEPTH:
        raise ValueError(too_deep)
    return value


def depth(value: Any, limit: int) -> int:
    """How deep lists and objects nest in `value` (a scalar: 0), counted up to `limit` + 1
    without recursion: level by level, so a value of any depth is safe to measure."""
    level = [value] if isinstance(value, dict | list) else []
    levels = 0
    while level and levels <= limit:
        levels += 1
        inner: list[Any] = []
        for item in level:
            inner.extend(v for v in (item.values() if isinstance(item, dict) else item)
                         if isinstance(v, dict | list))  # fmt: skip
        level = inner
    return levels
