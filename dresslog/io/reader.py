"""`TrialReader`: a dresslog MCAP trial back as numpy streams and its metadata.

Opening reads the file once, checks it is a trial (our channels with our
schemas, the metadata record) and keeps the raw payloads; each stream is
decoded on first use with the vectorised codec. Every problem becomes one
`TrialFormatError` naming the file, and the channel where there is one.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, replace
from functools import cache, cached_property
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, BinaryIO, NoReturn, Self

import numpy as np
from mcap.exceptions import McapError
from mcap.records import Channel, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from pydantic import ValidationError
from zstandard import ZstdError

from dresslog.errors import TrialFormatError, first_problem
from dresslog.io import cdr, jsontext
from dresslog.io import well_known as wk
from dresslog.io.files import NOT_REGULAR, no_such
from dresslog.spec import RECORDED, TRIAL_FORMAT_VERSION, Task, TrialMetadata
from dresslog.trial import (
    CONTACT_DTYPE,
    STEP_HZ,
    Contacts,
    ForceMaps,
    GarmentStates,
    LimbPoints,
    Measurements,
    Stream,
    Trial,
    measurements,
    median_rate,
)

if TYPE_CHECKING:
    from mcap.summary import Summary

MAGIC = b"\x89MCAP0\r\n"
#: How a Rerun recording (.rrd) begins, so `infer`'s output given back as a trial is named.
RRD_MAGIC = b"RRF"
CONVERT_HINT = "for a ROS bag or a force/torque CSV, run `dresslog convert` first"


#: How many folders of trials a folder's hint names before it counts the rest.
_HINT_FOLDERS = 3


def _folder_hint(folder: Path) -> str:
    """A folder of trials (a day's, a dataset split) is given by its files, and one whose
    trials lie in subfolders (a dataset's splits, a sweep's settings) by theirs; a model's
    (safetensors weights) with --model; a bag folder (metadata.yaml beside its storage) or
    one holding no trials is converted first."""
    if (folder / "metadata.yaml").exists():
        return CONVERT_HINT
    if any(folder.glob("*.safetensors")):  # weights: a model's folder
        return "a model's (it holds weights): give it with --model, after a trial"
    held = [folder]
    if not any(folder.glob("*.mcap")):  # its subfolders', or theirs where a subfolder has none
        near = {p.parent for p in folder.glob("*/*.mcap")}
        far = {p.parent for p in folder.glob("*/*/*.mcap") if p.parent.parent not in near}
        held = sorted(near | far)
    if not held:
        return CONVERT_HINT
    named = " ".join(str(f / "*.mcap") for f in held[:_HINT_FOLDERS])
    more = len(held) - _HINT_FOLDERS
    return f"give its trials, {named}" + (f" (and {more} more folders)" if more > 0 else "")


def _stamp_problem(stamps: np.ndarray) -> str:
    """What makes a channel's sorted header stamps not one step each: all unset, some
    repeated, or negative; "" if nothing."""
    repeated = np.flatnonzero(np.diff(stamps) == 0)
    if len(stamps) > 1 and stamps[0] == stamps[-1]:
        return f"all {len(stamps)} messages have the header stamp {stamps[0]} ns, unset"
    if len(repeated):
        return (
            f"{len(repeated)} messages repeat another's header stamp (the first "
            f"{stamps[repeated[0]] / 1e9:.6g} s), and a step is one stamp"
        )
    if stamps[0] < 0:
        return f"header stamp {stamps[0]} ns is negative"
    return ""


def _backwards(log_ns: list[int], stamps: np.ndarray) -> str:
    """Where a channel's header stamps, in the order its messages were logged, go back: a
    clock that jumped back (sorted, its steps would interleave with the earlier ones as a
    channel at twice the rate, or repeat their stamps); "" if they never do."""
    in_log_order = stamps[np.argsort(np.asarray(log_ns, dtype=np.int64), kind="stable")]
    back = np.flatnonzero(np.diff(in_log_order) < 0)
    if not len(back):
        return ""
    i, first = int(back[0]) + 1, in_log_order[0]
    was, now = (in_log_order[i - 1] - first) / 1e9, (in_log_order[i] - first) / 1e9
    more = f" ({len(back)} times in all)" if len(back) > 1 else ""
    return (
        f"header stamps go backwards at message {i} of {len(stamps)} in the order logged, "
        f"from {was:.3f} s to {now:.3f} s (counted from the first stamp){more}: its clock "
        "jumped back, and a step is one time"
    )


def off_rate(rate: float) -> str:
    """Why a channel at `rate` Hz cannot be the model's input (its steps are `STEP_HZ`)."""
    return (
        f"is at {rate:.4g} Hz, and the model reads {STEP_HZ} Hz steps; "
        "resample the log onto them with `dresslog convert`"
    )


#: What to do about a trial whose steps are not the model's: make it again.
_CURE = "re-record it, or re-convert its log"


@cache
def _task_points(task: Task) -> int:
    """How many force-map points the limb of `task` has (300 on the arm, 400 on the leg)."""
    from dresslog.limb import build_limb  # lazily: the limb's geometry is not a reader's

    return sum(build_limb(task).points_per_part.values())


def _seconds(t_ns: int | np.integer, origin: int | np.integer) -> str:
    return f"{(int(t_ns) - int(origin)) / 1e9:.3f} s"


def _input_problem(wrench: np.ndarray, twist: np.ndarray) -> tuple[str, str] | None:
    """(channel, problem and cure) of the model's two input channels' sorted stamps when they do
    not give one run of steps that both cover: at other rates, a hole in either, or one
    ending or starting while the other goes on. None if they do (or share no stamp at
    all, which `measurements` words itself). Times count from the trial's first step."""
    origin = min(wrench[0], twist[0])
    channels = ((wk.WRENCH, wrench), (wk.TWIST, twist))
    rates = {topic: median_rate(t) for topic, t in channels}
    if all(rates.values()) and abs(rates[wk.WRENCH] / rates[wk.TWIST] - 1) > 0.02:
        topic = next((t for t, r in rates.items() if abs(STEP_HZ / r - 1) > 0.02), wk.TWIST)
        return topic, off_rate(rates[topic])
    for topic, t_ns in channels:
        if len(t_ns) < 3:
            continue
        steps = np.diff(t_ns)
        step = np.median(steps)
        if len(holes := np.flatnonzero(steps > 1.5 * step)):
            at = holes[0]
            more = f"; {len(holes)} gaps in all" if len(holes) > 1 else ""
            return topic, (
                f"has a gap: no message between {_seconds(t_ns[at], origin)} and "
                f"{_seconds(t_ns[at + 1], origin)} ({(steps[at] - step) / 1e9:.3g} s, "
                f"{round(steps[at] / step) - 1} steps missing{more}), and the model would read "
                f"the steps either side as consecutive; {_CURE}"
            )
    common = np.intersect1d(wrench, twist)
    if not len(common):
        return None
    for (topic, t_ns), (other, with_it) in zip(channels, channels[::-1], strict=True):
        alone = np.setdiff1d(t_ns, with_it)
        if not len(alone):
            continue
        if alone[0] > with_it[-1]:
            return other, (
                f"stops at {_seconds(with_it[-1], origin)}, {(t_ns[-1] - with_it[-1]) / 1e9:.3g} "
                f"s before {topic} does: the last {len(alone)} of {len(t_ns)} {topic} steps have "
                f"no {other} message, and the model reads both on every step; {_CURE}"
            )
        if alone[-1] < with_it[0]:
            return other, (
                f"starts at {_seconds(with_it[0], origin)}, {(with_it[0] - t_ns[0]) / 1e9:.3g} s "
                f"after {topic} does: the first {len(alone)} of {len(t_ns)} {topic} steps have "
                f"no {other} message, and the model reads both on every step; {_CURE}"
            )
        return other, (
            f"has no message of the stamp of {len(alone)} of {len(t_ns)} {topic} steps (the "
            f"first at {_seconds(alone[0], origin)}), and the model reads both on every step; "
            + _CURE
        )
    return None


@dataclass(frozen=True)
class ChannelInfo:
    """One channel of the file: its schema, encoding and message count."""

    topic: str
    schema: str
    encoding: str
    count: int


@dataclass
class _Raw:
    info: ChannelInfo
    times: list[int]
    payloads: list[bytes]


class TrialReader:
    """Read one trial; use as a context manager."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._raw: dict[str, _Raw] | None = None
        self._metadata: TrialMetadata | None = None

    # -- lifecycle -------------------------------------------------------------
    def open(self) -> Self:
        for name, member in vars(TrialReader).items():  # reopened: the file may be another
            if isinstance(member, cached_property):
                self.__dict__.pop(name, None)
        self._raw = self._metadata = None  # and an open that fails leaves nothing to read
        if not self.path.exists():
            raise TrialFormatError(no_such(self.path), path=self.path)
        if self.path.is_dir():
            raise TrialFormatError(f"is a folder, not an MCAP file; {_folder_hint(self.path)}",
                                   path=self.path)  # fmt: skip
        if not self.path.is_file():  # read again from its start after the magic: not a pipe
            raise TrialFormatError(NOT_REGULAR, path=self.path)
        with self.path.open("rb") as stream:
            head = stream.read(len(MAGIC))
            if not head:
                raise TrialFormatError("file is empty", path=self.path)
            if head.startswith(RRD_MAGIC):
                raise TrialFormatError(
                    "is a Rerun recording, not a trial; open it with `dresslog view`",
                    path=self.path,
                )
            if head != MAGIC:
                raise TrialFormatError(f"not an MCAP file; {CONVERT_HINT}", path=self.path)
            stream.seek(0)
            self._raw, metadata = self._scan(stream)
        try:
            self._check_channels(metadata)
            self._metadata = self._parse_metadata(metadata)
            self._put_in_stamp_order()
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        self._raw = None

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _scan(self, stream: BinaryIO) -> tuple[dict[str, _Raw], dict[str, str] | None]:
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        messages: dict[int, tuple[list[int], list[bytes]]] = {}
        metadata: dict[str, str] | None = None
        complete = False
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, Message):
                    times, payloads = messages.setdefault(record.channel_id, ([], []))
                    times.append(record.log_time)
                    payloads.append(record.data)
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Metadata) and record.name == wk.METADATA_NAME:
                    metadata = record.metadata
                elif isinstance(record, DataEnd | Footer):
                    complete = True
                    break
        except (McapError, ValueError, EOFError, OverflowError, struct.error, ZstdError) as err:
            detail = f"{type(err).__name__}: {err}" if str(err) else type(err).__name__
            raise TrialFormatError(
                f"MCAP file is damaged or truncated ({detail}); "
                "re-record it, or salvage it with `mcap recover`",
                path=self.path,
            ) from None
        if not complete:
            raise TrialFormatError(
                "MCAP file is truncated (no end record); it was not closed cleanly: "
                "re-record it, or salvage it with `mcap recover`",
                path=self.path,
            )
        raw: dict[str, _Raw] = {}
        for cid, channel in sorted(channels.items()):  # a topic's channels are read as one
            times, payloads = messages.get(cid, ([], []))
            schema = schemas.get(channel.schema_id)
            info = ChannelInfo(
                channel.topic, schema.name if schema else "", channel.message_encoding, len(times)
            )
            if (seen := raw.get(channel.topic)) is None:
                raw[channel.topic] = _Raw(info, list(times), list(payloads))
                continue
            ours = channel.topic in wk.SCHEMAS  # another tool's topics are only counted
            if ours and (seen.info.schema, seen.info.encoding) != (info.schema, info.encoding):
                raise TrialFormatError(
                    f"two channels of this topic with other schemas ({seen.info.schema}, "
                    f"{info.schema}); the file is not one trial",
                    path=self.path,
                    channel=channel.topic,
                )
            seen.times += times
            seen.payloads += payloads
            seen.info = replace(seen.info, count=len(seen.times))
        return raw, metadata

    def _put_in_stamp_order(self) -> None:
        """Order each of our channels by header stamp; refuse a stamp that repeats.

        MCAP does not promise messages in time order (a merged or re-written file), and a
        step is matched across channels by its stamp, so two messages of one stamp (a
        driver that never set its headers, a message written twice) have no one meaning.
        """
        assert self._raw is not None
        for topic, raw in self._raw.items():
            head = cdr.heads(raw.payloads) if topic in wk.SCHEMAS and raw.payloads else None
            if head is None:
                continue  # not ours, empty, or a message too short: decoding says so
            kind = head["encapsulation"][:, :2]
            if len(foreign := np.flatnonzero((kind != (0, 1)).any(axis=1))):
                raise TrialFormatError(
                    f"message {foreign[0]} is not plain little-endian CDR (its encapsulation "
                    f"header is {raw.payloads[foreign[0]][:2].hex(' ')}, not 00 01); write it "
                    "as ROS 2 does on x86 and ARM",
                    path=self.path,
                    channel=topic,
                )
            stamps = cdr.stamp_ns(head)
            if topic != wk.LIMB_POINTS and (back := _backwards(raw.times, stamps)):
                raise TrialFormatError(f"{back}; {_CURE}", path=self.path, channel=topic)
            order = np.argsort(stamps, kind="stable")
            if (np.diff(order) != 1).any():
                raw.times = [raw.times[i] for i in order]
                raw.payloads = [raw.payloads[i] for i in order]
                stamps = stamps[order]
            # limb points are sent once; only the first is read
            if topic != wk.LIMB_POINTS and (problem := _stamp_problem(stamps)):
                raise TrialFormatError(
                    f"{problem}; re-record it, or re-convert its log (`dresslog convert` drops "
                    "messages logged twice, and with --clock log takes receive times)",
                    path=self.path,
                    channel=topic,
                )

    def _check_channels(self, metadata: dict[str, str] | None) -> None:
        """Refuse a file without our required channels, or with ours under another schema."""
        assert self._raw is not None
        if not any(raw.info.count for raw in self._raw.values()):
            empty = ", ".join(sorted(self._raw))
            what = f" (its channels {empty} are empty)" if empty else ""
            if metadata is None:
                raise TrialFormatError(
                    f"holds no messages{what} and no `{wk.METADATA_NAME}` metadata record: "
                    f"an empty MCAP file, not a trial; {CONVERT_HINT}",
                    path=self.path,
                )
            raise TrialFormatError(
                f"holds no messages{what}: a trial with no step; re-record it", path=self.path
            )
        missing = [t for t in wk.REQUIRED if t not in self._raw]
        if missing and (metadata is None or not any(t in self._raw for t in wk.SCHEMAS)):
            topics = ", ".join(sorted(self._raw)) or "none"
            raise TrialFormatError(
                f"not a dresslog trial (channels: {topics}); {CONVERT_HINT}", path=self.path
            )
        if missing:
            raise TrialFormatError(
                f"missing channel {missing[0]}; the model needs end-effector wrench and twist",
                path=self.path,
            )
        for topic, raw in self._raw.items():
            expected = wk.SCHEMAS.get(topic)
            if expected and (raw.info.schema, raw.info.encoding) != (expected, wk.MESSAGE_ENCODING):
                raise TrialFormatError(
                    f"has schema {raw.info.schema or 'none'} ({raw.info.encoding}), "
                    f"expected {expected} (cdr)",
                    path=self.path,
                    channel=topic,
                )

    def _parse_metadata(self, metadata: dict[str, str] | None) -> TrialMetadata:
        """The trial's metadata from the `dresslog` record, or why it cannot be read."""
        if metadata is None:
            raise TrialFormatError(
                f"has no `{wk.METADATA_NAME}` metadata record; {CONVERT_HINT}", path=self.path
            )
        if "trial" not in metadata:
            raise TrialFormatError(
                f"`{wk.METADATA_NAME}` metadata record has no `trial` entry", path=self.path
            )
        try:
            entry = jsontext.loads(metadata["trial"])
            version = entry.get("format_version") if isinstance(entry, dict) else None
            if isinstance(version, int) and version > TRIAL_FORMAT_VERSION:
                raise TrialFormatError(
                    f"written by a newer dresslog (trial format {version}; this one reads "
                    f"{TRIAL_FORMAT_VERSION}); upgrade dresslog",
                    path=self.path,
                )
            return TrialMetadata.model_validate(entry, context=RECORDED)
        except ValidationError as err:
            problem = first_problem(err, "metadata")
            message = f"metadata record is invalid: {problem}"
            raise TrialFormatError(message, path=self.path) from None
        except ValueError as err:  # not JSON, NaN, nested past reading
            first = str(err).splitlines()[0]
            raise TrialFormatError(f"metadata record is invalid: {first}", path=self.path) from None

    # -- contents --------------------------------------------------------------
    def _opened(self) -> dict[str, _Raw]:
        if self._raw is None:
            raise TrialFormatError("reader is not open", path=self.path)
        return self._raw

    def _channel(self, topic: str) -> _Raw:
        if topic not in (raw := self._opened()):
            raise TrialFormatError(f"has no channel {topic}", path=self.path)
        return raw[topic]

    @property
    def metadata(self) -> TrialMetadata:
        self._opened()
        assert self._metadata is not None
        return self._metadata

    @property
    def channels(self) -> dict[str, ChannelInfo]:
        """Every channel in the file, ours or not, by topic."""
        return {topic: raw.info for topic, raw in sorted(self._opened().items())}

    def has(self, topic: str) -> bool:
        raw = self._opened().get(topic)
        return raw is not None and raw.info.count > 0

    def messages(self, topic: str) -> tuple[np.ndarray, list[bytes]]:
        """Raw log times (int64 ns) and CDR payloads of one channel (dresslog's own in
        header-stamp order, another tool's as in the file)."""
        raw = self._channel(topic)
        return np.asarray(raw.times, dtype=np.int64), raw.payloads

    def _decode(self, topic: str) -> list[np.ndarray]:
        _, payloads = self.messages(topic)
        try:
            return cdr.decode(wk.SCHEMAS[topic], payloads)
        except cdr.MessageError as err:
            raise TrialFormatError(
                f"message {err.index} of {err.count} does not match its schema: {err.problem}; "
                "the recording is corrupt, re-record or re-convert it",
                path=self.path,
                channel=topic,
            ) from None
        except (ValueError, KeyError) as err:
            raise TrialFormatError(
                f"message does not match its schema: {err}", path=self.path, channel=topic
            ) from None

    def _vectors(self, topic: str) -> Stream:
        if not self.has(topic):
            return Stream(np.zeros(0, np.int64), np.zeros((0, 6)))
        msgs = np.concatenate(self._decode(topic))
        values = np.concatenate([msgs[f] for f in wk.VECTOR_FIELDS[topic]], axis=1)
        bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
        if len(bad):
            raise TrialFormatError(
                f"NaN or infinite value in message {bad[0]} of {len(values)}; "
                "the recording is corrupt, re-record or re-convert it",
                path=self.path,
                channel=topic,
            )
        return Stream(cdr.stamp_ns(msgs), values)

    @cached_property
    def wrench(self) -> Stream:
        """(T, 6) force and torque the garment applies at the end effector."""
        return self._vectors(wk.WRENCH)

    @cached_property
    def twist(self) -> Stream:
        """(T, 6) end-effector linear and angular velocity."""
        return self._vectors(wk.TWIST)

    @cached_property
    def pose(self) -> Stream | None:
        """(T, 7) end-effector position and quaternion x y z w."""
        if not self.has(wk.POSE):
            return None
        return self._vectors(wk.POSE)

    @cached_property
    def measurements(self) -> Measurements:
        """The network input phi_t (T, 9) on the steps of wrench and twist; refused unless
        both cover one run of steps (a gap in either, or one that stops or starts while the
        other goes on, would be fed to the model as consecutive steps, or dropped)."""
        if len(self.wrench) and len(self.twist):
            found = _input_problem(self.wrench.t_ns, self.twist.t_ns)
            if found is not None:
                topic, problem = found
                raise TrialFormatError(problem, path=self.path, channel=topic)
        steps = measurements(self.wrench, self.twist)
        if not len(steps.t_ns):
            empty = [t for t, s in ((wk.WRENCH, self.wrench), (wk.TWIST, self.twist)) if not len(s)]
            problem = (
                f"channel {empty[0]} has no messages"
                if empty
                else f"no {wk.WRENCH} message has a {wk.TWIST} message of the same stamp"
            )
            raise TrialFormatError(
                f"{problem}, so there is no step to run the model on; re-record or re-convert it",
                path=self.path,
            )
        return steps

    def force_maps(self, *, estimate: bool = False) -> ForceMaps | None:
        """Ground-truth force maps, or a model's estimate with its contact map."""
        topic = wk.ESTIMATE if estimate else wk.FORCE_MAP
        if not self.has(topic):
            return None
        runs = self._decode(topic)
        widths = {run["forces"].shape[1] for run in runs}
        if len(widths) != 1:
            raise TrialFormatError(
                f"force maps change size ({sorted(widths)})", path=self.path, channel=topic
            )
        msgs = np.concatenate(runs)
        maps = ForceMaps(cdr.stamp_ns(msgs), msgs["forces"].copy(), msgs["contact"].copy())
        bad = np.flatnonzero(~np.isfinite(maps.forces).all(axis=1))
        if len(bad) or not np.isfinite(maps.contact).all():
            at = f" in message {bad[0]} of {len(msgs)}" if len(bad) else " in a contact map"
            self._corrupt(f"NaN or infinite value{at}", topic)
        limb = self.limb_points
        width = maps.forces.shape[1]
        if limb is not None and width != len(limb.points):
            self._corrupt(
                f"force maps have {width} values but {wk.LIMB_POINTS} has "
                f"{len(limb.points)} points",
                topic,
            )
        task, wanted = self.metadata.task.value, _task_points(self.metadata.task)
        if width != wanted and limb is None:  # drawn on the task's limb, which it does not fit
            raise TrialFormatError(
                f"force maps have {width} values but the trial has no {wk.LIMB_POINTS} and the "
                f"{task}'s limb has {wanted} points; write its limb points with the maps",
                path=self.path,
                channel=topic,
            )
        if width != wanted:  # the trial's fault, not that of a model that fits its task
            what = "estimate" if estimate else "force map"
            self._corrupt(
                f"the trial's {what} has {width} points where a {task} trial has {wanted} (its "
                f"{wk.LIMB_POINTS} too): its task or its maps are wrong",
                topic,
            )
        return maps

    def _check_limb(self) -> None:
        """Refuse limb points of another number than the trial's task's limb has: a model
        of that task would be blamed for not fitting them."""
        limb, wanted = self.limb_points, _task_points(self.metadata.task)
        if limb is not None and len(limb) != wanted:
            self._corrupt(
                f"the trial's limb has {len(limb)} points where a {self.metadata.task.value} "
                f"trial has {wanted}: its task or its limb points are wrong",
                wk.LIMB_POINTS,
            )

    @cached_property
    def force_map(self) -> ForceMaps | None:
        return self.force_maps()

    @cached_property
    def estimate(self) -> ForceMaps | None:
        return self.force_maps(estimate=True)

    @cached_property
    def contacts(self) -> Contacts | None:
        """Per-step garment-limb contacts (CONTACT_DTYPE arrays)."""
        if not self.has(wk.CONTACTS):
            return None
        items: list[np.ndarray] = []
        times: list[np.ndarray] = []
        for run in self._decode(wk.CONTACTS):
            times.append(cdr.stamp_ns(run))
            items.extend(np.asarray(c, dtype=CONTACT_DTYPE) for c in run["contacts"])
        # all in one array: a check per contact costs ms
        joined = np.frombuffer(b"".join(c.tobytes() for c in items), dtype=CONTACT_DTYPE)
        if not all(np.isfinite(joined[name]).all() for name in wk.CONTACT_REALS):
            self._corrupt("NaN or infinite value in a contact", wk.CONTACTS)
        return Contacts(np.concatenate(times), items)

    @cached_property
    def limb_points(self) -> LimbPoints | None:
        """The force-map sites, from the first `/limb/points` message."""
        if not self.has(wk.LIMB_POINTS):
            return None
        msg = self._decode(wk.LIMB_POINTS)[0][0]
        count = int(msg["segment_names.len"])
        names = tuple(msg[f"segment_names.{i}"].decode() for i in range(count))
        if not np.isfinite(msg["points"]).all():
            self._corrupt("NaN or infinite limb point", wk.LIMB_POINTS)
        return LimbPoints(msg["limb"].decode(), msg["points"].copy(), msg["segment"].copy(), names)

    @cached_property
    def garment(self) -> GarmentStates | None:
        """Garment vertices over time and the triangles from the first message."""
        if not self.has(wk.GARMENT):
            return None
        runs = self._decode(wk.GARMENT)
        msgs = [m for run in runs for m in run]
        corners = msgs[0]["triangles"].astype(np.int64)
        counts = sorted({len(m["vertices"]) for m in msgs})
        problem = f"the garment changes size ({counts} vertices)" if len(counts) > 1 else ""
        if not problem and len(corners) % 3:
            problem = f"{len(corners)} triangle corners, not a multiple of 3"
        if not problem and len(corners) and corners.max() >= counts[0]:
            problem = f"a triangle names vertex {corners.max()} of {counts[0]}"
        if not problem and not all(np.isfinite(m["vertices"]).all() for m in msgs):
            problem = "NaN or infinite vertex"
        if problem:
            self._corrupt(problem, wk.GARMENT)
        vertices = np.stack([m["vertices"] for m in msgs]).astype(np.float32)
        triangles = corners.reshape(-1, 3)
        return GarmentStates(np.concatenate([cdr.stamp_ns(r) for r in runs]), vertices, triangles)

    def _corrupt(self, problem: str, topic: str) -> NoReturn:
        raise TrialFormatError(
            f"{problem}; the recording is corrupt, re-record it", path=self.path, channel=topic
        )

    def read(self) -> Trial:
        """Every stream in memory at once (a trial with no step to run on is refused)."""
        _ = self.measurements  # refuses a file with no step
        force_map, estimate = self.force_map, self.estimate
        self._check_limb()
        return Trial(
            metadata=self.metadata,
            wrench=self.wrench,
            twist=self.twist,
            pose=self.pose,
            force_map=force_map,
            estimate=estimate,
            contacts=self.contacts,
            limb_points=self.limb_points,
            garment=self.garment,
        )


def read_trial(path: str | Path) -> Trial:
    """Read a whole trial file."""
    with TrialReader(path) as reader:
        return reader.read()


def file_summary(path: str | Path) -> tuple[str, Summary, bool] | None:
    """An MCAP file's profile, its summary section and whether it holds a `dresslog`
    metadata record, read without its messages; None for a file with none of that to
    read (not MCAP, cut short, no summary section), which a whole read explains."""
    from mcap.reader import make_reader

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
    ours = any(index.name == wk.METADATA_NAME for index in summary.metadata_indexes)
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
