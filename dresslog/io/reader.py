"""`TrialReader`: a dresslog MCAP trial back as numpy streams and its metadata.

Opening reads the file's summary and metadata and checks it is a trial (our channels with
our schemas, the metadata); nothing else is held. Messages are read on demand through the
MCAP index (`McapSource`): `messages(topics, start, stop)` yields them one by one, and
each whole-stream property (`wrench`, `force_map`, ...) reads and decodes its channel when
first asked, block by block with the vectorised codec, checking as it goes. Every problem
becomes one `TrialFormatError` naming the file, and the channel where there is one.

Times are presented from the trial's start: a file's stamps count from the origin its
metadata names (`TrialMetadata.time_origin_ns`, 2020-01-01 in files of format 2, 0 before),
and the reader takes it off, so files of either kind read the same.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from types import TracebackType
from typing import NoReturn, Self

import numpy as np

from dresslog.errors import TrialFormatError
from dresslog.io import cdr
from dresslog.io import well_known as wk
from dresslog.io.checks import (
    CONVERT_HINT,
    CURE,
    backwards,
    folder_hint,
    input_problem,
    off_rate,
    stamp_problem,
    task_points,
)
from dresslog.io.files import NOT_REGULAR, no_such
from dresslog.io.opening import check_channels, has_metadata_channel, trial_metadata
from dresslog.io.source import MAGIC, ChannelInfo, McapSource, file_summary, summary_counts
from dresslog.spec import TrialMetadata
from dresslog.trial import (
    CONTACT_DTYPE,
    Contacts,
    ForceMaps,
    GarmentStates,
    LimbPoints,
    Measurements,
    Stream,
    Trial,
    measurements,
)

__all__ = [
    "CONVERT_HINT",
    "MAGIC",
    "ChannelInfo",
    "TrialMessage",
    "TrialReader",
    "file_summary",
    "off_rate",
    "read_trial",
    "summary_counts",
]

#: How a Rerun recording (.rrd) begins, so `infer`'s output given back as a trial is named.
RRD_MAGIC = b"RRF"
#: The cached property that holds each channel's stream: `read` reads ahead those not read.
_PROPERTY = {
    wk.WRENCH: "wrench",
    wk.TWIST: "twist",
    wk.POSE: "pose",
    wk.FORCE_MAP: "force_map",
    wk.ESTIMATE: "estimate",
    wk.CONTACTS: "contacts",
    wk.LIMB_POINTS: "limb_points",
    wk.GARMENT: "garment",
}
#: Messages of one channel decoded at once: their payloads are all a read holds undecoded.
BLOCK = 8192


@dataclass(frozen=True)
class TrialMessage:
    """One message as `TrialReader.messages` yields it: its topic, its log time from the
    trial's start (ns) and its CDR payload, decoded when asked."""

    topic: str
    t_ns: int
    data: bytes

    def decode(self) -> np.ndarray:
        """The message as a numpy record of its schema's layout (dresslog's topics only)."""
        schema = wk.SCHEMAS.get(self.topic) or wk.UNSTAMPED.get(self.topic)
        if schema is None:
            raise TrialFormatError(f"{self.topic} is not a dresslog topic; its payload is CDR")
        return cdr.decode(schema, [self.data])[0][0]


class _Gathered:
    """One channel's messages decoded as they are read: runs of one layout (none if only
    checked), their log times and stamps, and the payloads of the block not yet decoded."""

    def __init__(self, check_only: bool = False) -> None:
        self.check_only = check_only
        self.runs: list[np.ndarray] = []
        self.log_ns: list[np.ndarray] = []
        self.stamps: list[np.ndarray] = []
        self.block: list[bytes] = []
        self.block_log: list[int] = []
        self.decoded = 0


class TrialReader:
    """Read one trial; use as a context manager."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._source: McapSource | None = None
        self._metadata: TrialMetadata | None = None
        self._origin = 0
        self._pending: dict[str, list[np.ndarray]] = {}  # read ahead by `read`, not yet taken
        self._widths: dict[str, int] = {}  # per channel checked block by block: its width
        self._block: tuple[int, int] | None = None  # the block checked: first message, of all

    # -- lifecycle -------------------------------------------------------------
    def open(self) -> Self:
        for name, member in vars(TrialReader).items():  # reopened: the file may be another
            if isinstance(member, cached_property):
                self.__dict__.pop(name, None)
        self.close()  # and an open that fails leaves nothing to read
        if not self.path.exists():
            raise TrialFormatError(no_such(self.path), path=self.path)
        if self.path.is_dir():
            raise TrialFormatError(f"is a folder, not an MCAP file; {folder_hint(self.path)}",
                                   path=self.path)  # fmt: skip
        if not self.path.is_file():  # read again from its start after the magic: not a pipe
            raise TrialFormatError(NOT_REGULAR, path=self.path)
        with self.path.open("rb") as stream:
            head = stream.read(len(MAGIC))
        if not head:
            raise TrialFormatError("file is empty", path=self.path)
        if head.startswith(RRD_MAGIC):
            raise TrialFormatError(
                "is a Rerun recording, not a trial; open it with `dresslog view`", path=self.path
            )
        if head != MAGIC:
            raise TrialFormatError(f"not an MCAP file; {CONVERT_HINT}", path=self.path)
        self._source = McapSource(self.path)
        try:
            self._source.open()
            has_record = wk.METADATA_NAME in self._source.metadata
            check_channels(self._source, has_record or has_metadata_channel(self._source))
            self._metadata = trial_metadata(self._source)
            self._origin = self._metadata.time_origin_ns
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        if self._source is not None:
            self._source.close()
        self._source = None
        self._pending = {}

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- reading on demand -----------------------------------------------------
    def _opened(self) -> McapSource:
        if self._source is None:
            raise TrialFormatError("reader is not open", path=self.path)
        return self._source

    def _known(self, topics: Iterable[str]) -> list[str]:
        channels = self._opened().channels
        wanted = list(topics)
        for topic in wanted:
            if topic not in channels:
                raise TrialFormatError(f"has no channel {topic}", path=self.path)
        return wanted

    def messages(
        self,
        topics: str | Iterable[str] | None = None,
        start: int | None = None,
        stop: int | None = None,
    ) -> Iterator[TrialMessage]:
        """The messages of `topics` (default: every channel) logged in [start, stop) ns from
        the trial's start, in log-time order, read from the file as they are yielded (only
        the chunks that hold them) and decoded when asked (`TrialMessage.decode`).

        Unlike the whole-stream properties this checks neither stamps nor values: it is
        the file as written (mcap's and rosbags' `messages`, on the trial's clock).
        """
        chosen = self._known(
            self._opened().channels if topics is None else [topics] if isinstance(topics, str)
            else topics
        )  # fmt: skip
        origin = self._origin
        low = None if start is None else start + origin
        high = None if stop is None else stop + origin
        found = self._opened().messages(chosen, low, high)  # refused now, read when iterated
        return (TrialMessage(topic, log_ns - origin, data) for topic, log_ns, data in found)

    def _read_ahead(self, topics: Iterable[str], check_only: Iterable[str] = ()) -> None:
        """Decode the channels of `topics` in one pass over the file, for the properties
        that take them (`read` asks for every stream, and a pass per channel would
        decompress the file once for each); those of `check_only` are checked block by
        block and let go (`check`)."""
        wanted = [t for t in topics if self.has(t) and t not in self._pending]
        only = set(check_only)
        gathered = {topic: _Gathered(topic in only) for topic in wanted}
        if not gathered:
            return
        # in file order: the stamps put them in order, and merging by log time costs more
        for topic, log_ns, data in self._opened().messages(wanted, in_log_order=False):
            into = gathered[topic]
            into.block.append(data)
            into.block_log.append(log_ns)
            if len(into.block) >= BLOCK:
                self._decode_block(topic, into)
        for topic, into in gathered.items():
            self._decode_block(topic, into)
            runs = self._in_stamp_order(topic, into)
            if not into.check_only:
                self._pending[topic] = runs

    def _decode_block(self, topic: str, into: _Gathered) -> None:
        """Decode the payloads gathered so far; refuse one not plain CDR or not its schema."""
        block, at, count = into.block, into.decoded, self._opened().channels[topic].count
        if not block:
            return
        head = cdr.heads(block)  # None: a message too short, which decoding words
        if head is not None:
            kind = head["encapsulation"][:, :2]
            if len(foreign := np.flatnonzero((kind != (0, 1)).any(axis=1))):
                raise TrialFormatError(
                    f"message {at + foreign[0]} is not plain little-endian CDR (its encapsulation "
                    f"header is {block[foreign[0]][:2].hex(' ')}, not 00 01); write it "
                    "as ROS 2 does on x86 and ARM",
                    path=self.path,
                    channel=topic,
                )
        try:
            runs = cdr.decode(wk.SCHEMAS[topic], block)
        except cdr.MessageError as err:
            raise TrialFormatError(
                f"message {at + err.index} of {count} does not match its schema: "
                f"{err.problem}; the recording is corrupt, re-record or re-convert it",
                path=self.path,
                channel=topic,
            ) from None
        except (ValueError, KeyError) as err:
            raise TrialFormatError(
                f"message does not match its schema: {err}", path=self.path, channel=topic
            ) from None
        into.log_ns.append(np.asarray(into.block_log, dtype=np.int64))
        into.decoded += len(block)
        into.block, into.block_log = [], []
        if into.check_only:
            into.stamps += [cdr.stamp_ns(run) for run in runs]
            self._block = into.decoded - len(block), self._opened().channels[topic].count
            try:
                self._check_block(topic, runs)
            finally:
                self._block = None
        else:
            into.runs += runs

    def _check_block(self, topic: str, runs: list[np.ndarray]) -> None:
        """Check one block of a channel as its property checks the whole, and that it has
        the width of the blocks before it; nothing of it is kept (`check`)."""
        self._pending[topic] = runs  # what the property's `_decode` takes
        if topic == wk.CONTACTS:
            self._contacts()
            return
        if topic == wk.GARMENT:
            width = len(self._garment().vertices[0])
            problem = "the garment changes size ({} vertices)"
        else:
            maps = self.force_maps(estimate=topic == wk.ESTIMATE)
            assert maps is not None
            width, problem = maps.forces.shape[1], "force maps change size ({})"
        first = self._widths.setdefault(topic, width)
        if first != width:
            self._corrupt(problem.format(sorted({first, width})), topic)

    def _in_stamp_order(self, topic: str, into: _Gathered) -> list[np.ndarray]:
        """A channel's decoded runs ordered by header stamp; refuse a stamp that repeats or
        a clock that went back.

        MCAP does not promise messages in time order (a merged or re-written file), and a
        step is matched across channels by its stamp, so two messages of one stamp (a
        driver that never set its headers, a message written twice) have no one meaning.
        """
        runs = into.runs
        stamps = np.concatenate(into.stamps or [cdr.stamp_ns(run) for run in runs])
        log_ns = np.concatenate(into.log_ns)
        if topic != wk.LIMB_POINTS and (back := backwards(log_ns, stamps)):
            raise TrialFormatError(f"{back}; {CURE}", path=self.path, channel=topic)
        order = np.argsort(stamps, kind="stable")
        if runs and (np.diff(order) != 1).any():  # a row per message, in order, joined again
            rows = [run[i : i + 1] for run in runs for i in range(len(run))]
            groups: list[list[np.ndarray]] = []
            for i in order:
                if groups and groups[-1][-1].dtype == rows[i].dtype:
                    groups[-1].append(rows[i])
                else:
                    groups.append([rows[i]])
            runs = [np.concatenate(group) for group in groups]
            stamps = stamps[order]
        # limb points are sent once; only the first is read
        if topic != wk.LIMB_POINTS and (problem := stamp_problem(stamps)):
            raise TrialFormatError(
                f"{problem}; re-record it, or re-convert its log (`dresslog convert` drops "
                "messages logged twice, and with --clock log takes receive times)",
                path=self.path,
                channel=topic,
            )
        return runs

    def _decode(self, topic: str) -> list[np.ndarray]:
        """A channel decoded, in stamp order, as runs of one layout (read now unless `read`
        read it ahead)."""
        if topic not in self._pending:
            self._read_ahead([topic])
        return self._pending.pop(topic)

    def _t_ns(self, messages: np.ndarray) -> np.ndarray:
        """Header stamps from the trial's start."""
        stamps = cdr.stamp_ns(messages)
        return stamps - self._origin if self._origin else stamps

    # -- contents --------------------------------------------------------------
    @property
    def metadata(self) -> TrialMetadata:
        self._opened()
        assert self._metadata is not None
        return self._metadata

    @property
    def channels(self) -> dict[str, ChannelInfo]:
        """Every channel in the file, ours or not, by topic."""
        return dict(sorted(self._opened().channels.items()))

    @property
    def origin_ns(self) -> int:
        """The stamp (ns since the Unix epoch) of the trial's time 0, which every time the
        reader gives is counted from: 2020-01-01 for a trial of format 2, 0 before."""
        self._opened()
        return self._origin

    def has(self, topic: str) -> bool:
        info = self._opened().channels.get(topic)
        return info is not None and info.count > 0

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
        return Stream(self._t_ns(msgs), values)

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
            found = input_problem(self.wrench.t_ns, self.twist.t_ns)
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
        msgs = runs[0] if len(runs) == 1 else np.concatenate(runs)
        del runs
        maps = ForceMaps(self._t_ns(msgs), msgs["forces"].copy(), msgs["contact"].copy())
        bad = np.flatnonzero(~np.isfinite(maps.forces).all(axis=1))
        if len(bad) or not np.isfinite(maps.contact).all():
            first, count = self._block or (0, len(msgs))  # a block's: counted in the channel
            at = f" in message {first + bad[0]} of {count}" if len(bad) else " in a contact map"
            self._corrupt(f"NaN or infinite value{at}", topic)
        limb = self.limb_points
        width = maps.forces.shape[1]
        if limb is not None and width != len(limb.points):
            self._corrupt(
                f"force maps have {width} values but {wk.LIMB_POINTS} has "
                f"{len(limb.points)} points",
                topic,
            )
        task, wanted = self.metadata.task.value, task_points(self.metadata.task)
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
        limb, wanted = self.limb_points, task_points(self.metadata.task)
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
        return self._contacts() if self.has(wk.CONTACTS) else None

    def _contacts(self) -> Contacts:
        items: list[np.ndarray] = []
        times: list[np.ndarray] = []
        for run in self._decode(wk.CONTACTS):
            times.append(self._t_ns(run))
            contacts = run["contacts"]  # (messages, contacts) of one count: checked at once
            if not all(np.isfinite(contacts[name]).all() for name in wk.CONTACT_REALS):
                self._corrupt("NaN or infinite value in a contact", wk.CONTACTS)
            items.extend(np.asarray(c, dtype=CONTACT_DTYPE) for c in contacts)  # views
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
        return self._garment() if self.has(wk.GARMENT) else None

    def _garment(self) -> GarmentStates:
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
        return GarmentStates(np.concatenate([self._t_ns(r) for r in runs]), vertices, triangles)

    def _corrupt(self, problem: str, topic: str) -> NoReturn:
        raise TrialFormatError(
            f"{problem}; the recording is corrupt, re-record it", path=self.path, channel=topic
        )

    def read(self) -> Trial:
        """Every stream in memory at once (a trial with no step to run on is refused), read
        in one pass over the file."""
        self._read_ahead(t for t, name in _PROPERTY.items() if name not in self.__dict__)
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

    def check(self) -> None:
        """Read and check every stream as `read` does, in one pass, keeping only the small
        ones: the force maps, contacts and garment are checked block by block and let go.
        What `info` does to pass only files `infer` runs on, in the memory of one block
        of them rather than of the whole `Trial`."""
        _ = self.limb_points  # small, and every map is checked against it
        heavy = [
            t
            for t in (wk.FORCE_MAP, wk.ESTIMATE, wk.CONTACTS, wk.GARMENT)
            if self.has(t) and _PROPERTY[t] not in self.__dict__
        ]
        kept = [t for t in (wk.WRENCH, wk.TWIST, wk.POSE) if _PROPERTY[t] not in self.__dict__]
        self._read_ahead([*kept, *heavy], check_only=heavy)
        _ = self.measurements, self.pose
        self._check_limb()


def read_trial(path: str | Path) -> Trial:
    """Read a whole trial file."""
    with TrialReader(path) as reader:
        return reader.read()
