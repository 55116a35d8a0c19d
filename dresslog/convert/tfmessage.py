"""Read a tf topic's raw TFMessages (ROS 1 or CDR) in bulk with numpy.

A TFMessage has no fixed layout, as the stamped topics `rosbag.decode` reads have: its
length follows its frames' names. But a robot_state_publisher sends the same frames in
the same order in every message, so the payloads of one length nearly always share one
byte layout but for the numbers. Here each length's first payload is laid out once
(where each transform's stamp and 7 float64 sit), every payload of that length is
compared with it at the other bytes (counts, names, padding), and the numbers of those
that match are read in one gather. Payloads of another layout at the same length take
the next template (up to `MAX_LAYOUTS`); any payload left over, or one that does not lay
out as a plain TFMessage, is deserialised alone by the caller's `deserialize` (rosbags),
so the transforms are always those rosbags' per-message path gives.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dresslog.io.cdr import ENCAPSULATION

#: Layouts tried at one payload length before its other payloads go one by one.
MAX_LAYOUTS = 4
#: Payloads compared at once: bounds the copies to a few tens of MB on a long bag.
CHUNK = 32_768


@dataclass
class Run:
    """Transform `slot` of some of a topic's messages (`message`, indices into the
    payloads): child frame `child` in `parent` (as sent), at header stamps `t_ns`,
    position + quaternion `values` (n, 7)."""

    parent: str
    child: str
    message: np.ndarray
    slot: np.ndarray
    t_ns: np.ndarray
    values: np.ndarray


@dataclass
class _Layout:
    """One payload's layout: its transforms' frames and the offsets of their stamps and
    values; `fixed` marks the bytes every payload of this layout repeats."""

    frames: list[tuple[str, str]]
    stamps: np.ndarray
    values: np.ndarray
    template: np.ndarray
    fixed: np.ndarray


def layout(payload: bytes, *, ros1: bool) -> _Layout | None:
    """Where the numbers of one TFMessage sit, or None where it is not one rosbags would
    read exactly so (then it goes to rosbags). ROS 1: no alignment, a header seq (ignored,
    as rosbags' path ignores it), strings without NUL. CDR: little endian, each field
    aligned to its size from after the 4-byte encapsulation, strings NUL-terminated."""
    origin = 0 if ros1 else len(ENCAPSULATION)
    if not ros1 and payload[:2] != ENCAPSULATION[:2]:
        return None
    size = len(payload)
    numbers = np.zeros(size, dtype=bool)
    frames: list[tuple[str, str]] = []
    stamps: list[int] = []
    values: list[int] = []

    def aligned(at: int, n: int) -> int:
        return at if ros1 else origin + (at - origin + n - 1) // n * n

    def u32(at: int) -> int:
        if at + 4 > size:
            raise ValueError("past the end")
        return int.from_bytes(payload[at : at + 4], "little")

    def string(at: int) -> tuple[str, int]:
        at = aligned(at, 4)
        end = at + 4 + u32(at)
        if end > size or (not ros1 and (end == at + 4 or payload[end - 1] != 0)):
            raise ValueError("not a string")
        return bytes(payload[at + 4 : end if ros1 else end - 1]).decode(), end

    try:
        at = aligned(origin, 4)
        count = u32(at)
        at += 4
        for _ in range(min(count, size // 56)):  # a transform takes 56 bytes and more
            at = aligned(at, 4)
            if ros1:  # header.seq
                numbers[at : at + 4] = True
                at += 4
            stamps.append(at)
            numbers[at : at + 8] = True
            parent, at = string(at + 8)
            child, at = string(at)
            at = aligned(at, 8)
            values.append(at)
            numbers[at : at + 56] = True
            at += 56
            frames.append((parent, child))
    except (ValueError, UnicodeDecodeError):
        return None
    if len(frames) != count or at != size:
        return None
    template = np.frombuffer(bytes(payload), dtype=np.uint8)
    return _Layout(frames, np.asarray(stamps), np.asarray(values), template, ~numbers)


def _runs(rows: np.ndarray, message: np.ndarray, found: _Layout, ros1: bool) -> list[Run]:
    """The transforms of payloads (rows of bytes, messages `message`) of one layout."""
    runs = []
    for slot, ((parent, child), stamp, at) in enumerate(
        zip(found.frames, found.stamps.tolist(), found.values.tolist(), strict=True)
    ):
        pair = rows[:, stamp : stamp + 8].copy()  # a strided view's rows, made contiguous
        sec = pair[:, :4].copy().view("<u4" if ros1 else "<i4")[:, 0].astype(np.int64)
        t_ns = sec * 1_000_000_000 + pair[:, 4:].copy().view("<u4")[:, 0]
        values = rows[:, at : at + 56].copy().view("<f8")
        runs.append(Run(parent, child, message, np.full(len(message), slot), t_ns, values))
    return runs


def decode(
    payloads: Sequence[bytes], deserialize: Callable[[bytes], Any], *, ros1: bool
) -> list[Run]:
    """Every transform of a topic's TFMessages, in runs: in bulk where a layout repeats,
    else one run per frame of the messages rosbags deserialised."""
    runs: list[Run] = []
    lengths = np.fromiter(map(len, payloads), dtype=np.int64, count=len(payloads))
    alone: list[int] = []
    for size in np.unique(lengths).tolist():
        index = np.flatnonzero(lengths == size)
        layouts: list[_Layout] = []
        for start in range(0, len(index), CHUNK):
            part = index[start : start + CHUNK]
            joined = b"".join(payloads[i] for i in part.tolist())
            rows = np.frombuffer(joined, dtype=np.uint8).reshape(len(part), size)
            left = np.arange(len(part))
            for tried in range(MAX_LAYOUTS):
                if not len(left):
                    break
                if tried == len(layouts):  # a new template: the first payload left
                    found = layout(payloads[int(part[left[0]])], ros1=ros1)
                    if found is None:
                        break
                    layouts.append(found)
                found = layouts[tried]
                ours = rows if len(left) == len(part) else rows[left]
                same = ~((ours != found.template) & found.fixed).any(axis=1)
                matched = ours if same.all() else ours[same]
                runs += _runs(matched, part[left[same]], found, ros1)
                left = left[~same]
            alone += part[left].tolist()
    rows_of: dict[tuple[str, str], tuple[list[int], list[int], list[int], list[tuple]]] = {}
    for i in sorted(alone):
        for slot, transform in enumerate(deserialize(payloads[i]).transforms):
            stamp, move = transform.header.stamp, transform.transform
            key = (transform.header.frame_id, transform.child_frame_id)
            messages, slots, stamps, values = rows_of.setdefault(key, ([], [], [], []))
            messages.append(i)
            slots.append(slot)
            stamps.append(stamp.sec * 1_000_000_000 + stamp.nanosec)
            t, r = move.translation, move.rotation
            values.append((t.x, t.y, t.z, r.x, r.y, r.z, r.w))
    for (parent, child), (messages, slots, stamps, values) in rows_of.items():
        runs.append(Run(parent, child, np.asarray(messages, np.int64), np.asarray(slots),
                        np.asarray(stamps, np.int64), np.asarray(values, np.float64)))  # fmt: skip
    return runs
