"""Read the wrench, twist and pose topics of a ROS 1 bag, ROS 2 bag or bare ROS 2 MCAP file.

rosbags (the optional extra `dresslog[ros]`) opens every format through
`AnyReader` and hands over raw payloads; decoding is done here in bulk with
numpy, because the three message types are a header followed by a fixed run
of float64: one `frombuffer` per distinct payload length replaces hundreds of
thousands of per-message deserialisations. CDR payloads are laid out by
`dresslog.io.cdr` from the `.msg` files in `schemas/`; ROS 1 payloads (a
uint32 seq in the header, no encapsulation, no alignment) by `ros1_dtype`.
"""

from __future__ import annotations

from array import array
from collections import Counter
from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path, PurePath
from typing import Any, Literal, Protocol

import numpy as np

from dresslog.convert import tf
from dresslog.convert.source import (
    MESSAGE_TYPES,
    WIDTHS,
    Source,
    SourceStream,
    stamps_unset,
    unset_note,
)
from dresslog.errors import ConversionError
from dresslog.io import cdr
from dresslog.io import well_known as wk

INSTALL_HINT = "reading ROS bags needs rosbags: pip install 'dresslog[ros]'"
#: What to do with a log in another format: no repair makes it ROS 2, an export does.
READS = (
    "convert reads ROS 1 bags, ROS 2 bags (a folder, or an MCAP file of profile 'ros2' "
    "with CDR messages) and CSV: export the wrench and the twist or pose as one of those"
)
#: How a ROS 1 bag begins (format 2.0, the only one rosbags reads).
ROS1_MAGIC = b"#ROSBAG V2.0\n"
#: Schema encodings rosbags reads in a ROS 2 MCAP file (another is a KeyError in it).
ROS2_SCHEMA_ENCODINGS = frozenset({"ros2msg", "ros2idl", "omgidl", ""})
OPTIONS = {"wrench": "--wrench-topic", "twist": "--twist-topic", "pose": "--pose-topic"}
#: CDR field names of each kind's two value blocks: those of our own topic of that kind.
FIELDS = {
    "wrench": wk.VECTOR_FIELDS[wk.WRENCH],
    "twist": wk.VECTOR_FIELDS[wk.TWIST],
    "pose": wk.VECTOR_FIELDS[wk.POSE],
}


def _rosbags() -> Any:
    """The rosbags modules, imported only when a bag is converted."""
    try:
        from rosbags import highlevel, rosbag1, rosbag2, typesys
    except ImportError:
        raise ConversionError(INSTALL_HINT) from None
    return highlevel, rosbag1, rosbag2, typesys


# -- bulk decoding -------------------------------------------------------------------------


def ros1_dtype(frame_len: int, width: int) -> np.dtype:
    """ROS 1 layout of a stamped message whose body is `width` float64 after the header."""
    return np.dtype(
        {
            "names": ["seq", "sec", "nsec", "frame_len", "values"],
            "formats": ["<u4", "<u4", "<u4", "<u4", ("<f8", (width,))],
            "offsets": [0, 4, 8, 12, 16 + frame_len],
            "itemsize": 16 + frame_len + 8 * width,
        }
    )


def _frame_id(message: np.void, ros1: bool) -> str:
    if ros1:
        return bytes(message.tobytes()[16 : 16 + int(message["frame_len"])]).decode(
            errors="replace"
        )
    return message["header.frame_id"].decode(errors="replace")


def _decode_group(
    kind: str, payloads: list, ros1: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """Decode equal-length payloads: stamps (sec, nsec) and values (T, width), plus frame_id."""
    width = WIDTHS[kind]
    size = len(payloads[0])
    if ros1:
        frame_len = size - 16 - 8 * width
        if frame_len < 0:
            raise ValueError(f"{size}-byte message is too short")
        messages = np.frombuffer(b"".join(payloads), dtype=ros1_dtype(frame_len, width))
        if (messages["frame_len"] != frame_len).any():
            raise ValueError("header length field does not match the message size")
        sec, nsec, values = messages["sec"], messages["nsec"], messages["values"]
    else:  # each message's length fields checked: one of 4 GB is refused, not laid out
        runs = cdr.decode(MESSAGE_TYPES[kind], [bytes(p) for p in payloads])
        if any((run["encapsulation"][:, :2] != (0, 1)).any() for run in runs):
            raise ValueError("not little-endian CDR (encapsulation header is not 00 01)")
        a, b = FIELDS[kind]
        sec = np.concatenate([run["header.stamp.sec"] for run in runs])
        nsec = np.concatenate([run["header.stamp.nanosec"] for run in runs])
        values = np.concatenate([np.concatenate([run[a], run[b]], axis=1) for run in runs])
        messages = runs[0]
    return sec, nsec, values, _frame_id(messages[0], ros1)


def decode(
    kind: str, payloads: Sequence[bytes], *, ros1: bool
) -> tuple[np.ndarray, np.ndarray, str]:
    """Header stamps (int64 ns), values (T, width) and the first frame_id of raw payloads."""
    count = len(payloads)
    lengths = np.fromiter(map(len, payloads), dtype=np.int64, count=count)
    stamps = np.zeros(count, dtype=np.int64)
    values = np.zeros((count, WIDTHS[kind]))
    frame_id = ""
    for size in np.unique(lengths):  # one group unless frame_id lengths vary
        index = np.flatnonzero(lengths == size)
        group = payloads if len(index) == count else [payloads[int(i)] for i in index]
        try:
            sec, nsec, vals, frame = _decode_group(kind, list(group), ros1)
        except cdr.MessageError as err:  # named by its place among all the payloads
            raise cdr.MessageError(int(index[err.index]), count, err.problem) from None
        stamps[index] = sec.astype(np.int64) * 1_000_000_000 + nsec.astype(np.int64)
        values[index] = vals
        frame_id = frame_id or frame
    return stamps, values, frame_id


# -- ROS 1 fast path ---------------------------------------------------------------------


def _ros1_messages(reader: Any, sinks: Mapping[str, Sink]) -> bool:
    """Feed each topic's raw ROS 1 messages to its sink, cut from each decompressed chunk
    by rosbags' own index; False if the bag's layout surprised it (then nothing is fed but
    what went before, and the caller starts over on rosbags' per-message path).

    rosbags parses a record header per message (about 10 us each); here each
    chunk is read once and payloads are sliced at the indexed offsets. This
    leans on rosbags' reader internals (`indexes`, `chunks`).
    """
    try:
        bio, chunks, indexes = reader.bio, reader.chunks, reader.indexes
        by_chunk: dict[int, list[tuple[int, int, str]]] = {}
        for connection in reader.connections:
            if connection.topic not in sinks:
                continue
            for entry in indexes[connection.id]:
                by_chunk.setdefault(entry.chunk_pos, []).append(
                    (entry.time, entry.offset, connection.topic)
                )
        for position in sorted(by_chunk):
            chunk = chunks[position]
            bio.seek(chunk.datapos)
            data = chunk.decompressor(bio.read(chunk.datasize))
            for t_ns, offset, topic in sorted(by_chunk[position]):
                header_len = int.from_bytes(data[offset : offset + 4], "little")
                start = offset + 4 + header_len
                if b"op=\x02" not in data[offset + 4 : start]:
                    return False
                size = int.from_bytes(data[start : start + 4], "little")
                if start + 4 + size > len(data):  # a length past the chunk: rosbags says so
                    return False
                sinks[topic].add(t_ns, data[start + 4 : start + 4 + size])
    except (AttributeError, KeyError, TypeError, ValueError, OSError):
        return False
    return True


# -- topics read into sinks ------------------------------------------------------------


#: Messages of a wrench, twist or pose topic decoded at a time while a bag is read, so
#: that a long log's payloads are never all held at once (2 million Python bytes objects
#: for 30 minutes at 1 kHz).
BLOCK = 65_536


class Sink(Protocol):
    def add(self, t_ns: int, raw: bytes) -> None: ...
    def clear(self) -> None: ...


class RawTopic:
    """A topic's receive times and raw payloads, kept as read (tf, decoded as a whole)."""

    def __init__(self) -> None:
        self.times: list[int] = []
        self.payloads: list[bytes] = []

    def add(self, t_ns: int, raw: bytes) -> None:
        self.times.append(t_ns)
        self.payloads.append(raw)

    def clear(self) -> None:
        self.times, self.payloads = [], []

    def ordered(self) -> tuple[list[int], list[bytes]]:
        """Times and payloads in log-time order, as rosbags yields them."""
        order = np.argsort(np.asarray(self.times, dtype=np.int64), kind="stable").tolist()
        return [self.times[i] for i in order], [self.payloads[i] for i in order]


class DecodedTopic:
    """A wrench, twist or pose topic decoded `BLOCK` messages at a time as it is read."""

    def __init__(self, kind: str, topic: str, path: Path, *, ros1: bool) -> None:
        self.kind, self.topic, self.path, self.ros1 = kind, topic, path, ros1
        self.clear()

    def clear(self) -> None:
        self.logged = array("q")
        self.pending: list[bytes] = []
        self.blocks: list[tuple[np.ndarray, np.ndarray]] = []
        self.frame_id = ""

    def add(self, t_ns: int, raw: bytes) -> None:
        self.logged.append(t_ns)
        self.pending.append(raw)
        if len(self.pending) >= BLOCK:
            self._decode()

    def _decode(self) -> None:
        try:
            stamps, values, frame_id = decode(self.kind, self.pending, ros1=self.ros1)
        except cdr.MessageError as err:  # counted from the topic's first message
            first = len(self.logged) - len(self.pending)
            raise ConversionError(
                f"topic {self.topic}: message {first + err.index} does not match "
                f"{MESSAGE_TYPES[self.kind]}: {err.problem}",
                path=self.path,
            ) from None
        except ValueError as err:
            raise ConversionError(
                f"topic {self.topic}: message does not match {MESSAGE_TYPES[self.kind]}: {err}",
                path=self.path,
            ) from None
        self.blocks.append((stamps, values))
        self.frame_id = self.frame_id or frame_id
        self.pending = []

    def ordered(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
        """Receive times, header stamps (int64 ns), values (T, width) in log-time order, and
        the first frame_id."""
        if self.pending:
            self._decode()
        logged = np.frombuffer(self.logged, dtype=np.int64)
        order = np.argsort(logged, kind="stable")
        stamps = np.concatenate([b[0] for b in self.blocks]) if self.blocks else logged[:0]
        values = (
            np.concatenate([b[1] for b in self.blocks])
            if self.blocks
            else np.zeros((0, WIDTHS[self.kind]))
        )
        return logged[order], stamps[order], values[order], self.frame_id


# -- topics --------------------------------------------------------------------------------


def _listing(types: dict[str, str]) -> str:
    return ", ".join(f"{t} ({m.split('/')[-1]})" for t, m in sorted(types.items())) or "none"


def choose_topics(
    types: dict[str, str],
    wanted: dict[str, str | None],
    path: Path,
    empty: frozenset[str] = frozenset(),
    pose_tf: bool = False,
) -> tuple[dict[str, str], list[str]]:
    """Topic per kind: the one asked for, or the only candidate; errors list the candidates.

    Wrench is required; velocity needs a twist or a pose (differentiated only when
    there is no twist, whether or not a pose topic was named). When a twist is found
    and the pose is ambiguous, the pose is left out with a note. With `pose_tf` the pose
    comes from tf, and no pose topic is chosen.
    """
    candidates = {  # a topic with no messages has nothing to convert: no rival
        kind: sorted(t for t, m in types.items() if m == msgtype and t not in empty)
        for kind, msgtype in MESSAGE_TYPES.items()
    }
    listing = _listing(types)
    chosen: dict[str, str] = {}
    notes: list[str] = []
    for kind, topic in wanted.items():
        if topic is None:
            continue
        if topic not in types:
            raise ConversionError(f"topic {topic} not found (topics: {listing})", path=path)
        if types[topic] != MESSAGE_TYPES[kind]:
            unstamped = types[topic] == MESSAGE_TYPES[kind].removesuffix("Stamped")
            why = " (dresslog reads stamped messages only)" if unstamped else ""
            raise ConversionError(
                f"topic {topic} is {types[topic]}, {OPTIONS[kind]} needs "
                f"{MESSAGE_TYPES[kind]}{why}",
                path=path,
            )
        chosen[kind] = topic
    for kind in ("wrench", "twist", "pose"):
        found = candidates[kind]
        if kind in chosen or (not found and kind != "wrench") or (kind == "pose" and pose_tf):
            continue
        if len(found) == 1:
            chosen[kind] = found[0]
            continue
        short = MESSAGE_TYPES[kind].split("/")[-1]
        if not found:
            plain = MESSAGE_TYPES[kind].removesuffix("Stamped")
            why = "; dresslog reads stamped messages only" if plain in types.values() else ""
            raise ConversionError(
                f"no {short} topic for the wrench (topics: {listing}){why}", path=path
            )
        message = (
            f"{len(found)} {short} topics ({', '.join(found)}); choose one with {OPTIONS[kind]}"
        )
        if kind == "pose" and "twist" in chosen:
            notes.append(f"pose left out: {message}")
            continue
        raise ConversionError(message, path=path)
    if "twist" not in chosen and "pose" not in chosen and not pose_tf:
        # a robot's gripper pose is mostly in its tf tree: say how to take it from there
        hint = "; the bag has /tf: give the gripper's frame as --pose-tf PARENT:CHILD"
        raise ConversionError(
            f"no TwistStamped or PoseStamped topic for the end-effector velocity "
            f"(topics: {listing}); the model needs force, torque and velocity"
            f"{hint if tf.TF_TYPE in types.values() else ''}",
            path=path,
        )
    return chosen, notes


def check_name(path: Path) -> None:
    """Refuse a name rosbags would misread: it tells a bag's kind by its suffix, exactly,
    so `LOG.BAG` was "Unrecognized storage format" and a ROS 2 bag folder named `.bag`
    "Is a directory", each with the cure of a bag cut short."""
    suffix = path.suffix
    if path.is_dir() and suffix == ".bag":
        raise ConversionError(
            "rosbags reads a folder named .bag as a ROS 1 bag, not a ROS 2 bag folder; "
            f"rename it {path.with_suffix('').name}",
            path=path,
        )
    if path.is_file() and suffix != suffix.lower():
        raise ConversionError(
            f"rosbags knows a bag by the lower-case {suffix.lower()} only; "
            f"rename it {path.with_suffix(suffix.lower()).name}",
            path=path,
        )


def check_bag(path: Path) -> None:
    """Refuse a .bag file that is not a ROS 1 bag, saying so: rosbags' "File magic is
    invalid." came with the cure of a bag cut short, `rosbag reindex`, which mends only a
    bag's end."""
    with path.open("rb") as stream:
        head = stream.read(len(ROS1_MAGIC))
    if head != ROS1_MAGIC:
        problem = "file is empty" if not head else "not a ROS 1 bag (it does not begin as one)"
        raise ConversionError(f"{problem}; {READS}", path=path)


def check_mcap(path: Path) -> None:
    """Refuse an MCAP file that rosbags cannot read as ROS 2, saying which kind it is: not
    MCAP, of another profile (ROS 1, none), with channels not in CDR (JSON, say), or cut
    short. rosbags said "Profile is not ros2." beside the cure of a cut-short file, and a
    JSON schema ended in its KeyError."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from mcap.records import Channel, Schema
    from mcap.stream_reader import StreamReader

    from dresslog.io.reader import MAGIC

    with path.open("rb") as stream:
        head = stream.read(len(MAGIC))
        if head != MAGIC:
            problem = "file is empty" if not head else "not an MCAP file (it does not begin as one)"
            raise ConversionError(f"{problem}; {READS}", path=path)
        stream.seek(-len(MAGIC), 2)
        ended = stream.read() == MAGIC  # the footer's magic: the file was closed
        stream.seek(0)
        try:
            reader = make_reader(stream)
            profile = reader.get_header().profile
            if profile != wk.PROFILE:
                shown = f"of profile {profile!r}" if profile else "with no profile"
                raise ConversionError(
                    f"an MCAP file {shown}, not ROS 2's {wk.PROFILE!r}; {READS}", path=path
                )
            if not ended:
                raise ConversionError(
                    "MCAP file is truncated (no end record), as when its recording was cut "
                    "short; `mcap recover` may repair it",
                    path=path,
                )
            summary = reader.get_summary()
            if summary is not None:
                schemas, channels = summary.schemas, list(summary.channels.values())
            else:  # no summary section: the records themselves, each let go once seen
                stream.seek(0)
                schemas, channels = {}, []
                for record in StreamReader(stream).records:
                    if isinstance(record, Schema):
                        schemas[record.id] = record
                    elif isinstance(record, Channel):
                        channels.append(record)
        except (McapError, ValueError, EOFError) as err:
            raise ConversionError(
                f"MCAP file is damaged ({err}); `mcap recover` may salvage its messages",
                path=path,
            ) from None
    foreign = []
    for channel in channels:
        schema = schemas.get(channel.schema_id)
        encoding = schema.encoding if schema is not None else ""
        if channel.message_encoding != wk.MESSAGE_ENCODING:
            foreign.append(f"{channel.topic} ({channel.message_encoding})")
        elif encoding not in ROS2_SCHEMA_ENCODINGS:
            foreign.append(f"{channel.topic} (schema {encoding})")
    if foreign:
        raise ConversionError(
            f"MCAP channels not in ROS 2's CDR: {', '.join(sorted(set(foreign)))}; {READS}",
            path=path,
        )


def _listed_storage(folder: Path) -> list[Path]:
    """The storage files a ROS 2 bag folder's metadata.yaml lists, found as rosbags finds
    them (by name, in the folder): another MCAP beside them is not the bag's. Empty when the
    metadata cannot be read, which rosbags then reports. ruamel.yaml comes with rosbags."""
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        metadata = YAML(typ="safe").load((folder / "metadata.yaml").read_text())
        names = metadata["rosbag2_bagfile_information"]["relative_file_paths"]
        return [folder / PurePath(name).name for name in names]
    except (YAMLError, OSError, UnicodeDecodeError, KeyError, TypeError, AttributeError):
        return []
    except RecursionError:  # `[` 200,000 times: rosbags' reader of it would fail so too
        raise ConversionError(
            "cannot read bag: its metadata.yaml nests too deeply for a YAML reader to follow, "
            "as no recorder writes it; restore the bag's metadata.yaml (`ros2 bag reindex` "
            "writes it again)",
            path=folder,
        ) from None


@contextmanager
def opened_bag(path: Path) -> Iterator[Any]:
    """rosbags' AnyReader on a bag checked first for what it would misread, its errors
    (there, or while reading in the block) one line with the cure for a bag cut short."""
    check_name(path)
    if path.suffix.lower() == ".mcap" and path.is_file():  # before rosbags, which is optional
        check_mcap(path)
    elif path.suffix.lower() == ".bag" and path.is_file():
        check_bag(path)
    highlevel, rosbag1, rosbag2, typesys = _rosbags()
    if path.is_dir():  # a ROS 2 bag folder's MCAP storage, which rosbags reads as a file
        for storage in _listed_storage(path):
            if storage.suffix.lower() == ".mcap" and storage.is_file():
                check_mcap(storage)
    # UnicodeDecodeError: bytes where rosbags reads text (a ROS 1 bag's first line, the YAML)
    errors = (highlevel.AnyReaderError, rosbag1.ReaderError, rosbag2.ReaderError, OSError,
              UnicodeDecodeError)  # fmt: skip
    try:
        default = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
        with highlevel.AnyReader([path], default_typestore=default) as reader:
            yield reader
    except errors as err:
        tools = {".bag": "rosbag reindex", ".mcap": "mcap recover"}  # else a ROS 2 bag folder
        tool = tools.get(path.suffix, "ros2 bag reindex") if path.is_file() else "ros2 bag reindex"
        reason = " ".join(str(err).split())  # a YAML error draws a caret under the line
        raise ConversionError(
            f"cannot read bag: {reason}; if its recording was cut short, `{tool}` may repair it",
            path=path,
        ) from None


def topic_counts(reader: Any) -> tuple[dict[str, str], Counter[str], frozenset[str]]:
    """Each topic's message type (pkg/msg/Type, ROS 1 too) and message count, and the
    topics with none: a connection a recorder opened and never wrote to, which no
    default choice may take."""
    types = {c.topic: c.msgtype for c in reader.connections}
    counts = Counter[str]()
    for connection in reader.connections:
        counts[connection.topic] += connection.msgcount
    return types, counts, frozenset(t for t in types if not counts[t])


def tf_topics_of(types: dict[str, str], empty: Collection[str] = ()) -> list[str]:
    """The bag's tf topics (/tf, /tf_static) that hold messages."""
    return sorted(t for t, m in types.items() if m == tf.TF_TYPE and t not in empty)


def read_into(reader: Any, sinks: Mapping[str, Sink]) -> None:
    """Feed each wanted topic's messages to its sink (keyed by topic), by the ROS 1 fast
    path where it holds, else rosbags' own per-message path (on sinks cleared: the fast
    path may have fed some before its surprise)."""
    if not reader.is2 and _ros1_messages(reader.readers[0], sinks):
        return
    for sink in sinks.values():
        sink.clear()
    connections = [c for c in reader.connections if c.topic in sinks]
    for connection, t_ns, raw in reader.messages(connections=connections):
        sinks[connection.topic].add(t_ns, raw)


def read_topics(reader: Any, topics: set[str]) -> dict[str, tuple[list[int], list]]:
    """Each topic's receive times and raw payloads, in log-time order."""
    sinks = {t: RawTopic() for t in topics}
    read_into(reader, sinks)
    return {topic: sink.ordered() for topic, sink in sinks.items()}


def tf_edges(
    reader: Any, tf_topics: list[str], buckets: dict[str, tuple[list[int], list]]
) -> dict[str, list[tf.Edge]]:
    """The tf tree's edges from the read tf topics' messages (`tf.collect_edges`)."""
    statics = {t for t in tf_topics if t.rsplit("/", 1)[-1] == "tf_static"}
    return tf.collect_edges(
        [(topic in statics, *buckets[topic]) for topic in tf_topics],
        lambda raw: reader.deserialize(raw, tf.TF_TYPE),
        ros1=not reader.is2,
    )


def read_bag(
    path: str | Path,
    *,
    wrench_topic: str | None = None,
    twist_topic: str | None = None,
    pose_topic: str | None = None,
    pose_tf: str | None = None,
    clock: Literal["header", "log"] = "header",
) -> Source:
    """Read the needed topics of one bag (any format AnyReader opens) into a `Source`.

    Times are the messages' header stamps, or with `clock="log"` the bag's receive times:
    for a sensor whose own clock is not the robot's. `pose_tf` ("PARENT:CHILD") builds the
    pose of CHILD in PARENT from the bag's tf topics (`dresslog.convert.tf`) in place of
    a PoseStamped topic.
    """
    path = Path(path)
    if pose_tf is not None and pose_topic is not None:
        raise ConversionError(
            f"{tf.OPTION} and --pose-topic both give the pose; leave one out", path=path
        )
    frames = tf.parse_frames(pose_tf, path) if pose_tf is not None else None
    wanted = {"wrench": wrench_topic, "twist": twist_topic, "pose": pose_topic}
    with opened_bag(path) as reader:
        ros1 = not reader.is2
        types, _, empty = topic_counts(reader)
        if not types or reader.message_count == 0:
            raise ConversionError("bag has no messages", path=path)
        chosen, notes = choose_topics(types, wanted, path, empty, pose_tf=frames is not None)
        tf_topics = tf_topics_of(types, empty) if frames is not None else []
        if frames is not None and not tf_topics:
            raise ConversionError(
                f"{tf.OPTION}: no /tf in the bag (no {tf.TF_TYPE} topic with messages; "
                f"topics: {_listing(types)})",
                path=path,
            )
        decoded = {t: DecodedTopic(k, t, path, ros1=ros1) for k, t in chosen.items()}
        raw = {t: RawTopic() for t in tf_topics}
        read_into(reader, {**decoded, **raw})
        if frames is not None:  # deserialised while the reader is open
            tf_read = {t: raw[t].ordered() for t in tf_topics}
            edges = tf_edges(reader, tf_topics, tf_read)
    streams: dict[str, SourceStream] = {}
    if frames is not None:
        streams["pose"] = tf.pose_stream(edges, *frames, path, clock, notes)
        streams["pose"].messages = sum(len(tf_read[t][1]) for t in tf_topics)
    for kind, topic in chosen.items():
        logged, stamps, values, frame_id = decoded[topic].ordered()
        if not len(logged):
            raise ConversionError(f"topic {topic} has no messages", path=path)
        unset = stamps_unset(stamps)  # then the recording time stands in
        if clock == "log":
            if not unset and (swapped := int((np.diff(stamps) < 0).sum())):
                notes.append(
                    f"{topic}: {swapped} message(s) arrived before one stamped earlier; on "
                    "receive times (--clock log) they stay in arrival order"
                )
            stamps, stream_clock = logged, "log"
        elif unset:
            stamps, stream_clock = logged, "log"
            notes.append(unset_note(topic))
        else:
            stream_clock = "header"
        streams[kind] = SourceStream(kind, topic, stamps, values, frame_id, stream_clock, logged)
    mount = None
    if frames is not None and (sensor := tf.frame_name(streams["wrench"].frame_id)):
        mount = tf.sensor_mount(edges, frames[1], sensor)
    return Source(
        path=path,
        format="ros1" if ros1 else "ros2",
        wrench=streams["wrench"],
        twist=streams.get("twist"),
        pose=streams.get("pose"),
        notes=notes,
        sensor_mount=mount,
    )
