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
class Transforms:
    """A topic's transforms, one row each: transform `slot` of message `message` (indices
    into the payloads, rows in no set order), of child `frames[frame][1]` in parent
    `frames[frame][0]` (as sent), at header stamp `t_ns`, position + quaternion `values`."""

    frames: list[tuple[str, str]]
    frame: np.ndarray
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


def _numbers(rows: np.ndarray, found: _Layout, ros1: bool) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (n, k) int64 ns and values (n, k, 7) of n payloads (rows of bytes) of a layout."""
    stamp = np.ascontiguousarray(rows[:, found.stamps[:, None] + np.arange(8)])  # (n, k, 8)
    sec = stamp.view("<u4" if ros1 else "<i4")[..., 0].astype(np.int64)
    t_ns = sec * 1_000_000_000 + stamp.view("<u4")[..., 1].astype(np.int64)
    values = np.ascontiguousarray(rows[:, found.values[:, None] + np.arange(56)]).view("<f8")
    return t_ns, values


def decode(
    payloads: Sequence[bytes], deserialize: Callable[[bytes], Any], *, ros1: bool
) -> Transforms:
    """Every transform of a topic's TFMessages, in bulk where a layout repeats."""
    frames: dict[tuple[str, str], int] = {}
    parts: list[tuple[np.ndarray, ...]] = []  # frame, message, slot, t_ns, values

    def add(names: list[tuple[str, str]], message: np.ndarray, t_ns: np.ndarray,
            values: np.ndarray) -> None:  # fmt: skip
        frame = np.asarray([frames.setdefault(n, len(frames)) for n in names], dtype=np.int64)
        n, k = t_ns.shape
        parts.append((np.tile(frame, n), np.repeat(message, k), np.tile(np.arange(k), n),
                      t_ns.ravel(), values.reshape(n * k, 7)))  # fmt: skip

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
                if len(found.frames):
                    add(found.frames, part[left[same]], *_numbers(ours[same], found, ros1))
                left = left[~same]
            alone += part[left].tolist()
    for i in sorted(alone):
        transforms = deserialize(payloads[i]).transforms
        if not transforms:
            continue
        names, stamps, moves = [], [], []
        for transform in transforms:
            stamp, move = transform.header.stamp, transform.transform
            names.append((transform.header.frame_id, transform.child_frame_id))
            stamps.append(stamp.sec * 1_000_000_000 + stamp.nanosec)
            t, r = move.translation, move.rotation
            moves.append((t.x, t.y, t.z, r.x, r.y, r.z, r.w))
        add(names, np.array([i]), np.array([stamps], np.int64), np.array([moves], np.float64))
    if not parts:
        empty = np.zeros(0, dtype=np.int64)
        return Transforms([], empty, empty, empty, empty, np.zeros((0, 7)))
    frame, message, slot, t_ns, values = (np.concatenate(c) for c in zip(*parts, strict=True))
    return Transforms(list(frames), frame, message, slot, t_ns, values)
