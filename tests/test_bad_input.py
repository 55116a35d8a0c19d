"""Files that are not good trials give one clear line and exit 1, never a traceback."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from mcap.writer import Writer

from dresslog.cli.main import main
from dresslog.errors import TrialFormatError
from dresslog.io import cdr
from dresslog.io import well_known as wk
from dresslog.io.msgdefs import schema_text
from dresslog.io.reader import TrialReader
from dresslog.spec import Task, TrialMetadata
from tests.conftest import SAMPLES, prints_warnings


def _raw_mcap(
    path: Path, channels: dict[str, tuple[str, list[bytes]]], metadata: bool | dict[str, str]
) -> None:
    """An MCAP written with mcap's own writer: topic -> (schema name, payloads); the
    metadata record a new trial's, none, or the one given."""
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="another tool")
        for topic, (schema, payloads) in channels.items():
            sid = writer.register_schema(schema, "ros2msg", schema_text(schema).encode())
            cid = writer.register_channel(topic, "cdr", sid)
            for i, payload in enumerate(payloads):
                writer.add_message(cid, i * 10_000_000, payload, i * 10_000_000, i)
        if metadata is True:
            metadata = {"task": "gown", "trial": TrialMetadata(task=Task.GOWN).model_dump_json()}
        if metadata:
            writer.add_metadata(wk.METADATA_NAME, metadata)
        writer.finish()


def _vectors(schema: str, fields: tuple[str, str], values: np.ndarray) -> list[bytes]:
    msgs = cdr.new_messages(schema, {"header.frame_id": 2}, len(values))
    cdr.set_stamp(msgs, np.arange(len(values)) * 10_000_000, "ee")
    msgs[fields[0]], msgs[fields[1]] = values[:, :3], values[:, 3:]
    return cdr.to_payloads(msgs)


WRENCH = ("geometry_msgs/msg/WrenchStamped", ("wrench.force", "wrench.torque"))
TWIST = ("geometry_msgs/msg/TwistStamped", ("twist.linear", "twist.angular"))


def missing(tmp: Path, good: Path) -> Path:
    return tmp / "nowhere.mcap"


def empty(tmp: Path, good: Path) -> Path:
    (path := tmp / "empty.mcap").write_bytes(b"")
    return path


def random_bytes(tmp: Path, good: Path) -> Path:
    (path := tmp / "noise.mcap").write_bytes(np.random.default_rng(0).bytes(5000))
    return path


def json_named_mcap(tmp: Path, good: Path) -> Path:
    (path := tmp / "trial.mcap").write_text('{"task": "gown"}')
    return path


def rerun_recording(tmp: Path, good: Path) -> Path:
    import rerun as rr

    rec = rr.RecordingStream("dresslog-test")
    rec.save(path := tmp / "trial.rrd")
    rec.log("x", rr.Scalars(1.0))
    rec.flush()
    rec.disconnect()
    return path


def truncated(tmp: Path, good: Path) -> Path:
    data = good.read_bytes()
    (path := tmp / "cut.mcap").write_bytes(data[: len(data) // 2])
    return path


SAMPLE = SAMPLES / "gown.mcap"


def cut_in_a_chunk(tmp: Path, good: Path) -> Path:
    """A recording cut mid-chunk: the compressed chunk ends early."""
    (path := tmp / "cut.mcap").write_bytes(SAMPLE.read_bytes()[:500_000])
    return path


def flipped_bit(tmp: Path, good: Path) -> Path:
    """One bit flipped inside a compressed chunk (CRCs are checked too)."""
    data = bytearray(SAMPLE.read_bytes())
    data[154_100] ^= 0x10
    (path := tmp / "flipped.mcap").write_bytes(data)
    return path


def foreign(tmp: Path, good: Path) -> Path:
    path = tmp / "chatter.mcap"
    _raw_mcap(path, {"/joint_states": (TWIST[0], _vectors(*TWIST, np.zeros((3, 6))))}, False)
    return path


def wrong_schema(tmp: Path, good: Path) -> Path:
    path = tmp / "wrong.mcap"
    twist = _vectors(*TWIST, np.zeros((3, 6)))
    _raw_mcap(path, {wk.WRENCH: (TWIST[0], twist), wk.TWIST: (TWIST[0], twist)}, True)
    return path


def missing_twist(tmp: Path, good: Path) -> Path:
    path = tmp / "no_twist.mcap"
    _raw_mcap(path, {wk.WRENCH: (WRENCH[0], _vectors(*WRENCH, np.zeros((3, 6))))}, True)
    return path


def nan_wrench(tmp: Path, good: Path) -> Path:
    path = tmp / "nan.mcap"
    values = np.zeros((3, 6))
    values[1, 2] = np.nan
    channels = {
        wk.WRENCH: (WRENCH[0], _vectors(*WRENCH, values)),
        wk.TWIST: (TWIST[0], _vectors(*TWIST, np.zeros((3, 6)))),
    }
    _raw_mcap(path, channels, True)
    return path


def robot_bag(tmp: Path, good: Path) -> Path:
    """A ROS 2 bag whose pose topic happens to share our name: a log to convert."""
    path = tmp / "robot.mcap"
    poses = cdr.new_messages(wk.SCHEMAS[wk.POSE], {"header.frame_id": 4}, 3)
    channels = {
        wk.POSE: (wk.SCHEMAS[wk.POSE], cdr.to_payloads(poses)),
        "/ft/wrench": (WRENCH[0], _vectors(*WRENCH, np.zeros((3, 6)))),
    }
    _raw_mcap(path, channels, False)
    return path


def _with_steps(
    path: Path, extra: dict[str, tuple[str, list[bytes]]], metadata: bool | dict[str, str]
) -> Path:
    """Three zero wrench and twist steps and the `extra` channels, by mcap's own writer."""
    channels = {
        wk.WRENCH: (WRENCH[0], _vectors(*WRENCH, np.zeros((3, 6)))),
        wk.TWIST: (TWIST[0], _vectors(*TWIST, np.zeros((3, 6)))),
        **extra,
    }
    _raw_mcap(path, channels, metadata)
    return path


def no_metadata(tmp: Path, good: Path) -> Path:
    return _with_steps(tmp / "bare.mcap", {}, metadata=False)


def _encoded(topic: str, stamps_ns: list[int], sizes: dict, **values: object) -> list[bytes]:
    """`topic` messages of one layout at these stamps, each field given for all of them."""
    schema = wk.SCHEMAS[topic]
    sizes = {"header.frame_id": len(wk.FRAMES[topic]), **sizes}
    msgs = cdr.new_messages(schema, sizes, len(stamps_ns))
    cdr.set_stamp(msgs, np.array(stamps_ns, np.int64), wk.FRAMES[topic])
    for field, value in values.items():
        msgs[field] = value
    return cdr.to_payloads(msgs)


def no_common_stamp(tmp: Path, good: Path) -> Path:
    """Our writer refuses it; another tool's need not."""
    twist = _encoded(wk.TWIST, [1, 10_000_001, 20_000_001], {})
    return _with_steps(tmp / "apart.mcap", {wk.TWIST: (TWIST[0], twist)}, metadata=True)


def force_map_too_narrow(tmp: Path, good: Path) -> Path:
    sizes = {"limb": 3, "points": 3, "segment": 3, "segment_names": ()}
    points = _encoded(wk.LIMB_POINTS, [0], sizes, limb=b"arm")
    forces = _encoded(wk.FORCE_MAP, [0, 10_000_000, 20_000_000], {"forces": 2, "contact": 0})
    extra = {
        wk.LIMB_POINTS: (wk.SCHEMAS[wk.LIMB_POINTS], points),
        wk.FORCE_MAP: (wk.SCHEMAS[wk.FORCE_MAP], forces),
    }
    return _with_steps(tmp / "narrow.mcap", extra, metadata=True)


def garment_changing_size(tmp: Path, good: Path) -> Path:
    first = _encoded(wk.GARMENT, [0], {"vertices": 6, "triangles": 3}, triangles=[[0, 1, 2]])
    torn = _encoded(wk.GARMENT, [10_000_000], {"vertices": 4, "triangles": 0})
    return _with_steps(
        tmp / "torn.mcap", {wk.GARMENT: (wk.SCHEMAS[wk.GARMENT], first + torn)}, metadata=True
    )


def _garment_with(tmp: Path, name: str, corners: list[int]) -> Path:
    """A garment whose triangles our writer refuses to write: mcap's own writer."""
    path = tmp / name
    schema = wk.SCHEMAS[wk.GARMENT]
    sizes = {"header.frame_id": len(wk.FRAMES[wk.GARMENT]), "vertices": 6}
    garment = cdr.new_messages(schema, {**sizes, "triangles": len(corners)}, 1)
    cdr.set_stamp(garment, np.zeros(1, np.int64), wk.FRAMES[wk.GARMENT])
    garment["triangles"][0] = corners
    return _with_steps(path, {wk.GARMENT: (schema, cdr.to_payloads(garment))}, metadata=True)


def triangle_past_the_vertices(tmp: Path, good: Path) -> Path:
    return _garment_with(tmp, "tri.mcap", [0, 1, 2, 3, 4, 99])


def triangles_cut_short(tmp: Path, good: Path) -> Path:
    return _garment_with(tmp, "cut_tri.mcap", [0, 1, 2, 3])


def no_wrench_messages(tmp: Path, good: Path) -> Path:
    path = tmp / "silent.mcap"
    channels = {
        wk.WRENCH: (WRENCH[0], []),
        wk.TWIST: (TWIST[0], _vectors(*TWIST, np.zeros((3, 6)))),
    }
    _raw_mcap(path, channels, True)
    return path


def nan_force_map(tmp: Path, good: Path) -> Path:
    """NaN in the ground truth, which our writer refuses to write: mcap's own writer."""
    path = tmp / "nan_truth.mcap"
    schema = wk.SCHEMAS[wk.FORCE_MAP]
    maps = cdr.new_messages(schema, {"header.frame_id": 4, "forces": 3, "contact": 0}, 3)
    cdr.set_stamp(maps, np.arange(3) * 10_000_000, "limb")
    maps["forces"][1, 2] = np.nan
    return _with_steps(path, {wk.FORCE_MAP: (schema, cdr.to_payloads(maps))}, metadata=True)


def _stamped_wrench(tmp: Path, name: str, stamps: list[int]) -> Path:
    """Wrench messages with the given header stamps (twist at 0, 10, 20 ms)."""
    msgs = cdr.new_messages(WRENCH[0], {"header.frame_id": 2}, len(stamps))
    cdr.set_stamp(msgs, np.array(stamps), "ee")
    channels = {
        wk.WRENCH: (WRENCH[0], cdr.to_payloads(msgs)),
        wk.TWIST: (TWIST[0], _vectors(*TWIST, np.zeros((3, 6)))),
    }
    _raw_mcap(path := tmp / name, channels, True)
    return path


def unset_stamps(tmp: Path, good: Path) -> Path:
    """A driver that never fills its headers."""
    return _stamped_wrench(tmp, "unset.mcap", [0, 0, 0])


def logged_twice(tmp: Path, good: Path) -> Path:
    return _stamped_wrench(tmp, "twice.mcap", [0, 0, 10_000_000, 10_000_000, 20_000_000])


def _with_one(tmp: Path, name: str, topic: str, sizes: dict, **values: object) -> Path:
    """Three good steps and one `topic` message with `values`, by mcap's own writer."""
    schema = wk.SCHEMAS[topic]
    msg = cdr.new_messages(schema, {"header.frame_id": len(wk.FRAMES[topic]), **sizes}, 1)
    cdr.set_stamp(msg, np.zeros(1, np.int64), wk.FRAMES[topic])
    for field, value in values.items():
        msg[field.replace("__", ".")][0] = value
    return _with_steps(tmp / name, {topic: (schema, cdr.to_payloads(msg))}, metadata=True)


def nan_garment_vertex(tmp: Path, good: Path) -> Path:
    vertices = np.zeros((3, 3))
    vertices[1, 2] = np.nan
    sizes = {"vertices": 3, "triangles": 3}
    return _with_one(
        tmp, "nan_cloth.mcap", wk.GARMENT, sizes, vertices=vertices, triangles=[0, 1, 2]
    )


def nan_limb_point(tmp: Path, good: Path) -> Path:
    points = np.zeros((2, 3))
    points[0, 0] = np.inf
    sizes = {"limb": 3, "points": 2, "segment": 2, "segment_names": ()}
    return _with_one(tmp, "nan_limb.mcap", wk.LIMB_POINTS, sizes, limb=b"arm", points=points)


def nan_contact(tmp: Path, good: Path) -> Path:
    from dresslog.trial import CONTACT_DTYPE

    contact = np.zeros(1, CONTACT_DTYPE)
    contact["normal_force"] = np.nan
    return _with_one(tmp, "nan_contact.mcap", wk.CONTACTS, {"contacts": 1}, contacts=contact)


def from_a_newer_dresslog(tmp: Path, good: Path) -> Path:
    trial = '{"format_version": 2, "task": "gown", "new_field": 1}'
    return _with_steps(tmp / "newer.mcap", {}, metadata={"task": "gown", "trial": trial})


def metadata_without_the_trial(tmp: Path, good: Path) -> Path:
    return _with_steps(tmp / "no_trial.mcap", {}, metadata={"task": "gown"})


def big_endian(tmp: Path, good: Path) -> Path:
    """CDR's other byte order, which neither ROS 2 on x86/ARM nor dresslog writes."""
    wrench = [b"\x00\x00" + p[2:] for p in _vectors(*WRENCH, np.zeros((3, 6)))]
    return _with_steps(tmp / "big.mcap", {wk.WRENCH: (WRENCH[0], wrench)}, metadata=True)


def link_to_nothing(tmp: Path, good: Path) -> Path:
    """`ls` lists it, so "no such file" misled."""
    (path := tmp / "linked.mcap").symlink_to(tmp / "moved" / "trial.mcap")
    return path


def a_pipe(tmp: Path, good: Path) -> Path:
    os.mkfifo(path := tmp / "pipe.mcap")
    return path


CASES: list[tuple[Callable[[Path, Path], Path], str]] = [
    (missing, "no such file"),
    (empty, "file is empty"),
    (random_bytes, "not an MCAP file.*dresslog convert"),
    (json_named_mcap, "not an MCAP file"),
    (rerun_recording, "is a Rerun recording, not a trial; open it with `dresslog view`"),
    (truncated, "truncated"),
    (cut_in_a_chunk, "damaged or truncated"),
    (flipped_bit, "damaged or truncated"),
    (foreign, "not a dresslog trial.*/joint_states.*dresslog convert"),
    (wrong_schema, "channel /ee/wrench: has schema geometry_msgs/msg/TwistStamped"),
    (missing_twist, "missing channel /ee/twist"),
    (robot_bag, "not a dresslog trial.*/ee/pose, /ft/wrench.*dresslog convert"),
    (nan_wrench, "channel /ee/wrench: NaN"),
    (no_metadata, "no `dresslog` metadata record"),
    (no_wrench_messages, "channel /ee/wrench has no messages, so there is no step"),
    (no_common_stamp, "no /ee/wrench message has a /ee/twist message of the same stamp"),
    (nan_force_map, "channel /limb/force_map: NaN or infinite value in message 1 of 3"),
    (force_map_too_narrow, "force maps have 2 values but /limb/points has 3 points"),
    (garment_changing_size, r"the garment changes size \(\[4, 6\] vertices\)"),
    (triangle_past_the_vertices, "a triangle names vertex 99 of 6"),
    (triangles_cut_short, "4 triangle corners, not a multiple of 3"),
    (unset_stamps, "channel /ee/wrench: all 3 messages have the header stamp 0 ns, unset"),
    (logged_twice, "channel /ee/wrench: 2 messages repeat another's header stamp.*convert"),
    (nan_garment_vertex, "channel /garment/state: NaN or infinite vertex"),
    (nan_limb_point, "channel /limb/points: NaN or infinite limb point"),
    (nan_contact, "channel /limb/contacts: NaN or infinite value in a contact"),
    (from_a_newer_dresslog, r"newer dresslog \(trial format 2; this one reads 1\); upgrade"),
    (metadata_without_the_trial, "`dresslog` metadata record has no `trial` entry"),
    (a_pipe, "not a regular file"),
    (link_to_nothing, "is a symbolic link to .*moved/trial.mcap, which does not exist; mend the"),
    (big_endian, "channel /ee/wrench: message 0 is not plain little-endian CDR"),
]


#: Robots' logs, not trials: `info` describes them as the ROS 2 bags they are.
LOGS = (foreign, robot_bag)
NOT_LOGS = [case for case in CASES if case[0] not in LOGS]


@pytest.mark.parametrize(("make", "message"), NOT_LOGS, ids=[c[0].__name__ for c in NOT_LOGS])
def test_info_says_what_is_wrong_in_one_line(tmp_path: Path, make_trial, make, message) -> None:
    good, _ = make_trial(name="good.mcap")
    path = make(tmp_path, good)
    result = CliRunner().invoke(main, ["info", str(path)])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    assert lines[0].startswith(f"Error: {path}: ")
    assert __import__("re").search(message, lines[0]), lines[0]
    assert "Traceback" not in result.output


def test_info_describes_a_bare_ros2_bag_that_the_trial_reader_refuses(tmp_path: Path) -> None:
    """A robot's MCAP (profile ros2, no dresslog metadata, no /ee/wrench) is described
    as a bag: what `convert` takes from it, or why it would refuse it."""
    pytest.importorskip("rosbags")
    robot, chatter = robot_bag(tmp_path, tmp_path), foreign(tmp_path, tmp_path)
    result = CliRunner().invoke(main, ["info", str(robot)])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[0] == "robot.mcap: ROS 2 bag, 6 messages over 0.02 s"
    assert "  convert  takes wrench /ft/wrench, pose /ee/pose" in result.output
    result = CliRunner().invoke(main, ["info", str(chatter)])
    assert result.exit_code == 0, result.output
    assert "  convert  refuses it as it stands: no WrenchStamped topic" in result.output


@pytest.mark.parametrize(("make", "message"), CASES, ids=[c[0].__name__ for c in CASES])
def test_reader_raises_a_format_error_naming_the_file(tmp_path: Path, make_trial, make, message):
    good, _ = make_trial(name="good.mcap")
    path = make(tmp_path, good)
    with pytest.raises(TrialFormatError) as info, TrialReader(path) as reader:
        reader.read()
    assert info.value.path == path


def _unwritable_folder() -> Path | None:
    """/sys: no file can be made there, not even by root (which passes permission bits)."""
    folder = Path("/sys")
    try:
        (folder / ".dresslog-probe").touch()
    except OSError:
        return folder
    (folder / ".dresslog-probe").unlink()
    return None


UNWRITABLE = _unwritable_folder()


@pytest.mark.skipif(UNWRITABLE is None, reason="needs a folder where no file can be made")
@pytest.mark.parametrize(
    "args",
    [
        ["record", "--task", "gown", "--duration", "0.1", "-o", "{out}/t.mcap"],
        ["infer", str(SAMPLES / "gown.mcap"), "-o", "{out}/t.rrd"],
        ["view", str(SAMPLES / "gown.mcap"), "--save", "{out}/t.rrd"],
        ["generate", "--task", "gown", "--trials", "2", "--duration", "0.1", "-o", "{out}/d"],
    ],
    ids=["record", "infer", "view", "generate"],
)
def test_an_output_folder_that_cannot_be_written_is_one_line(args: list[str]) -> None:
    result = CliRunner().invoke(main, [a.format(out=UNWRITABLE) for a in args])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {UNWRITABLE}"), result.output


def test_a_flipped_bit_is_an_error_never_silently_different_data(tmp_path: Path) -> None:
    """Bit rot in the data section: the chunk CRCs catch what decompression would not."""
    with TrialReader(SAMPLE) as reader:
        reference = reader.read()
    data = SAMPLE.read_bytes()
    rng = np.random.default_rng(0)
    errors = 0
    for position in rng.integers(1_000, 500_000, size=30):
        flipped = bytearray(data)
        flipped[position] ^= 1 << int(rng.integers(8))
        (path := tmp_path / "flipped.mcap").write_bytes(flipped)
        try:
            with TrialReader(path) as reader:
                trial = reader.read()
        except TrialFormatError:
            errors += 1
            continue
        assert trial.force_map is not None and reference.force_map is not None
        np.testing.assert_array_equal(trial.wrench.values, reference.wrench.values)
        np.testing.assert_array_equal(trial.twist.values, reference.twist.values)
        np.testing.assert_array_equal(trial.force_map.forces, reference.force_map.forces)
    assert errors >= 25  # the rest fell in padding, indexes or metadata strings


def test_library_calls_with_a_bad_value_raise_the_dresslog_error_naming_it(
    tmp_path: Path,
) -> None:
    """What the Python API gives a script with a typo: the error family, not a KeyError."""
    from dresslog.convert import convert
    from dresslog.errors import DresslogError
    from dresslog.experiments import evaluate_dataset, sweep

    model = SAMPLES / "models" / "gown"
    with pytest.raises(DresslogError, match="split 'val' is not one of train, test, sweep"):
        evaluate_dataset(model, tmp_path, split="val")
    for n, shown in ((0, "0"), (2_000_000, "2,000,000")):  # neither leaves a folder
        with pytest.raises(
            DresslogError, match=f"1,000,000 sequences per setting .-n., not {shown}"
        ):
            sweep(model, tmp_path / "sw", speeds=[0.2], n=n)
    assert list(tmp_path.iterdir()) == []
    csv = tmp_path / "ft.csv"
    csv.write_text("time,fx,fy,fz,tx,ty,tz,vx,vy,vz\n" + "0,0,0,0,0,0,0,0,0,0\n" * 3)
    with pytest.raises(DresslogError, match="time unit 'min' is not one of s, ms, us, ns"):
        convert(csv, tmp_path / "t.mcap", "gown", time_unit="min")
    with pytest.raises(TrialFormatError, match="has no channel /nope"), TrialReader(SAMPLE) as r:
        r.messages("/nope")


@pytest.mark.parametrize(("topic", "step_ms", "hz"), [(wk.TWIST, 20, "50"), (wk.WRENCH, 1, "1000")])
def test_a_trial_at_another_rate_than_the_models_is_refused_by_infer(
    tmp_path: Path, topic: str, step_ms: int, hz: str
) -> None:
    """Steps pair by stamp: a 1 kHz wrench would run as every tenth sample, unaveraged."""
    channels = {}
    for name, schema in ((wk.WRENCH, WRENCH[0]), (wk.TWIST, TWIST[0])):
        steps = 100 // step_ms if name == topic else 10  # 0.1 s either way
        msgs = cdr.new_messages(schema, {"header.frame_id": 2}, steps)
        cdr.set_stamp(msgs, np.arange(steps) * (step_ms if name == topic else 10) * 10**6, "ee")
        channels[name] = (schema, cdr.to_payloads(msgs))
    _raw_mcap(path := tmp_path / "rate.mcap", channels, metadata=True)
    out = tmp_path / "out.rrd"
    result = CliRunner().invoke(main, ["infer", str(path), "-o", str(out)])
    assert result.exit_code == 1 and not out.exists()
    assert result.output == (
        f"Error: {path}: channel {topic}: is at {hz} Hz, and the model reads 100 Hz steps; "
        "resample the log onto them with `dresslog convert`\n"
    )


@prints_warnings
def test_view_shows_a_trial_at_another_rate_with_ground_truth_alone(tmp_path: Path) -> None:
    """Only an asked-for model refuses it: `view` falls back as for a task without a model."""
    from dresslog.sim.record import record_trial
    from dresslog.spec import TrialSpec

    spec = {"task": "gown", "seed": 1, "duration": 0.3, "sim": {"record_hz": 50}}
    record_trial(TrialSpec.model_validate(spec), trial := tmp_path / "hz50.mcap")
    out = tmp_path / "view.rrd"
    shown = CliRunner().invoke(main, ["view", str(trial), "--save", str(out)])
    assert shown.exit_code == 0 and out.is_file(), shown.output
    assert "Warning: " in shown.stderr and "is at 50 Hz" in shown.stderr
    assert "shown with ground truth alone" in shown.stderr
    model = str(SAMPLES / "models" / "gown")
    asked = CliRunner().invoke(main, ["view", str(trial), "--save", str(out), "--model", model,
                                      "--overwrite"])  # fmt: skip
    assert asked.exit_code == 1 and "is at 50 Hz" in asked.output
