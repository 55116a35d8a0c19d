"""`TrialWriter`: a dresslog trial as an MCAP file (profile ros2, CDR, zstd chunks).

Beside dresslog's own channels it writes, from the same data, the standard ones a 3D
viewer draws (`dresslog.io.drawn`): force-map clouds, the garment's mesh, limb and path
markers, and the frames on `/tf` and `/tf_static`.

The file appears under its final name only when the writer closes cleanly;
until then it is a hidden temporary beside it, removed if anything fails.
"""

from __future__ import annotations

import contextlib
import errno
import json
import struct
from collections.abc import Sequence
from functools import cache
from pathlib import Path
from types import TracebackType
from typing import IO, Self

import numpy as np
from mcap.writer import CompressionType, Writer

from dresslog import __version__
from dresslog.errors import TrialWriteError
from dresslog.io import cdr, drawn
from dresslog.io import well_known as wk
from dresslog.io.files import (
    check_output,
    discard,
    discard_stale_temporaries,
    make_folders,
    put_in_place,
    remove_folders,
    temporary_path,
)
from dresslog.io.msgdefs import schema_text
from dresslog.spec import TRIAL_FORMAT_VERSION, TrialMetadata
from dresslog.trial import CONTACT_DTYPE, LimbPoints

CHUNK_SIZE = 4 * 1024 * 1024
#: Layouts of the Contacts header stamp (sec int32, nanosec uint32) and count (uint32).
_HEAD_STAMP = struct.Struct("<iI")
_HEAD_LEN = struct.Struct("<I")
#: What a write the file system refuses raises: a full disk, a quota, a file too large.
_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
#: The last time a ROS 2 stamp (int32 seconds) holds.
MAX_STAMP_NS = (2**31 - 1) * 1_000_000_000 + 999_999_999


def software_versions() -> dict[str, str]:
    """Versions of the packages that shape a recording's content."""
    from importlib.metadata import PackageNotFoundError, version

    out = {"dresslog": __version__}
    for name in ("numpy", "mcap", "pybullet", "torch"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            continue
    return out


@cache
def _contacts_header() -> tuple[bytes, int, int]:
    """A Contacts message of zero contacts (stamp 0) as bytes, and the offsets of its stamp
    and its count, which `write_contacts` fills in."""
    frame = wk.FRAMES[wk.CONTACTS]
    head = cdr.new_messages(
        wk.SCHEMAS[wk.CONTACTS], {"header.frame_id": len(frame), "contacts": 0}, 1
    )
    cdr.set_stamp(head, np.zeros(1, np.int64), frame)
    fields = head.dtype.fields
    assert fields is not None
    sec, nanosec, count = (
        fields[n] for n in ("header.stamp.sec", "header.stamp.nanosec", "contacts.len")
    )
    # the struct formats above must be the fields' own layouts (fixed by the .msg text)
    assert (sec[0], nanosec[0], count[0]) == (np.dtype("<i4"), np.dtype("<u4"), np.dtype("<u4"))
    assert nanosec[1] == sec[1] + 4
    # contacts follow it unpadded: the first would be aligned to 8 (an empty list is not)
    assert (head.itemsize - len(cdr.ENCAPSULATION)) % 8 == 0
    return head.tobytes(), sec[1], count[1]


class TrialWriter:
    """Write one trial; use as a context manager. Times are integer nanoseconds.

    `draw=False` leaves out the standard channels viewers draw (`dresslog.io.drawn`): what
    the benchmarks measure their cost against; every command writes them.
    """

    def __init__(
        self, path: str | Path, metadata: TrialMetadata, *, overwrite: bool = False,
        draw: bool = True,
    ) -> None:  # fmt: skip
        self.path = Path(path)
        if not isinstance(metadata, TrialMetadata):  # else it would fail only at close
            raise TrialWriteError(
                f"metadata must be a TrialMetadata, not {type(metadata).__name__}", path=path
            )
        self.metadata = metadata
        self.overwrite = overwrite
        self.draw = draw
        self._tmp: Path | None = None  # named when opened, once the output is checked
        self._made: list[Path] = []  # folders made for it, removed again if it fails
        self._stream: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[str, int] = {}
        self._last_stamp: dict[str, int] = {}  # per topic: stamps must increase
        self._widths: dict[str, int] = {}  # per force-map topic: one width throughout
        self._points: int | None = None  # limb points written: every map's width
        self._garment_size: int | None = None  # vertices of the first garment message
        self._limb: np.ndarray | None = None  # limb point positions, where clouds are drawn
        self._triangles: np.ndarray | None = None  # the garment's, for its mesh marker
        self._path: list[tuple[np.ndarray, np.ndarray]] = []  # pose stamps and positions
        self._drawn_bin: dict[str, int] = {}  # per drawn topic: the last period it drew
        self._steps: dict[str, list[np.ndarray]] = {wk.WRENCH: [], wk.TWIST: []}
        self._origin = wk.TIME_ORIGIN_NS  # what a stamp adds to a trial time

    # -- lifecycle -------------------------------------------------------------
    def open(self) -> Self:
        if self._tmp is not None:  # its channels belong to the first file
            raise TrialWriteError(
                "this writer was opened before; a TrialWriter writes one file, so make another",
                path=self.path,
            )
        check_output(self.path, suffix=".mcap", overwrite=self.overwrite)
        self._made = make_folders(self.path)
        discard_stale_temporaries(self.path)  # a killed run's
        self._tmp = temporary_path(self.path)
        self._stream = self._tmp.open("wb")
        self._writer = Writer(self._stream, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        self._writer.start(profile=wk.PROFILE, library=f"{wk.LIBRARY} {__version__}")
        self._writer.add_metadata(*wk.ROSBAG2_METADATA)  # how rosbag2 reads our QoS
        return self

    def close(self) -> None:
        """Write the metadata and summary, then move the file into place."""
        if self._writer is not None:
            self.finish()
            self.place()

    def finish(self) -> None:
        """Write the metadata and summary; the file stays under its temporary name until
        `place` (for a caller that puts several outputs in place together)."""
        writer, stream, tmp = self._writer, self._stream, self._tmp
        if writer is None or stream is None or tmp is None:
            raise TrialWriteError("writer is not open", path=self.path)
        empty = np.empty(0, np.int64)  # int64 throughout: float64 merges stamps 100 ns apart
        wrench, twist = (np.concatenate([*self._steps[t], empty]) for t in (wk.WRENCH, wk.TWIST))
        if not len(np.intersect1d(wrench, twist)):  # the model's steps: read, it is refused
            raise TrialWriteError(
                f"a trial needs {wk.WRENCH} and {wk.TWIST} at one or more common times",
                path=self.path,
            )
        self._write_path()
        metadata = self.metadata.model_copy(
            update={
                "software": self.metadata.software or software_versions(),
                "format_version": TRIAL_FORMAT_VERSION,
                "time_origin_ns": self._origin,
            }
        )
        record = {"task": metadata.task.value, "trial": metadata.model_dump_json()}
        self._write_metadata_message(record)
        writer.add_metadata(wk.METADATA_NAME, record)
        writer.finish()
        stream.close()
        self._writer = self._stream = None

    def _write_metadata_message(self, record: dict[str, str]) -> None:
        """The metadata record again as a latched message at the trial's time 0, which
        tools that drop MCAP metadata records keep (see `wk.METADATA_TOPIC`)."""
        text = json.dumps(record).encode()
        message = cdr.new_messages(wk.UNSTAMPED[wk.METADATA_TOPIC], {"data": len(text)}, 1)
        message["data"] = text
        self._write_payloads(wk.METADATA_TOPIC, [self._origin], cdr.to_payloads(message))

    def place(self) -> None:
        """Move the file `finish` wrote to its final name."""
        if self._writer is not None or self._tmp is None:
            raise TrialWriteError("writer is not finished", path=self.path)
        put_in_place(self._tmp, self.path, overwrite=self.overwrite)
        self._made = []  # they hold the trial now

    def abort(self) -> None:
        """Drop everything written so far; nothing appears under the final name."""
        if self._stream is not None:
            with contextlib.suppress(OSError):  # a full disk refuses its buffered bytes again
                self._stream.close()
        self._writer = self._stream = None
        if self._tmp is not None:
            discard(self._tmp)
        remove_folders(self._made)  # those still empty
        self._made = []

    def __enter__(self) -> Self:
        try:
            return self.open()
        except BaseException:  # a Ctrl-C while opening leaves no temporary either
            self.abort()
            raise

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            try:
                self.close()
            except BaseException as err:  # finishing compresses the last chunk: Ctrl-C lands here
                self.abort()
                self.name_a_full_disk(err)
                raise
        else:
            self.abort()
            self.name_a_full_disk(exc)

    def name_a_full_disk(self, err: BaseException | None) -> None:
        """A write the file system refused says so about the output: the OSError of a full
        disk names no file, and the command printed `No space left on device` alone. For a
        caller that aborts the writer itself (`McapSink`), after `abort`."""
        if isinstance(err, OSError) and err.errno in _FULL and err.filename is None:
            raise TrialWriteError(f"cannot write it: {err.strerror}", path=self.path) from err

    # -- channels --------------------------------------------------------------
    def _channel(self, topic: str) -> int:
        if self._writer is None:
            raise TrialWriteError("writer is not open", path=self.path)
        if topic not in self._channels:
            name = wk.TYPES[topic]
            if name not in self._schemas:
                self._schemas[name] = self._writer.register_schema(
                    name, wk.SCHEMA_ENCODING, schema_text(name).encode()
                )
            self._channels[topic] = self._writer.register_channel(
                topic,
                wk.MESSAGE_ENCODING,
                self._schemas[name],
                metadata={"offered_qos_profiles": wk.QOS.get(topic, wk.STREAM_QOS)},
            )
            self._sequence[topic] = 0
        return self._channels[topic]

    def _write(self, topic: str, t_ns: np.ndarray, messages: np.ndarray) -> None:
        self._write_payloads(topic, t_ns.tolist(), cdr.to_payloads(messages))

    def _write_payloads(self, topic: str, t_ns: list[int], payloads: list[bytes]) -> None:
        channel = self._channel(topic)
        assert self._writer is not None
        seq = self._sequence[topic]
        for t, payload in zip(t_ns, payloads, strict=True):
            self._writer.add_message(channel, t, payload, t, seq)
            seq += 1
        self._sequence[topic] = seq

    def _times(self, topic: str, t_ns: int | np.ndarray, count: int) -> np.ndarray:
        """The stamps of `count` integer-nanosecond trial times, increasing on `topic` from
        call to call: the times moved on by the origin (`wk.TIME_ORIGIN_NS`)."""
        raw = np.atleast_1d(np.asarray(t_ns))
        problem = ""
        if raw.dtype.kind not in "iu":
            problem = f"times must be integer nanoseconds, not {raw.dtype}"
        elif len(raw) != count:
            problem = f"{len(raw)} times for {count} messages"
        times = raw.astype(np.int64)
        if not problem and len(times):
            after = self._last_stamp.get(topic, -1)
            if times[0] <= after or (np.diff(times) <= 0).any():
                problem = "times must increase from message to message, and not be negative"
            elif times[-1] > MAX_STAMP_NS - self._origin:
                problem = (
                    f"time {times[-1]} ns is past what a ROS 2 stamp holds (2**31 s from 1970, "
                    f"and the trial's time 0 is at {self._origin} ns)"
                )
            self._last_stamp[topic] = int(times[-1])
        if problem:
            raise TrialWriteError(f"{topic}: {problem}", path=self.path)
        return times + self._origin

    def _stamped(
        self,
        topic: str,
        t_ns: int | np.ndarray,
        sizes: dict,
        count: int = 1,
        frame: str | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        times = self._times(topic, t_ns, count)
        frame = wk.FRAMES[topic] if frame is None else frame
        schema = wk.TYPES[topic]
        messages = cdr.new_messages(schema, {"header.frame_id": len(frame), **sizes}, count)
        cdr.set_stamp(messages, times, frame)
        return times, messages

    def _rows(self, topic: str, values: np.ndarray, width: int) -> np.ndarray:
        rows = np.asarray(values, dtype=np.float64)
        rows = rows.reshape(-1, width) if rows.ndim == 1 else rows
        if rows.shape[1] != width:
            raise TrialWriteError(f"{topic} needs {width} values per message", path=self.path)
        if not np.isfinite(rows).all():
            raise TrialWriteError(f"{topic} has NaN or infinite values", path=self.path)
        return rows

    # -- streams ---------------------------------------------------------------
    def write_wrench(self, t_ns: int | np.ndarray, wrench: np.ndarray) -> None:
        """Force (N) and torque (N m) the garment applies at the end effector, (6,) or (T, 6)."""
        self._write_vectors(wk.WRENCH, t_ns, wrench, 6)

    def write_twist(self, t_ns: int | np.ndarray, twist: np.ndarray) -> None:
        """End-effector linear (m/s) and angular (rad/s) velocity, (6,) or (T, 6)."""
        self._write_vectors(wk.TWIST, t_ns, twist, 6)

    def write_pose(self, t_ns: int | np.ndarray, pose: np.ndarray) -> None:
        """End-effector position (m) and quaternion x y z w, (7,) or (T, 7)."""
        self._write_vectors(wk.POSE, t_ns, pose, 7)

    def write_received(
        self, kind: str, t_ns: int | np.ndarray, values: np.ndarray, frame_id: str
    ) -> None:
        """A live session's samples of `kind` (wrench, twist, pose) as they arrived, in the
        frame `frame_id` they came in, on `wk.RECEIVED`'s topics."""
        width = 7 if kind == "pose" else 6
        self._write_vectors(wk.RECEIVED[kind], t_ns, values, width, frame_id)

    def _write_vectors(
        self,
        topic: str,
        t_ns: int | np.ndarray,
        values: np.ndarray,
        width: int,
        frame: str | None = None,
    ) -> None:
        rows = self._rows(topic, values, width)
        times, msgs = self._stamped(topic, t_ns, {}, len(rows), frame)
        first, second = wk.VECTOR_FIELDS[topic]
        msgs[first], msgs[second] = rows[:, :3], rows[:, 3:]
        self._write(topic, times, msgs)
        if topic in self._steps:
            self._steps[topic].append(times)
        if topic == wk.POSE and self.draw:  # the frames at every pose, as tf readers expect
            tf_times, frames = drawn.moving_frames(times, rows)
            self._write_payloads(wk.TF, tf_times.tolist(), frames)
            self._path.append((times, rows[:, :3]))

    def write_force_map(
        self,
        t_ns: int | np.ndarray,
        forces: np.ndarray,
        contact: np.ndarray | None = None,
        *,
        estimate: bool = False,
    ) -> None:
        """Force map(s) (N,) or (T, N); an estimate also carries its contact map."""
        topic = wk.ESTIMATE if estimate else wk.FORCE_MAP
        forces = np.asarray(forces, dtype=np.float32)
        forces = forces[None] if forces.ndim == 1 else forces
        contact = None if contact is None else np.asarray(contact, dtype=np.float32)
        problem = ""
        if forces.ndim != 2 or (contact is not None and contact.size != forces.size):
            problem = "needs (N,) or (T, N) forces, and a contact map of the same size"
        elif not (np.isfinite(forces).all() and (contact is None or np.isfinite(contact).all())):
            problem = "has NaN or infinite values"
        elif self._widths.setdefault(topic, forces.shape[1]) != forces.shape[1]:
            problem = f"maps of {forces.shape[1]} points after maps of {self._widths[topic]}"
        elif self._points not in (None, forces.shape[1]):
            problem = f"maps of {forces.shape[1]} points for {self._points} limb points"
        if problem:
            raise TrialWriteError(f"{topic} {problem}", path=self.path)
        n_contact = 0 if contact is None else forces.shape[1]
        sizes = {"forces": forces.shape[1], "contact": n_contact}
        times, msgs = self._stamped(topic, t_ns, sizes, len(forces))
        msgs["forces"] = forces
        if contact is not None:
            msgs["contact"] = contact.reshape(forces.shape)
        self._write(topic, times, msgs)
        cloud = wk.ESTIMATE_CLOUD if estimate else wk.FORCE_CLOUD
        keep = self._drawn_steps(cloud, times, drawn.CLOUD_PERIOD_NS)
        if self._limb is not None and keep.any():
            clouds = drawn.point_clouds(times[keep], self._limb, forces[keep])
            self._write(cloud, times[keep], clouds)

    def _drawn_steps(self, topic: str, times: np.ndarray, period_ns: int) -> np.ndarray:
        """Which of these messages `topic` draws: the first of each `period_ns`, counted on
        from the messages written before (none if the writer does not draw)."""
        if not self.draw or not len(times):
            return np.zeros(len(times), bool)
        last = self._drawn_bin.get(topic, -1)
        self._drawn_bin[topic] = int(times[-1]) // period_ns
        if len(times) == 1:  # a garment state at a time: numpy's diff took 2 ms a trial
            return np.array([self._drawn_bin[topic] != last])
        return drawn.drawn_steps(times, period_ns, last)

    def write_contacts(self, t_ns: int, contacts: np.ndarray) -> None:
        """Every garment-limb contact at one step, a CONTACT_DTYPE array (possibly empty).

        Called every step by the simulator, so it skips the general path: the
        message is its header laid out for zero contacts (from the .msg text),
        followed by the contacts' bytes, whose layout is the CDR element layout.
        """
        if np.asarray(contacts).dtype.names != CONTACT_DTYPE.names or np.ndim(contacts) != 1:
            raise TrialWriteError(f"{wk.CONTACTS} needs a 1-D CONTACT_DTYPE array", path=self.path)
        contacts = np.asarray(contacts, dtype=CONTACT_DTYPE)
        if not all(np.isfinite(contacts[name]).all() for name in wk.CONTACT_REALS):
            raise TrialWriteError(f"{wk.CONTACTS} has NaN or infinite values", path=self.path)
        t_ns = int(self._times(wk.CONTACTS, t_ns, 1)[0])
        empty, stamp_at, len_at = _contacts_header()
        head = bytearray(empty)
        _HEAD_STAMP.pack_into(head, stamp_at, *divmod(t_ns, 1_000_000_000))
        _HEAD_LEN.pack_into(head, len_at, len(contacts))
        self._write_payloads(wk.CONTACTS, [t_ns], [bytes(head + contacts.tobytes())])

    def write_limb_points(self, t_ns: int, limb_points: LimbPoints) -> None:
        """The force-map sites, once at the start."""
        problem = ""
        if widths := set(self._widths.values()) - {len(limb_points)}:
            problem = f"are {len(limb_points)}, for maps of {widths.pop()} points"
        elif not np.isfinite(limb_points.points).all():
            problem = "have NaN or infinite positions"
        if problem:
            raise TrialWriteError(f"{wk.LIMB_POINTS} {problem}", path=self.path)
        self._points = len(limb_points)
        names = tuple(n.encode() for n in limb_points.segment_names)
        sizes = {
            "limb": len(limb_points.limb),
            "points": len(limb_points),
            "segment": len(limb_points),
            "segment_names": tuple(len(n) for n in names),
        }
        times, msgs = self._stamped(wk.LIMB_POINTS, t_ns, sizes, 1)
        msgs["limb"] = limb_points.limb.encode()
        msgs["points"][0] = limb_points.points
        msgs["segment"][0] = limb_points.segment
        for i, name in enumerate(names):
            msgs[f"segment_names.{i}"] = name
        self._write(wk.LIMB_POINTS, times, msgs)
        if not self.draw:
            return
        self._limb = np.asarray(limb_points.points, np.float32)
        stamp = int(times[0])  # the stamp with the origin, as every other header's
        self._write(wk.TF_STATIC, times, drawn.static_frames(stamp))
        marker = drawn.marker_array(stamp, drawn.LIMB, "limb", drawn.LIMB_LOOK, self._limb)
        self._write(wk.LIMB_MARKER, times, marker)

    def write_garment(
        self, t_ns: int, vertices: np.ndarray, triangles: np.ndarray | Sequence | None = None
    ) -> None:
        """Garment vertex positions (V, 3); the triangles (F, 3) in the first message only."""
        tris = np.zeros((0,), np.uint32) if triangles is None else np.asarray(triangles).ravel()
        vertices = np.asarray(vertices, dtype=np.float32)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.isfinite(vertices).all():
            raise TrialWriteError(f"{wk.GARMENT} needs finite (V, 3) vertices", path=self.path)
        if len(tris) % 3 or (len(tris) and (tris.min() < 0 or tris.max() >= len(vertices))):
            raise TrialWriteError(f"{wk.GARMENT} triangles must index its vertices", path=self.path)
        if self._garment_size is not None and (len(tris) or len(vertices) != self._garment_size):
            raise TrialWriteError(
                f"{wk.GARMENT} keeps its {self._garment_size} vertices, and its triangles go "
                "in the first message only",
                path=self.path,
            )
        self._garment_size = len(vertices)
        sizes = {"vertices": len(vertices), "triangles": len(tris)}
        times, msgs = self._stamped(wk.GARMENT, t_ns, sizes, 1)
        msgs["vertices"][0] = vertices
        msgs["triangles"][0] = tris
        self._write(wk.GARMENT, times, msgs)
        if len(tris):
            self._triangles = tris
        keep = self._drawn_steps(wk.GARMENT_SCENE, times, drawn.MESH_PERIOD_NS)
        if self._triangles is not None and keep.any():  # the mesh, at 2 Hz
            stamp = int(times[0])
            mesh = drawn.scene_update(stamp, drawn.WORLD, "garment", vertices, self._triangles)
            self._write(wk.GARMENT_SCENE, times, mesh)  # Foxglove draws it
            cloud = drawn.vertex_cloud(stamp, drawn.WORLD, vertices)  # Rerun's importer, this
            self._write(wk.GARMENT_CLOUD, times, cloud)

    def _write_path(self) -> None:
        """The gripper's whole path, once (latched) at its first pose: a viewer shows where
        the gripper goes while `/tf` moves it along. Through its pose at 10 Hz and its
        last: a line through all 100 a second looks the same and took 12 KB."""
        if not self._path:
            return
        times = np.concatenate([t for t, _ in self._path])
        keep = drawn.drawn_steps(times, drawn.PATH_PERIOD_NS)
        keep[-1] = True
        points = np.concatenate([p for _, p in self._path])[keep]
        marker = drawn.marker_array(int(times[0]), drawn.WORLD, "path", drawn.PATH_LOOK, points)
        self._write(wk.PATH_MARKER, times[:1], marker)
