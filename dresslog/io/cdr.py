"""Vectorised CDR codec for dresslog's fixed schemas, compiled from the `.msg` texts.

A ROS 2 message whose variable-length parts (strings, sequences) have known
lengths has a fixed byte layout. `layout()` walks the `.msg` definition with
those lengths and returns a numpy structured dtype whose fields sit at the CDR
offsets (little endian, alignment relative to the end of the 4-byte
encapsulation header). Encoding T messages is then filling one array and
slicing its bytes; decoding is one `frombuffer`. Because the layout comes from
the `.msg` text, the codec cannot drift from the schema the file registers.

Leaf naming: nested fields join with dots (`header.stamp.sec`); a sequence
adds a `<name>.len` count, and each element of a sequence of messages that have
no one size is named by its index (`markers.0.points`); a nested message whose
fields are all one primitive type (Vector3, Point, Quaternion) collapses into a
sub-array.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from functools import cache

import numpy as np
import numpy.typing as npt

from dresslog.io.msgdefs import fields, full_type_name

_NUMPY = {
    "bool": "u1", "byte": "u1", "char": "u1", "int8": "i1", "uint8": "u1",
    "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4",
    "int64": "<i8", "uint64": "<u8", "float32": "<f4", "float64": "<f8",
}  # fmt: skip
ENCAPSULATION = b"\x00\x01\x00\x00"  # CDR, little endian
_ORIGIN = len(ENCAPSULATION)

#: Lengths of the variable parts: a count for a sequence, the byte length for
#: a string, a tuple of byte lengths for a string sequence; keyed by dotted path.
Sizes = Mapping[str, "int | tuple[int, ...]"]


def _align(offset: int, size: int) -> int:
    rel = offset - _ORIGIN
    return _ORIGIN + (rel + size - 1) // size * size


@cache
def is_fixed(msg: str) -> bool:
    """Whether `msg` has one size: no strings or sequences in it, nor in what it holds."""
    package = msg.split("/")[0]
    for type_, _ in fields(msg):
        match = re.fullmatch(r"(.+?)(\[(\d*)\])?", type_)
        assert match is not None
        base, is_array, fixed = match.group(1), match.group(2), match.group(3)
        if base == "string" or (is_array and not fixed):
            return False
        if base not in _NUMPY and not is_fixed(full_type_name(base, package)):
            return False
    return True


def _uniform_primitive(msg: str) -> tuple[str, int] | None:
    """(primitive, count) when every field of `msg` is the same fixed primitive."""
    types = {t for t, _ in fields(msg)}
    if len(types) == 1 and (t := types.pop()) in _NUMPY:
        return t, len(fields(msg))
    return None


class _Builder:
    """Walks a definition, placing fields; reads unknown lengths from `payload` if given."""

    def __init__(self, sizes: Sizes, payload: bytes | None = None) -> None:
        self.sizes = dict(sizes)
        self.payload = payload
        self.names: list[str] = []
        self.formats: list[npt.DTypeLike] = []
        self.offsets: list[int] = []
        self.offset = _ORIGIN

    def add(self, name: str, fmt: npt.DTypeLike, align: int) -> None:
        self.offset = _align(self.offset, align)
        self.names.append(name)
        self.formats.append(fmt)
        self.offsets.append(self.offset)
        self.offset += np.dtype(fmt).itemsize

    def message(self, msg: str, prefix: str) -> None:
        package = msg.split("/")[0]
        for type_, name in fields(msg):
            path = f"{prefix}{name}"
            match = re.fullmatch(r"(.+?)(\[(\d*)\])?", type_)
            assert match is not None
            base, is_array, fixed = match.group(1), match.group(2), match.group(3)
            if is_array:
                each = 0 if fixed else self._least_size(base, package)
                count = int(fixed) if fixed else self._size(path, base == "string", each=each)
                if not fixed:
                    self.add(f"{path}.len", "<u4", 4)
                self.array(base, package, path, count)
            else:
                self.single(base, package, path)

    def single(self, base: str, package: str, path: str) -> None:
        if base == "string":
            length = self._size(path, False, string=True)
            assert isinstance(length, int)  # one string: its byte length
            self.add(f"{path}.len", "<u4", 4)
            self.add(path, f"S{length + 1}", 1)
        elif base in _NUMPY:
            fmt = np.dtype(_NUMPY[base])
            self.add(path, fmt, fmt.itemsize)
        else:
            full = full_type_name(base, package)
            uniform = _uniform_primitive(full)
            if uniform:
                fmt = np.dtype(_NUMPY[uniform[0]])
                self.add(path, (fmt, (uniform[1],)), fmt.itemsize)
            else:
                self.message(full, f"{path}.")

    def array(self, base: str, package: str, path: str, count: int | tuple[int, ...]) -> None:
        if base == "string":
            for i, length in enumerate(count if isinstance(count, tuple) else ()):
                self.add(f"{path}.{i}.len", "<u4", 4)
                self.add(f"{path}.{i}", f"S{length + 1}", 1)
            return
        assert isinstance(count, int)
        # an empty sequence has no padding either: CDR aligns the elements it reads, and
        # Foxglove's and mcap_ros2's readers align nothing for none (a scene entity's
        # empty float64 lists, between its other fields)
        if base in _NUMPY:
            fmt = np.dtype(_NUMPY[base])
            self.add(path, (fmt, (count,)), fmt.itemsize if count else 1)
            return
        full = full_type_name(base, package)
        if uniform := _uniform_primitive(full):
            fmt = np.dtype(_NUMPY[uniform[0]])
            self.add(path, (fmt, (count, uniform[1])), fmt.itemsize if count else 1)
            return
        if not is_fixed(full):  # elements of their own sizes (a MarkerArray's markers)
            for i in range(count):
                self.message(full, f"{path}.{i}.")
            return
        elem = element_dtype(full)
        self.add(path, (elem, (count,)), _max_align(elem) if count else 1)

    def _least_size(self, base: str, package: str) -> int:
        """The fewest bytes one element of a `base[]` sequence takes: a string's length
        field and NUL, a primitive's or a fixed message's size."""
        if base == "string":
            return 5
        if base in _NUMPY:
            return np.dtype(_NUMPY[base]).itemsize
        full = full_type_name(base, package)
        if uniform := _uniform_primitive(full):
            return np.dtype(_NUMPY[uniform[0]]).itemsize * uniform[1]
        if not is_fixed(full):  # at least one length field
            return 4
        return element_dtype(full).itemsize

    def _size(
        self, path: str, strings: bool, string: bool = False, each: int = 1
    ) -> int | tuple[int, ...]:
        """The length of the variable part at `path`, from `sizes` or read from the payload,
        where every length field is checked against the bytes the payload has left: a
        length of 4 GB in a corrupt message is refused, never laid out."""
        if path in self.sizes:
            return self.sizes[path]
        if self.payload is None:
            raise KeyError(f"layout needs the length of {path!r}")
        at = _align(self.offset, 4)
        count = self._u32(at)
        if string:
            self._check_string(path, count, at)
        elif count * each > (left := len(self.payload) - at - 4):
            raise ValueError(
                f"{path} holds {count} elements by its length field, {count * each} bytes or "
                f"more, but the {len(self.payload)}-byte message has {left} left"
            )
        size: int | tuple[int, ...] = count - 1 if string else count
        if strings:
            lengths = []
            at += 4
            for i in range(count):
                at = _align(at, 4)
                length = self._u32(at)
                self._check_string(f"{path}[{i}]", length, at)
                lengths.append(length - 1)
                at += 4 + length
            size = tuple(lengths)
        self.sizes[path] = size
        return size

    def _check_string(self, path: str, length: int, at: int) -> None:
        """A string's length field (at `at`) counts its bytes and its NUL: 1 or more, and no
        more than the message has left after the field."""
        assert self.payload is not None
        left = len(self.payload) - at - 4
        if length == 0:
            raise ValueError(
                f"string {path} has the length 0, and a CDR string's length counts its NUL"
            )
        if length > left:
            raise ValueError(
                f"string {path} is {length} bytes long by its length field, but the "
                f"{len(self.payload)}-byte message has {left} left"
            )

    def _u32(self, at: int) -> int:
        assert self.payload is not None
        if at + 4 > len(self.payload):
            raise ValueError("message is shorter than its schema needs")
        return int.from_bytes(self.payload[at : at + 4], "little")

    def dtype(self) -> np.dtype:
        names = ["encapsulation", *self.names]
        formats = [("u1", (4,)), *self.formats]
        offsets = [0, *self.offsets]
        return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                         "itemsize": self.offset})  # fmt: skip


def _names(dtype: np.dtype) -> tuple[str, ...]:
    """A structured dtype's field names (numpy types them as possibly None)."""
    return dtype.names or ()


def _max_align(dtype: np.dtype) -> int:
    if dtype.fields is None:
        return dtype.base.itemsize if dtype.subdtype else dtype.itemsize
    return max(_max_align(f[0]) for f in dtype.fields.values())


@cache
def element_dtype(msg: str) -> np.dtype:
    """The fixed layout of one element of a `msg[]` sequence (no strings or sequences inside)."""
    builder = _Builder({})
    builder.message(msg, "")
    offsets = [offset - _ORIGIN for offset in builder.offsets]
    formats = [np.dtype(f) for f in builder.formats]
    size = builder.offset - _ORIGIN
    if size % max(_max_align(f) for f in formats):
        raise ValueError(f"{msg} has trailing padding; its elements do not tile")
    return np.dtype({"names": builder.names, "formats": formats, "offsets": offsets,
                     "itemsize": size})  # fmt: skip


def _key(sizes: Sizes) -> tuple:
    return tuple(sorted(sizes.items()))


@cache
def _layout(msg: str, key: tuple) -> np.dtype:
    builder = _Builder(dict(key))
    builder.message(msg, "")
    return builder.dtype()


def layout(msg: str, sizes: Sizes) -> np.dtype:
    """The CDR byte layout of `msg` (e.g. `geometry_msgs/msg/WrenchStamped`) for these sizes."""
    return _layout(msg, _key(sizes))


def sizes_of(msg: str, payload: bytes) -> dict[str, int | tuple[int, ...]]:
    """The variable-part lengths of one encoded message, read from its bytes."""
    builder = _Builder({}, payload)
    builder.message(msg, "")
    if builder.offset - len(payload) > 7:  # a payload may omit trailing padding only
        raise ValueError(f"message of {len(payload)} bytes is shorter than its schema needs")
    return builder.sizes


class MessageError(ValueError):
    """Message `index` of `count` does not lay out as its schema says: `problem`."""

    def __init__(self, index: int, count: int, problem: str) -> None:
        self.index, self.count, self.problem = index, count, problem
        super().__init__(f"message {index} of {count}: {problem}")


def _sizes_of_message(msg: str, payloads: Sequence[bytes], i: int) -> Sizes:
    """`sizes_of` payload `i`, its problem a `MessageError` naming it."""
    try:
        return sizes_of(msg, payloads[i])
    except ValueError as err:
        raise MessageError(i, len(payloads), str(err)) from None


def decode(msg: str, payloads: Sequence[bytes]) -> list[np.ndarray]:
    """Decode payloads of any lengths: one array per run of equal layout, in order.

    The common case, every message with the same layout (a force-map channel),
    takes one `frombuffer` and a vectorised check of the length fields. A length field
    past its message's end is a `MessageError` naming the message.
    """
    if payloads and len({len(p) for p in payloads}) == 1:
        dtype = _layout(msg, _key(_sizes_of_message(msg, payloads, 0)))
        whole = from_payloads(payloads, dtype)
        lengths = [n for n in _names(dtype) if n.endswith(".len")]
        if all((whole[n] == whole[n][0]).all() for n in lengths):
            return [whole]
    out: list[np.ndarray] = []
    run: list[bytes] = []
    run_key: tuple | None = None
    for i, payload in enumerate(payloads):
        key = _key(_sizes_of_message(msg, payloads, i))
        if key != run_key and run:
            out.append(from_payloads(run, _layout(msg, run_key)))
            run = []
        run_key = key
        run.append(payload)
    if run:
        out.append(from_payloads(run, _layout(msg, run_key)))
    return out


def new_messages(msg: str, sizes: Sizes, count: int) -> np.ndarray:
    """`count` zeroed messages with the header and every length field filled in."""
    dtype = layout(msg, sizes)
    out = np.zeros(count, dtype=dtype)
    out["encapsulation"] = np.frombuffer(ENCAPSULATION, dtype="u1")
    for path, size in sizes.items():
        if isinstance(size, tuple):
            out[f"{path}.len"] = len(size)
            for i, length in enumerate(size):
                out[f"{path}.{i}.len"] = length + 1
        elif f"{path}.len" in _names(dtype):
            string = path in _names(dtype) and dtype[path].kind == "S"
            out[f"{path}.len"] = size + 1 if string else size
    return out


def set_stamp(messages: np.ndarray, t_ns: np.ndarray, frame_id: str) -> None:
    """Fill `header.stamp` from integer nanoseconds and `header.frame_id`."""
    t_ns = np.asarray(t_ns, dtype=np.int64)
    messages["header.stamp.sec"] = t_ns // 1_000_000_000
    messages["header.stamp.nanosec"] = t_ns % 1_000_000_000
    messages["header.frame_id"] = frame_id.encode()


def stamp_ns(messages: np.ndarray) -> np.ndarray:
    """`header.stamp` as integer nanoseconds."""
    sec = messages["header.stamp.sec"].astype(np.int64)
    return sec * 1_000_000_000 + messages["header.stamp.nanosec"].astype(np.int64)


#: How every stamped message begins: encapsulation header, then std_msgs/Header's stamp
#: (named as decoded, so `stamp_ns` reads it).
_HEAD = np.dtype(
    [
        ("encapsulation", "u1", (4,)),
        ("header.stamp.sec", "<i4"),
        ("header.stamp.nanosec", "<u4"),
    ]
)


def heads(payloads: Sequence[bytes]) -> np.ndarray | None:
    """The undecoded messages' encapsulation and header stamp (fields of `_HEAD`); None if
    one is too short to hold them. One pass over the payloads: it runs on every trial read."""
    joined = b"".join(p[:12] for p in payloads)
    if len(joined) != 12 * len(payloads):
        return None
    return np.frombuffer(joined, dtype=_HEAD)


def to_payloads(messages: np.ndarray) -> list[bytes]:
    """One bytes object per message, cut from a single buffer."""
    buf = messages.tobytes()
    size = messages.dtype.itemsize
    return [buf[i : i + size] for i in range(0, len(buf), size)]


def from_payloads(payloads: Sequence[bytes], dtype: np.dtype) -> np.ndarray:
    """Decode equal-layout payloads in one `frombuffer` (a payload may omit trailing padding)."""
    size = dtype.itemsize
    if all(len(p) == size for p in payloads):
        return np.frombuffer(b"".join(payloads), dtype=dtype)
    return np.frombuffer(b"".join(p.ljust(size, b"\0") for p in payloads), dtype=dtype)
