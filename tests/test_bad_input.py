"""Files that are not good trials give one clear line and exit 1, never a traceback."""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.errors import TrialFormatError
from dresslog.io import cdr
from dresslog.io import well_known as wk
from dresslog.io.reader import TrialReader
from dresslog.spec import TRIAL_FORMAT_VERSION, Task, TrialMetadata
from tests.conftest import (
    SAMPLES,
    TWIST,
    WRENCH,
    McapRow,
    mcap_records,
    missing_twist,
    nan_wrench,
    prints_warnings,
    raw_mcap,
    vector_payloads,
    write_mcap,
)


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
    raw_mcap(path, {"/joint_states": (TWIST[0], vector_payloads(*TWIST, np.zeros((3, 6))))}, False)
    return path


def wrong_schema(tmp: Path, good: Path) -> Path:
    path = tmp / "wrong.mcap"
    twist = vector_payloads(*TWIST, np.zeros((3, 6)))
    raw_mcap(path, {wk.WRENCH: (TWIST[0], twist), wk.TWIST: (TWIST[0], twist)}, True)
    return path


def robot_bag(tmp: Path, good: Path) -> Path:
    """A ROS 2 bag whose pose topic happens to share our name: a log to convert."""
    path = tmp / "robot.mcap"
    poses = cdr.new_messages(wk.SCHEMAS[wk.POSE], {"header.frame_id": 4}, 3)
    channels = {
        wk.POSE: (wk.SCHEMAS[wk.POSE], cdr.to_payloads(poses)),
        "/ft/wrench": (WRENCH[0], vector_payloads(*WRENCH, np.zeros((3, 6)))),
    }
    raw_mcap(path, channels, False)
    return path


def _with_steps(
    path: Path, extra: dict[str, tuple[str, list[bytes]]], metadata: bool | dict[str, str]
) -> Path:
    """Three zero wrench and twist steps and the `extra` channels, by mcap's own writer."""
    channels = {
        wk.WRENCH: (WRENCH[0], vector_payloads(*WRENCH, np.zeros((3, 6)))),
        wk.TWIST: (TWIST[0], vector_payloads(*TWIST, np.zeros((3, 6)))),
        **extra,
    }
    raw_mcap(path, channels, metadata)
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
        wk.TWIST: (TWIST[0], vector_payloads(*TWIST, np.zeros((3, 6)))),
    }
    raw_mcap(path, channels, True)
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
        wk.TWIST: (TWIST[0], vector_payloads(*TWIST, np.zeros((3, 6)))),
    }
    raw_mcap(path := tmp / name, channels, True)
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
    trial = f'{{"format_version": {TRIAL_FORMAT_VERSION + 1}, "task": "gown", "new_field": 1}}'
    return _with_steps(tmp / "newer.mcap", {}, metadata={"task": "gown", "trial": trial})


def metadata_without_the_trial(tmp: Path, good: Path) -> Path:
    return _with_steps(tmp / "no_trial.mcap", {}, metadata={"task": "gown"})


def big_endian(tmp: Path, good: Path) -> Path:
    """CDR's other byte order, which neither ROS 2 on x86/ARM nor dresslog writes."""
    wrench = [b"\x00\x00" + p[2:] for p in vector_payloads(*WRENCH, np.zeros((3, 6)))]
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
    (
        from_a_newer_dresslog,
        rf"newer dresslog \(trial format {TRIAL_FORMAT_VERSION + 1}; this one reads "
        rf"{TRIAL_FORMAT_VERSION}\); upgrade",
    ),
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
    raw_mcap(path := tmp_path / "rate.mcap", channels, metadata=True)
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


# -- hostile inputs (issue 50): one line naming the file, never a traceback ----------------

#: `[` 200,000 times: Python's JSON reader raised RecursionError, a traceback.
DEEP = "[" * 200_000
GOWN_MODEL = SAMPLES / "models" / "gown"


def _one_line(args: list[str], *, code: int = 1) -> str:
    """The one line (`Error: ...`) a command prints for a bad input, checked to be one."""
    result = CliRunner().invoke(main, args)
    lines = result.output.strip().splitlines()
    assert result.exit_code == code and len(lines) == 1, result.output
    assert "Traceback" not in result.output and not isinstance(result.exception, RecursionError)
    return lines[0]


def _copied_model(tmp: Path, card: str | None = None) -> Path:
    """The bundled gown model copied, its card replaced by `card` if given."""
    import shutil

    model = Path(shutil.copytree(GOWN_MODEL, tmp / "model"))
    if card is not None:
        (model / "card.json").write_text(card)
    return model


@pytest.mark.parametrize("nested", [DEEP, '{"a": ' * 150 + "1" + "}" * 150])
@pytest.mark.parametrize("command", ["info", "infer", "view"])
def test_deeply_nested_trial_metadata_is_one_line(tmp_path: Path, command: str, nested: str):
    path = _with_steps(tmp_path / "deep.mcap", {}, metadata={"task": "gown", "trial": nested})
    args = {"info": [], "infer": ["-o", str(tmp_path / "o.rrd")]}
    line = _one_line([command, str(path), *args.get(command, ["--save", str(tmp_path / "o.rrd")])])
    assert line == (
        f"Error: {path}: metadata record is invalid: it nests more than 100 levels deep, as "
        "no dresslog file does"
    )
    assert not (tmp_path / "o.rrd").exists()


@pytest.mark.parametrize(
    "args",
    [
        ["info", "{model}"],
        ["infer", str(SAMPLE), "--model", "{model}", "-o", "{tmp}/o.rrd"],
        ["view", str(SAMPLE), "--model", "{model}", "--save", "{tmp}/o.rrd"],
        ["eval", "{model}", "{tmp}"],
        ["sweep", "{model}", "--speeds", "0.2", "-n", "1", "-o", "{tmp}/sweep"],
    ],
    ids=["info", "infer", "view", "eval", "sweep"],
)
def test_a_deeply_nested_model_card_is_one_line(tmp_path: Path, args: list[str]) -> None:
    model = _copied_model(tmp_path, DEEP)
    line = _one_line([a.format(model=model, tmp=tmp_path) for a in args])
    assert line == (
        f"Error: {model}: card.json is not readable JSON: it nests more than 100 levels "
        "deep, as no dresslog file does"
    )


@pytest.mark.parametrize(
    ("args", "why"),
    [
        (["info", "{data}"], "it nests more than 100 levels deep, as no dresslog file does"),
        (["eval", str(GOWN_MODEL), "{data}"], "it nests more than 100 levels deep"),
        (["train", "{data}", "-o", "{tmp}/m"], "it nests more than 100 levels deep"),
    ],
    ids=["info", "eval", "train"],
)
def test_a_deeply_nested_dataset_manifest_is_one_line(tmp_path: Path, args, why: str) -> None:
    (data := tmp_path / "data").mkdir()
    (data / "manifest.json").write_text(DEEP)
    line = _one_line([a.format(data=data, tmp=tmp_path) for a in args])
    assert line.startswith(f"Error: {data}: manifest.json is not readable JSON: {why}"), line


def test_a_card_whose_normalisation_holds_nan_is_one_line(tmp_path: Path) -> None:
    """`NaN` is no JSON number (Python writes it, pydantic writes null)."""
    card = (GOWN_MODEL / "card.json").read_text().replace('"std": [', '"std": [NaN, ', 1)
    model = _copied_model(tmp_path, card)
    line = _one_line(["infer", str(SAMPLE), "--model", str(model), "-o", str(tmp_path / "o.rrd")])
    assert line == f"Error: {model}: card.json is not readable JSON: NaN is not a JSON number"


def test_json_nesting_is_measured_without_recursion() -> None:
    from dresslog.io.jsontext import depth, loads

    assert [depth(v, 100) for v in (1, [], {"a": [[1]]}, [{}, [[]]])] == [0, 1, 3, 3]
    assert depth(loads("[" * 100 + "]" * 100), 100) == 100
    with pytest.raises(ValueError, match="nests more than 100 levels"):
        loads("[" * 101 + "]" * 101)


def _rewritten(good: Path, out: Path, topic: str, index: int, field: str, value: int) -> Path:
    """`good` with the length field `field` of message `index` of `topic` set to `value`,
    written again by mcap's own writer (ours would not write it)."""
    messages, metadata = mcap_records(good)

    def rows() -> Iterator[McapRow]:
        seen = 0
        for schema, channel, message in messages:
            data = message.data
            if channel.topic == topic and (seen := seen + 1) == index + 1:
                layout = cdr.layout(schema.name, cdr.sizes_of(schema.name, data))
                at = layout.fields[f"{field}.len"][1]
                data = data[:at] + value.to_bytes(4, "little") + data[at + 4 :]
            yield channel.topic, schema, channel.topic, message.log_time, data, message.log_time

    return write_mcap(out, "a hostile tool", rows(), metadata)


LENGTHS = [  # (topic, length field, what the error says of it)
    (wk.WRENCH, "header.frame_id", "string header.frame_id is 4294967280 bytes long"),
    (wk.TWIST, "header.frame_id", "string header.frame_id is 4294967280 bytes long"),
    (wk.FORCE_MAP, "forces", "forces holds 4294967280 elements by its length field"),
    (wk.CONTACTS, "contacts", "contacts holds 4294967280 elements by its length field"),
    (wk.GARMENT, "vertices", "vertices holds 4294967280 elements by its length field"),
    (wk.LIMB_POINTS, "limb", "string limb is 4294967280 bytes long"),
    (wk.LIMB_POINTS, "segment_names.1", r"string segment_names\[1\] is 4294967280 bytes long"),
]


@pytest.mark.parametrize(
    ("topic", "field", "said"), LENGTHS, ids=[f"{t}:{f}" for t, f, _ in LENGTHS]
)
@pytest.mark.parametrize("command", ["info", "infer"])
def test_a_length_field_past_its_messages_end_is_one_line(
    tmp_path: Path, make_trial, topic: str, field: str, said: str, command: str
) -> None:
    """0xFFFFFFF0 in a length field: numpy was asked for a 4 GB string type (TypeError)."""
    good, _ = make_trial(name="good.mcap", steps=12)
    index = 0 if topic == wk.LIMB_POINTS else 1
    path = _rewritten(good, tmp_path / "long.mcap", topic, index, field, 0xFFFFFFF0)
    args = [] if command == "info" else ["-o", str(tmp_path / "o.rrd")]
    line = _one_line([command, str(path), *args])
    prefix = f"Error: {path}: channel {topic}: message {index} of "
    assert line.startswith(prefix) and " does not match its schema: " in line, line
    assert re.search(f"{said}.*message has \\d+ left; the recording is corrupt", line), line


def test_a_string_length_of_zero_is_refused_as_cdr_counts_its_nul(tmp_path: Path, make_trial):
    good, _ = make_trial(name="good.mcap", steps=12)
    path = _rewritten(good, tmp_path / "zero.mcap", wk.WRENCH, 3, "header.frame_id", 0)
    said = "message 3 of 12 does not match its schema: string header.frame_id has the length 0"
    with pytest.raises(TrialFormatError, match=said) as info, TrialReader(path) as reader:
        reader.read()
    assert info.value.path == path


def test_convert_refuses_a_length_field_past_its_messages_end(tmp_path: Path) -> None:
    """A robot's bag: the message is named by its place in the topic."""
    pytest.importorskip("rosbags")
    wrench = vector_payloads(*WRENCH, np.zeros((300, 6)))
    wrench[100] = wrench[100][:12] + (0xFFFFFFF0).to_bytes(4, "little") + wrench[100][16:]
    twist = vector_payloads(*TWIST, np.zeros((300, 6)))
    channels = {"/ft/wrench": (WRENCH[0], wrench), "/ft/twist": (TWIST[0], twist)}
    raw_mcap(bag := tmp_path / "robot.mcap", channels, False)
    out = tmp_path / "t.mcap"
    line = _one_line(["convert", str(bag), "-o", str(out), "--task", "gown"])
    assert line == (
        f"Error: {bag}: topic /ft/wrench: message 100 does not match "
        "geometry_msgs/msg/WrenchStamped: string header.frame_id is 4294967280 bytes long by "
        "its length field, but the 68-byte message has 52 left"
    )
    assert not out.exists()


def _weights_changed(tmp: Path, change: Callable[[dict[str, np.ndarray]], None]) -> Path:
    """The bundled model with its weights changed and its card's hash made to match."""
    import json

    from safetensors.numpy import load_file, save_file

    from dresslog.io.files import sha256_file

    model = _copied_model(tmp)
    weights = {k: v.copy() for k, v in load_file(str(model / "model.safetensors")).items()}
    change(weights)
    save_file(weights, str(model / "model.safetensors"), metadata={"format": "dresslog-model"})
    card = json.loads((model / "card.json").read_text())
    card["weights_sha256"] = sha256_file(model / "model.safetensors")
    (model / "card.json").write_text(json.dumps(card))
    return model


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_weights_holding_nan_are_refused_at_load(tmp_path: Path, bad: float) -> None:
    """Its card's hash matches: `infer` printed `RMSE nan` and wrote NaN estimates."""

    def poison(weights: dict[str, np.ndarray]) -> None:
        weights["lstm.weight_hh_l1"][7, 3] = bad

    model, out = _weights_changed(tmp_path, poison), tmp_path / "o.rrd"
    said = (
        f"Error: {model}: model.safetensors: lstm.weight_hh_l1 holds 1 NaN or infinite value "
        "(of 40000); the weights are corrupt, retrain the model or restore its folder"
    )
    assert _one_line(["infer", str(SAMPLE), "--model", str(model), "-o", str(out)]) == said
    assert not out.exists()
    result = CliRunner().invoke(main, ["info", str(model)])  # described, and it fails
    assert result.exit_code == 1 and result.output.strip().splitlines()[-1] == said


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_weights_that_overflow_on_a_trial_write_no_estimate(tmp_path: Path) -> None:
    """Finite weights whose estimate is not: refused at the step, no file of NaNs."""

    def overflow(weights: dict[str, np.ndarray]) -> None:
        weights["head.weight"][:] = 3e38

    model, out = _weights_changed(tmp_path, overflow), tmp_path / "o.rrd"
    line = _one_line(["infer", str(SAMPLE), "--model", str(model), "-o", str(out)])
    assert line.startswith(f"Error: {SAMPLE}: the model ({model} (3x100 LSTM")
    assert re.search(
        r"\) estimates NaN or infinite forces at step \d+; no estimate is written$", line
    )
    assert not out.exists()


def _steps_at(path: Path, wrench_ns: np.ndarray, twist_ns: np.ndarray) -> Path:
    """A trial whose wrench and twist have these header stamps (mcap's own writer)."""
    channels = {}
    for topic, schema, stamps in (
        (wk.WRENCH, WRENCH[0], wrench_ns),
        (wk.TWIST, TWIST[0], twist_ns),
    ):
        msgs = cdr.new_messages(schema, {"header.frame_id": 2}, len(stamps))
        cdr.set_stamp(msgs, np.asarray(stamps, np.int64), "ee")
        channels[topic] = (schema, cdr.to_payloads(msgs))
    raw_mcap(path, channels, True)
    return path


STEP = 10_000_000
T700 = np.arange(700) * STEP
CURE = "re-record it, or re-convert its log"
UNEVEN = [  # (wrench stamps, twist stamps, the line)
    (T700, T700[:350], f"channel {wk.TWIST}: stops at 3.490 s, 3.5 s before {wk.WRENCH} does: "
     f"the last 350 of 700 {wk.WRENCH} steps have no {wk.TWIST} message, and the model reads "
     f"both on every step; {CURE}"),
    (T700[:200], T700, f"channel {wk.WRENCH}: stops at 1.990 s, 5 s before {wk.TWIST} does: "
     f"the last 500 of 700 {wk.TWIST} steps have no {wk.WRENCH} message, and the model reads "
     f"both on every step; {CURE}"),
    (T700, T700[100:], f"channel {wk.TWIST}: starts at 1.000 s, 1 s after {wk.WRENCH} does: "
     f"the first 100 of 700 {wk.WRENCH} steps have no {wk.TWIST} message, and the model reads "
     f"both on every step; {CURE}"),
    (np.delete(T700, np.arange(300, 400)), T700, f"channel {wk.WRENCH}: has a gap: no message "
     "between 2.990 s and 4.000 s (1 s, 100 steps missing), and the model would read the steps "
     f"either side as consecutive; {CURE}"),
    (T700, np.delete(T700, [10, 11, 500]), f"channel {wk.TWIST}: has a gap: no message between "
     "0.090 s and 0.120 s (0.02 s, 2 steps missing; 2 gaps in all), and the model would read "
     f"the steps either side as consecutive; {CURE}"),
    (T700, T700 + STEP // 2, f"no {wk.WRENCH} message has a {wk.TWIST} message of the same "
     "stamp, so there is no step to run the model on; re-record or re-convert it"),
]  # fmt: skip


@pytest.mark.parametrize(("wrench", "twist", "said"), UNEVEN,
                         ids=["twist-stops", "wrench-stops", "twist-starts-late", "wrench-hole",
                              "twist-holes", "offset"])  # fmt: skip
@pytest.mark.parametrize("command", ["info", "infer"])
def test_input_channels_that_do_not_cover_the_same_steps_are_refused(
    tmp_path: Path, wrench, twist, said: str, command: str
) -> None:
    """Half a trial was dropped silently, and steps either side of a hole read as one apart."""
    path = _steps_at(tmp_path / "uneven.mcap", wrench, twist)
    out = tmp_path / "o.rrd"
    args = [] if command == "info" else ["-o", str(out)]
    assert _one_line([command, str(path), *args]) == f"Error: {path}: {said}"
    assert not out.exists()


def test_a_trial_of_one_step_is_refused_by_the_model_as_record_and_convert_refuse_it(
    tmp_path: Path,
) -> None:
    """It was scored `RMSE 0 N`."""
    path = _steps_at(tmp_path / "one.mcap", T700[:1], T700[:1])
    said = (
        f"Error: {path}: has one step ({wk.WRENCH} and {wk.TWIST} at one time), less than two "
        "steps, and the model needs two or more; re-record it, or re-convert a longer log"
    )
    out = tmp_path / "o.rrd"
    assert _one_line(["infer", str(path), "-o", str(out)]) == said
    assert _one_line(["view", str(path), "--model", str(GOWN_MODEL), "--save", str(out)]) == said
    assert not out.exists()


@prints_warnings
def test_view_shows_a_trial_of_one_step_with_ground_truth_alone(tmp_path: Path) -> None:
    from dresslog.io.writer import TrialWriter
    from dresslog.limb import build_limb, limb_points

    path, out = tmp_path / "one.mcap", tmp_path / "v.rrd"
    with TrialWriter(path, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_limb_points(0, limb_points(build_limb(Task.GOWN)))
        writer.write_wrench(0, np.zeros(6))
        writer.write_twist(0, np.zeros(6))
        writer.write_force_map(0, np.zeros(300, np.float32))
    shown = CliRunner().invoke(main, ["view", str(path), "--save", str(out)])
    assert shown.exit_code == 0 and out.is_file(), shown.output
    assert shown.stderr == (
        f"Warning: {path}: has one step ({wk.WRENCH} and {wk.TWIST} at one time), less than "
        "two steps, and the model needs two or more; re-record it, or re-convert a longer "
        "log; shown with ground truth alone\n"
    )


@pytest.mark.parametrize("name", ["pipe.mcap", "pipe.csv", "pipe.bag", "pipe"])
def test_convert_refuses_a_pipe_as_infer_and_info_do(tmp_path: Path, name: str) -> None:
    os.mkfifo(pipe := tmp_path / name)
    said = f"Error: {pipe}: is not a regular file (a pipe or a device); save it to a file first"
    assert (
        _one_line(["convert", str(pipe), "-o", str(tmp_path / "t.mcap"), "--task", "gown"]) == said
    )
    assert _one_line(["info", str(pipe)]) == said
    assert _one_line(["view", str(pipe), "--save", str(tmp_path / "v.rrd")]) == said
    assert not (tmp_path / "t.mcap").exists()


def test_convert_refuses_a_pipe_as_the_motion_csv(tmp_path: Path) -> None:
    (csv := tmp_path / "ft.csv").write_text("time,fx,fy,fz,tx,ty,tz\n0,0,0,0,0,0,0\n")
    os.mkfifo(motion := tmp_path / "motion.csv")
    line = _one_line(["convert", str(csv), "--motion", str(motion), "-o", str(tmp_path / "t.mcap"),
                      "--task", "gown"])  # fmt: skip
    assert line == (
        f"Error: {motion}: is not a regular file (a pipe or a device); save it to a file first"
    )


def _dead_pid() -> int:
    import subprocess

    done = subprocess.Popen(["true"])
    done.wait()
    return done.pid


def test_a_killed_runs_temporary_is_removed_when_its_name_is_next_written(tmp_path: Path):
    """`kill -9` leaves `.NAME.PID.N.partial`: the next writer of NAME removes it, if its
    process is gone (a running one's is its own), and nothing of another name."""
    import subprocess

    dead, alive = _dead_pid(), subprocess.Popen(["sleep", "60"])
    try:
        left = {}
        for name in ("t.mcap", "t.rrd"):
            left[name] = [tmp_path / f".{name}.{dead}.0.partial",
                          tmp_path / f".{name}.{alive.pid}.3.partial"]  # fmt: skip
        other = tmp_path / f".t.mcap.5.{dead}.0.partial"  # a temporary of `t.mcap.5`
        for path in [*left["t.mcap"], *left["t.rrd"], other]:
            path.write_bytes(b"half a trial")
        trial, rrd = tmp_path / "t.mcap", tmp_path / "t.rrd"
        args = ["record", "--task", "gown", "--duration", "0.05", "-o", str(trial)]
        assert CliRunner().invoke(main, args).exit_code == 0
        assert not left["t.mcap"][0].exists() and left["t.mcap"][1].exists() and other.exists()
        assert left["t.rrd"][0].exists()  # not yet written
        assert CliRunner().invoke(main, ["infer", str(trial), "-o", str(rrd)]).exit_code == 0
        assert not left["t.rrd"][0].exists() and left["t.rrd"][1].exists()
    finally:
        alive.kill()
        alive.wait()


def test_a_killed_saves_temporary_folder_and_an_atomic_files_are_removed(tmp_path: Path):
    from dresslog.io.files import atomic_path
    from dresslog.model.files import load_model, save_model

    dead = _dead_pid()
    (stale := tmp_path / f".model.{dead}.0.partial").mkdir()
    (stale / "model.safetensors").write_bytes(b"half")
    loaded = load_model(GOWN_MODEL)
    save_model(tmp_path / "model", loaded.weights, loaded.card)
    assert not stale.exists() and load_model(tmp_path / "model").card == loaded.card
    (stale := tmp_path / f".table.csv.{dead}.0.partial").write_text("half")
    with atomic_path(tmp_path / "table.csv") as tmp:
        tmp.write_text("whole")
    assert not stale.exists() and sorted(p.name for p in tmp_path.iterdir()) == [
        "model",
        "table.csv",
    ]


@pytest.mark.parametrize(("shift_ns", "to"), [(2_505_000_000, "2.495"), (2_500_000_000, "2.500")])
def test_stamps_that_go_backwards_are_named_so_not_as_another_rate(
    tmp_path: Path, shift_ns: int, to: str
) -> None:
    """A clock that jumps back by half a step read as `is at 200 Hz`, by whole steps as
    stamps repeated: it is the stamps going backwards."""
    jumped = np.concatenate([T700[:500], T700[500:] - shift_ns])
    path = _steps_at(tmp_path / "back.mcap", jumped, T700)
    line = _one_line(["infer", str(path), "-o", str(tmp_path / "o.rrd")])
    assert line == (
        f"Error: {path}: channel {wk.WRENCH}: header stamps go backwards at message 500 of 700 "
        f"in the order logged, from 4.990 s to {to} s (counted from the first stamp): its clock "
        f"jumped back, and a step is one time; {CURE}"
    )


@pytest.mark.parametrize("with_maps", [True, False], ids=["force-map", "limb-points-alone"])
def test_a_gown_trial_with_a_legs_limb_is_blamed_on_the_trial(tmp_path: Path, with_maps) -> None:
    """It was `model has 300 limb points but the trial has 400`: the model fits gown trials."""
    from dresslog.io.writer import TrialWriter
    from dresslog.limb import build_limb, limb_points

    path = tmp_path / "gown400.mcap"
    with TrialWriter(path, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_limb_points(0, limb_points(build_limb(Task.SHORTS)))
        writer.write_wrench(T700[:20], np.zeros((20, 6)))
        writer.write_twist(T700[:20], np.zeros((20, 6)))
        if with_maps:
            writer.write_force_map(T700[:20], np.zeros((20, 400), np.float32))
    if with_maps:
        said = (
            f"Error: {path}: channel {wk.FORCE_MAP}: the trial's force map has 400 points where "
            f"a gown trial has 300 (its {wk.LIMB_POINTS} too): its task or its maps are wrong; "
            "the recording is corrupt, re-record it"
        )
    else:
        said = (
            f"Error: {path}: channel {wk.LIMB_POINTS}: the trial's limb has 400 points where a "
            "gown trial has 300: its task or its limb points are wrong; the recording is "
            "corrupt, re-record it"
        )
    assert _one_line(["infer", str(path), "-o", str(tmp_path / "o.rrd")]) == said
    if with_maps:
        assert _one_line(["info", str(path)]) == said


@pytest.mark.parametrize("metadata", [True, False], ids=["trial", "bare"])
@pytest.mark.parametrize("registered", [True, False], ids=["empty-channels", "no-channels"])
def test_a_file_of_no_messages_says_it_holds_none(tmp_path: Path, metadata, registered) -> None:
    """It was `not a dresslog trial (channels: none)`."""
    channels = {wk.WRENCH: (WRENCH[0], []), wk.TWIST: (TWIST[0], [])} if registered else {}
    raw_mcap(path := tmp_path / "silent.mcap", channels, metadata)
    line = _one_line(["infer", str(path), "-o", str(tmp_path / "o.rrd")])
    assert line.startswith(f"Error: {path}: holds no messages"), line
    if metadata:
        assert line.endswith(": a trial with no step; re-record it")
    else:
        assert "and no `dresslog` metadata record: an empty MCAP file, not a trial" in line


@pytest.mark.parametrize("command", ["info", "convert"])
def test_a_bags_deeply_nested_metadata_yaml_is_one_line(tmp_path: Path, command: str) -> None:
    """YAML's flow style is JSON's: ruamel.yaml raised RecursionError, a traceback."""
    pytest.importorskip("rosbags")
    (bag := tmp_path / "bag").mkdir()
    (bag / "metadata.yaml").write_text(DEEP)
    args = ["-o", str(tmp_path / "t.mcap"), "--task", "gown"] if command == "convert" else []
    assert _one_line([command, str(bag), *args]) == (
        f"Error: {bag}: cannot read bag: its metadata.yaml nests too deeply for a YAML reader "
        "to follow, as no recorder writes it; restore the bag's metadata.yaml (`ros2 bag "
        "reindex` writes it again)"
    )


def test_a_dataset_trial_whose_truth_has_a_hole_is_refused(tmp_path: Path) -> None:
    """Training read the steps either side of the hole as consecutive."""
    from dresslog.dataset.cache import load_dataset
    from dresslog.dataset.manifest import Entry, Manifest, Split, Status, slot_file
    from dresslog.errors import DatasetError
    from dresslog.io.files import sha256_file
    from dresslog.io.writer import TrialWriter
    from dresslog.limb import build_limb, limb_points
    from dresslog.spec import TrialSpec

    root = tmp_path / "data"
    entries = []
    for slot in range(2):
        (path := root / slot_file(Split.TRAIN, slot)).parent.mkdir(parents=True, exist_ok=True)
        spec = TrialSpec(task=Task.GOWN, seed=slot)
        with TrialWriter(path, TrialMetadata(task=Task.GOWN, spec=spec)) as writer:
            writer.write_limb_points(0, limb_points(build_limb(Task.GOWN)))
            writer.write_wrench(T700[:40], np.zeros((40, 6)))
            writer.write_twist(T700[:40], np.zeros((40, 6)))
            truth = T700[:40] if slot == 0 else np.delete(T700[:40], np.arange(10, 20))
            writer.write_force_map(truth, np.zeros((len(truth), 300), np.float32))
        entries.append(Entry(split=Split.TRAIN, slot=slot, status=Status.OK,
                             file=slot_file(Split.TRAIN, slot), spec=spec, steps=40,
                             size=path.stat().st_size, sha256=sha256_file(path)))  # fmt: skip
    Manifest(task=Task.GOWN, n_train=2, n_test=0, trials=entries).save(root)
    with pytest.raises(DatasetError) as info:
        load_dataset(root, workers=1, progress=False)
    assert str(info.value) == (
        f"{root}: trial train/000001.mcap has no ground-truth force map on 10 of its 40 steps "
        "(the first at 0.100 s); run `dresslog generate` on it again to re-create it"
    )
