"""The reader streams (messages by topic and time, channels read on demand), counts time
from the trial's origin, and finds the metadata where generic tools left it."""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from cli.main import main
from dresslog.errors import TrialFormatError
from dresslog.io import well_known as wk
from dresslog.io.reader import TrialReader, read_trial
from dresslog.io.writer import TrialWriter
from dresslog.spec import Task, TrialMetadata
from tests.conftest import mcap_records, write_mcap

#: A header stamp's seconds (int32) in a CDR payload: after the 4-byte encapsulation.
_SEC = struct.Struct("<i")
_ORIGIN_S = wk.TIME_ORIGIN_NS // 1_000_000_000


def test_messages_yield_a_half_open_range_of_the_asked_topics(make_trial) -> None:
    path, sent = make_trial(steps=50)
    t_ns = sent["t_ns"]
    start, stop = int(t_ns[10]), int(t_ns[20])
    with TrialReader(path) as reader:
        got = list(reader.messages([wk.WRENCH, wk.TWIST], start, stop))
        assert sorted({m.topic for m in got}) == [wk.TWIST, wk.WRENCH]
        wrench = [m for m in got if m.topic == wk.WRENCH]
        assert [m.t_ns for m in wrench] == t_ns[10:20].tolist()  # stop itself is left out
        decoded = np.stack([np.r_[m.decode()["wrench.force"], m.decode()["wrench.torque"]]
                            for m in wrench])  # fmt: skip
        np.testing.assert_array_equal(decoded, sent["wrench"][10:20])
        assert len(list(reader.messages(wk.FORCE_MAP, start=int(t_ns[-1])))) == 1
        assert len(list(reader.messages())) == sum(c.count for c in reader.channels.values())
        with pytest.raises(TrialFormatError, match="has no channel /nope"):
            reader.messages(["/nope"])


def test_reading_one_channel_holds_none_of_the_others(tmp_path: Path) -> None:
    """The reader held every payload of every channel: reading the wrench of a file of
    force maps cost the force maps' size in memory."""
    steps, points = 10_000, 2_000  # 80 MB of maps, 2 MB of wrench
    t_ns = np.arange(steps, dtype=np.int64) * 10_000_000
    forces = np.random.default_rng(0).random((steps, points)).astype(np.float32)
    path = tmp_path / "maps.mcap"
    with TrialWriter(path, TrialMetadata(task=Task.SHORTS)) as writer:
        writer.write_wrench(t_ns, np.ones((steps, 6)))
        writer.write_twist(t_ns, np.ones((steps, 6)))
        writer.write_force_map(t_ns, forces)
    tracemalloc.start()
    try:
        with TrialReader(path) as reader:
            wrench = reader.wrench
            _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(wrench) == steps and (wrench.values == 1).all()
    assert peak < forces.nbytes / 4, f"{peak / 1e6:.1f} MB to read the wrench"


def test_stamps_count_from_2020_and_the_reader_from_the_trials_start(make_trial) -> None:
    from mcap.reader import make_reader

    path, sent = make_trial()
    with path.open("rb") as stream:
        first = next(iter(make_reader(stream).iter_messages(topics=[wk.WRENCH])))[2]
    assert first.log_time == wk.TIME_ORIGIN_NS + sent["t_ns"][0]
    assert _SEC.unpack_from(first.data, 4)[0] == _ORIGIN_S + sent["t_ns"][0] // 10**9
    with TrialReader(path) as reader:
        assert reader.origin_ns == reader.metadata.time_origin_ns == wk.TIME_ORIGIN_NS
        np.testing.assert_array_equal(reader.wrench.t_ns, sent["t_ns"])


def test_rerun_shows_a_trial_on_its_2020_dates(make_trial) -> None:
    """Rerun's MCAP importer had put every trial in January 1970."""
    from datetime import datetime

    from rerun.chunk import McapReader

    path, sent = make_trial()
    times = {}
    for chunk in McapReader(path).stream():
        if str(chunk.entity_path) == wk.WRENCH and "ros2_timestamp" in chunk.timeline_names:
            batch = chunk.to_record_batch()
            for name in ("message_log_time", "ros2_timestamp"):
                times[name] = batch.column(name)[0].as_py()
    first = datetime(2020, 1, 1) + (sent["t_ns"][0] // 1000) * np.timedelta64(1, "us").item()
    assert times == {"message_log_time": first, "ros2_timestamp": first}


def _as_format_1(new: Path, old: Path) -> Path:
    """`new` as dresslog wrote trials before format 2: stamps from 0, no metadata channel."""
    messages, metadata = mcap_records(new)
    rows = []
    for schema, channel, message in messages:
        if channel.topic == wk.METADATA_TOPIC:
            continue
        data = bytearray(message.data)
        _SEC.pack_into(data, 4, _SEC.unpack_from(data, 4)[0] - _ORIGIN_S)
        log = message.log_time - wk.TIME_ORIGIN_NS
        rows.append((channel.id, schema, channel.topic, log, bytes(data), log))
    trial = json.loads(dict(metadata)[wk.METADATA_NAME]["trial"])
    trial = {k: v for k, v in trial.items() if k != "time_origin_ns"} | {"format_version": 1}
    records = [(wk.METADATA_NAME, {"task": trial["task"], "trial": json.dumps(trial)})]
    return write_mcap(old, "dresslog 0.1.0", rows, records)


def _same_trial(a: Path, b: Path) -> None:
    one, two = read_trial(a), read_trial(b)
    for name in ("wrench", "twist", "pose"):
        np.testing.assert_array_equal(getattr(one, name).t_ns, getattr(two, name).t_ns)
        np.testing.assert_array_equal(getattr(one, name).values, getattr(two, name).values)
    assert one.force_map is not None and two.force_map is not None
    np.testing.assert_array_equal(one.force_map.t_ns, two.force_map.t_ns)
    np.testing.assert_array_equal(one.force_map.forces, two.force_map.forces)
    assert one.garment is not None and two.garment is not None
    np.testing.assert_array_equal(one.garment.t_ns, two.garment.t_ns)
    assert one.contacts is not None and two.contacts is not None
    np.testing.assert_array_equal(one.contacts.t_ns, two.contacts.t_ns)
    assert one.metadata.spec == two.metadata.spec and one.metadata.task == two.metadata.task


def test_a_trial_written_the_old_way_from_0_reads_the_same(tmp_path: Path, make_trial) -> None:
    path, _ = make_trial()
    old = _as_format_1(path, tmp_path / "old.mcap")
    with TrialReader(old) as reader:
        assert reader.origin_ns == 0 and reader.metadata.format_version == 1
    _same_trial(path, old)


@pytest.mark.skipif(shutil.which("rosbags-convert") is None, reason="needs rosbags' CLI")
def test_a_ros1_round_trip_drops_the_record_and_the_channel_keeps_the_metadata(
    tmp_path: Path, make_trial
) -> None:
    """`rosbags-convert` to a ROS 1 bag and back keeps messages, not metadata records."""
    from mcap.reader import make_reader

    path, _ = make_trial()
    tool = shutil.which("rosbags-convert")
    assert tool is not None
    bag, back = tmp_path / "trial.bag", tmp_path / "back"
    for src, dst, more in ((path, bag, []), (bag, back, ["--dst-storage", "mcap"])):
        subprocess.run([tool, "--src", str(src), "--dst", str(dst), *more], check=True)
    again = back / "back.mcap"
    with again.open("rb") as stream:
        names = {m.name for m in make_reader(stream).iter_metadata()}
    assert wk.METADATA_NAME not in names  # the record is gone ...
    result = CliRunner().invoke(main, ["info", str(again)])
    assert result.exit_code == 0, result.output  # ... and info reads it from the channel
    assert "outcome dressed" in result.output and "seed 11" in result.output
    _same_trial(path, again)
    with TrialReader(again) as reader:
        assert reader.metadata == read_trial(path).metadata
        offered = reader.channels[wk.METADATA_TOPIC]
        assert offered.count == 1


def test_a_metadata_channel_that_is_not_the_record_is_one_line(tmp_path: Path, make_trial) -> None:
    path, _ = make_trial()
    messages, _ = mcap_records(path)
    rows = []
    for schema, channel, message in messages:
        data = message.data
        if channel.topic == wk.METADATA_TOPIC:
            data = data[:8] + b"[" + data[9:]  # no longer a JSON object
        rows.append((channel.id, schema, channel.topic, message.log_time, data, message.log_time))
    bad = write_mcap(tmp_path / "bad.mcap", "dresslog 0.1.0", rows, [])
    with pytest.raises(TrialFormatError, match=f"{wk.METADATA_TOPIC}.*metadata"):
        TrialReader(bad).open()


def test_info_checks_the_force_maps_block_by_block_and_holds_none(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`info` read the whole trial to check it: a 30-minute file's streams, 1.9 GB."""
    from dresslog.io import reader as reader_module
    from dresslog.io.summary import summarize

    steps = 20_000
    t_ns = np.arange(steps, dtype=np.int64) * 10_000_000
    forces = np.random.default_rng(0).random((steps, 400)).astype(np.float32)
    path = tmp_path / "maps.mcap"
    with TrialWriter(path, TrialMetadata(task=Task.SHORTS)) as writer:
        writer.write_wrench(t_ns, np.ones((steps, 6)))
        writer.write_twist(t_ns, np.ones((steps, 6)))
        writer.write_force_map(t_ns, forces)
    monkeypatch.setattr(reader_module, "BLOCK", 1024)
    tracemalloc.start()
    try:
        summary = summarize(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert summary.steps == steps and summary.has_ground_truth
    # the whole read held the maps twice over (payloads and arrays): 64 MB and more
    assert peak < 0.75 * forces.nbytes, f"{peak / 1e6:.1f} MB to check {forces.nbytes / 1e6} MB"
    messages, records = mcap_records(path)  # a NaN in a later block is still found
    bad = tmp_path / "bad.mcap"
    rows = []
    for schema, channel, message in messages:
        data = message.data
        if channel.topic == wk.FORCE_MAP and message.log_time == wk.TIME_ORIGIN_NS + t_ns[5000]:
            data = data[:-8] + np.float32(np.nan).tobytes() + data[-4:]  # its last force
        rows.append((channel.id, schema, channel.topic, message.log_time, data, message.log_time))
    write_mcap(bad, "dresslog 0.1.0", rows, records)
    said = "force_map: NaN or infinite value in message 5000 of 20000"  # counted in the channel
    with pytest.raises(TrialFormatError, match=said):
        summarize(bad)
