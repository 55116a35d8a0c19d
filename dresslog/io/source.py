"""Where a trial's messages come from: an MCAP file read through its index, on demand.

Opening reads the summary section alone (schemas, channels, message counts, chunk and
metadata indexes); messages are read when asked for, only the chunks that hold the asked
topics and times, each chunk's CRC checked as it is read. A file without a usable summary
(written by a tool that skips it) is scanned once to count its channels and again for
each read, so it reads the same, slower. A truncated or damaged file is one
`TrialFormatError` naming it, whenever the damage is met.
"""

from __future__ import annotations

import struct
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.reader import SeekingReader, make_reader
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from zstandard import ZstdError

from dresslog.errors import TrialFormatError
from dresslog.io import well_known as wk

if TYPE_CHECKING:
    from mcap.summary import Summary

MAGIC = b"\x89MCAP0\r\n"

#: What mcap and its decompressor raise on a damaged or cut-short file.
DAMAGE = (McapError, ValueError, EOFError, OverflowError, struct.error, ZstdError, KeyError)
#: How a damaged file is put right.
_SALVAGE = "re-record it, or salvage it with `mcap recover`"


@dataclass(frozen=True)
class ChannelInfo:
    """One channel of the file (all the file's channels of one topic): its schema,
    encoding and message count."""

    topic: str
    schema: str
    encoding: str
    count: int


@dataclass(frozen=True)
class _Scanned:
    """What one pass over a file without a summary found."""

    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    counts: dict[int, int]
    metadata: list[Metadata]


class McapSource:
    """One MCAP file's channels, metadata records and messages, read on demand.

    Holds the file open between `open` and `close`; its memory is the summary's.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self._stream: BinaryIO | None = None
        self._reader: SeekingReader | None = None  # None: no usable index, scanned instead
        self._topics: dict[int, str] = {}
        #: Every topic of the file, ours or not.
        self.channels: dict[str, ChannelInfo] = {}
        #: The file's metadata records by name (the last of a name wins).
        self.metadata: dict[str, dict[str, str]] = {}

    def open(self) -> None:
        """Read the summary (or scan a file without one); refuse a damaged file."""
        self._stream = self.path.open("rb")
        with self._damage():
            reader = SeekingReader(self._stream, validate_crcs=True)
            summary = self._summary(reader)
            if summary is None:
                scanned = self._scan()
                schemas, channels, counts = scanned.schemas, scanned.channels, scanned.counts
                records = scanned.metadata
            else:
                self._reader = reader
                schemas, channels = summary.schemas, summary.channels
                assert summary.statistics is not None  # `_summary` checked it
                counts = summary.statistics.channel_message_counts
                wanted = {index.name for index in summary.metadata_indexes}
                records = list(reader.iter_metadata()) if wanted else []
        for record in records:
            self.metadata[record.name] = record.metadata
        self._name_channels(schemas, channels, counts)

    def close(self) -> None:
        """Close the file; what opening read (channels, counts, metadata) stays."""
        if self._stream is not None:
            self._stream.close()
        self._stream = self._reader = None

    @contextmanager
    def _damage(self) -> Iterator[None]:
        """Whatever a damaged file raises, as one line naming it."""
        try:
            yield
        except DAMAGE as err:
            detail = f"{type(err).__name__}: {err}" if str(err) else type(err).__name__
            raise TrialFormatError(
                f"MCAP file is damaged or truncated ({detail}); {_SALVAGE}", path=self.path
            ) from None

    @staticmethod
    def _summary(reader: SeekingReader) -> Summary | None:
        """The summary section if it indexes every message (statistics and chunk indexes);
        None for a file without one, or cut short before it."""
        try:
            summary = reader.get_summary()
        except DAMAGE:  # no footer: the scan says what is wrong
            return None
        if summary is None or summary.statistics is None:
            return None
        if summary.statistics.message_count and not summary.chunk_indexes:
            return None  # messages outside chunks: only a scan finds them
        return summary

    def _records(self) -> Iterator[object]:
        """Every record from the file's start, its end required (a file cut short says so)."""
        assert self._stream is not None
        self._stream.seek(0)
        for record in StreamReader(self._stream, validate_crcs=True).records:
            yield record
            if isinstance(record, DataEnd | Footer):
                return
        raise TrialFormatError(
            f"MCAP file is truncated (no end record); it was not closed cleanly: {_SALVAGE}",
            path=self.path,
        )

    def _scan(self) -> _Scanned:
        scanned = _Scanned({}, {}, {}, [])
        for record in self._records():
            if isinstance(record, Message):
                cid = record.channel_id
                scanned.counts[cid] = scanned.counts.get(cid, 0) + 1
            elif isinstance(record, Schema):
                scanned.schemas[record.id] = record
            elif isinstance(record, Channel):
                scanned.channels[record.id] = record
            elif isinstance(record, Metadata):
                scanned.metadata.append(record)
        return scanned

    def _name_channels(
        self, schemas: dict[int, Schema], channels: dict[int, Channel], counts: dict[int, int]
    ) -> None:
        """One `ChannelInfo` per topic; a topic's channels are read as one, and two of
        ours under other schemas are not one trial."""
        for cid, channel in sorted(channels.items()):
            self._topics[cid] = channel.topic
            schema = schemas.get(channel.schema_id)
            info = ChannelInfo(
                channel.topic,
                schema.name if schema else "",
                channel.message_encoding,
                counts.get(cid, 0),
            )
            if (seen := self.channels.get(channel.topic)) is None:
                self.channels[channel.topic] = info
                continue
            ours = channel.topic in wk.SCHEMAS  # another tool's topics are only counted
            if ours and (seen.schema, seen.encoding) != (info.schema, info.encoding):
                raise TrialFormatError(
                    f"two channels of this topic with other schemas ({seen.schema}, "
                    f"{info.schema}); the file is not one trial",
                    path=self.path,
                    channel=channel.topic,
                )
            self.channels[channel.topic] = replace(seen, count=seen.count + info.count)

    def messages(
        self,
        topics: Collection[str],
        start: int | None = None,
        stop: int | None = None,
        *,
        in_log_order: bool = True,
    ) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time ns, payload) of `topics` logged in [start, stop), in log-time
        order or (cheaper: no merging of chunks that overlap in time) in file order; a file
        without an index in file order always."""
        if self._stream is None:
            raise TrialFormatError("reader is not open", path=self.path)
        return self._read(set(topics), start, stop, in_log_order)

    def _read(
        self, wanted: set[str], start: int | None, stop: int | None, in_log_order: bool
    ) -> Iterator[tuple[str, int, bytes]]:
        with self._damage():
            if self._reader is not None and in_log_order:
                found = self._reader.iter_messages(
                    topics=sorted(wanted), starting_at=start, ending_before=stop
                )
                for _, channel, message in found:
                    yield channel.topic, message.log_time, message.data
                return
            if self._reader is not None:
                yield from self._chunk_by_chunk(wanted, start, stop)
                return
            for record in self._records():
                if not isinstance(record, Message):
                    continue
                topic = self._topics.get(record.channel_id)
                t = record.log_time
                if topic in wanted and (start is None or t >= start) and (stop is None or t < stop):
                    yield topic, t, record.data

    def _chunk_by_chunk(
        self, wanted: set[str], start: int | None, stop: int | None
    ) -> Iterator[tuple[str, int, bytes]]:
        """The messages of the chunks that may hold `wanted` in [start, stop), one chunk at a
        time in file order. mcap's reader in file order queues every message of the file
        before it yields the first (1.5 GB for a 30-minute trial); in log-time order it
        holds only the chunks that overlap in time, but merges message by message (a
        third of a read's time)."""
        assert self._reader is not None and self._stream is not None
        summary = self._reader.get_summary()
        assert summary is not None
        ids = {cid for cid, topic in self._topics.items() if topic in wanted}
        for index in sorted(summary.chunk_indexes, key=lambda i: i.chunk_start_offset):
            if start is not None and index.message_end_time < start:
                continue
            if stop is not None and index.message_start_time >= stop:
                continue
            if index.message_index_offsets and not ids & index.message_index_offsets.keys():
                continue  # indexed, and none of ours (without indexes: read to know)
            self._stream.seek(index.chunk_start_offset + 1 + 8)  # past opcode and length
            chunk = Chunk.read(ReadDataStream(self._stream))
            for record in breakup_chunk(chunk, validate_crc=True):
                if not isinstance(record, Message) or record.channel_id not in ids:
                    continue
                t = record.log_time
                if (start is None or t >= start) and (stop is None or t < stop):
                    yield self._topics[record.channel_id], t, record.data


def file_summary(path: str | Path) -> tuple[str, Summary, bool] | None:
    """An MCAP file's profile, its summary section and whether it holds a `dresslog`
    metadata record (or the channel `/dresslog/metadata`), read without its messages;
    None for a file with none of that to read (not MCAP, cut short, no summary section),
    which a whole read explains."""
    try:
        with Path(path).open("rb") as stream:
            if stream.read(len(MAGIC)) != MAGIC:
                return None
            stream.seek(0)
            reader = make_reader(stream)
            profile, summary = reader.get_header().profile, reader.get_summary()
    except (OSError, McapError, ValueError, EOFError, struct.error):
        return None
    if summary is None:
        return None
    ours = any(index.name == wk.METADATA_NAME for index in summary.metadata_indexes) or any(
        channel.topic == wk.METADATA_TOPIC for channel in summary.channels.values()
    )  # the record, or its copy on the channel that generic tools keep
    return profile, summary, ours


def summary_counts(path: str | Path) -> dict[str, int] | None:
    """Messages per topic of a dresslog file, from its summary section alone: None for a
    file that is not one (not MCAP, cut short, no summary or statistics, no `dresslog`
    metadata record).

    For a question a whole read would answer at the cost of the file's size in memory:
    a 30-minute estimate copy, read to see it is one, took 600 MB and 8 s.
    """
    found = file_summary(path)
    if found is None:
        return None
    _, summary, ours = found
    if summary.statistics is None or not ours:
        return None
    counts = summary.statistics.channel_message_counts
    topics: dict[str, int] = {}
    for cid, channel in summary.channels.items():
        topics[channel.topic] = topics.get(channel.topic, 0) + counts.get(cid, 0)
    return topics
