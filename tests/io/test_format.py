"""A trial written by TrialWriter reads back identically, here and in other tools."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from dresslog.errors import TrialWriteError
from dresslog.io import cdr, msgdefs
from dresslog.io import well_known as wk
from dresslog.io.msgdefs import schema_text
from dresslog.io.reader import TrialReader, read_trial
from dresslog.io.writer import TrialWriter
from dresslog.spec import Outcome, Task, TrialMetadata
from dresslog.trial import CONTACT_DTYPE, LimbPoints
from tests.conftest import mcap_records, write_mcap, write_synthetic_trial

SAMPLES = Path(__file__).resolve().parents[2] / "samples"


@pytest.mark.parametrize("task", list(Task))
def test_every_stream_round_trips(make_trial, task: Task) -> None:
    path, sent = make_trial(task)
    trial = read_trial(path)
    np.testing.assert_array_equal(trial.wrench.t_ns, sent["t_ns"])
    np.testing.assert_array_equal(trial.wrench.values, sent["wrench"])
    np.testing.assert_array_equal(trial.twist.values, sent["twist"])
    np.testing.assert_array_equal(trial.pose.values, sent["pose"])
    np.testing.assert_array_equal(trial.force_map.forces, sent["forces"])
    assert trial.force_map.contact.shape == (len(sent["t_ns"]), 0)
    for got, want in zip(trial.contacts.items, sent["contacts"], strict=True):
        np.testing.assert_array_equal(got, want)
    assert trial.limb_points.limb == sent["limb"].limb
    assert trial.limb_points.segment_names == sent["limb"].segment_names
    np.testing.assert_array_equal(trial.limb_points.points, sent["limb"].points)
    np.testing.assert_array_equal(trial.garment.vertices[1], sent["vertices"] + 10)
    np.testing.assert_array_equal(trial.garment.triangles, sent["triangles"])
    assert trial.metadata.spec == sent["spec"]
    assert trial.metadata.outcome is Outcome.DRESSED
    assert trial.metadata.software["dresslog"]
    phi = trial.measurements.phi
    np.testing.assert_allclose(phi[:, :6], sent["wrench"], rtol=1e-6)
    np.testing.assert_allclose(phi[:, 6:], sent["twist"][:, :3], rtol=1e-6)


def test_file_uses_the_ros2_profile_and_registers_the_msg_files(make_trial) -> None:
    from mcap.reader import make_reader

    path, _ = make_trial()
    with path.open("rb") as stream:
        reader = make_reader(stream)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2"
    assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        assert schema.encoding == "ros2msg"
        assert schema.name == (wk.SCHEMAS | wk.DRAWN | wk.UNSTAMPED)[channel.topic]
        assert schema.data.decode() == schema_text(schema.name)
    assert all(ci.compression == "zstd" for ci in summary.chunk_indexes)


def test_estimate_carries_its_contact_map(tmp_path: Path, make_trial) -> None:
    path, sent = make_trial()
    out = tmp_path / "with_estimate.mcap"
    rng = np.random.default_rng(1)
    est = rng.random(sent["forces"].shape).astype(np.float32)
    contact = rng.normal(size=est.shape).astype(np.float32)
    with TrialWriter(out, read_trial(path).metadata) as writer:
        writer.write_wrench(sent["t_ns"], sent["wrench"])
        writer.write_twist(sent["t_ns"], sent["twist"])
        writer.write_force_map(sent["t_ns"], est, contact, estimate=True)
    with TrialReader(out) as reader:
        assert reader.force_map is None
        np.testing.assert_array_equal(reader.estimate.forces, est)
        np.testing.assert_array_equal(reader.estimate.contact, contact)


@pytest.mark.parametrize(
    "msg",
    [
        "dresslog_msgs/msg/ForceMap",
        "dresslog_msgs/msg/ContactArray",
        "dresslog_msgs/msg/LimbPoints",
        "dresslog_msgs/msg/GarmentState",
        "geometry_msgs/msg/WrenchStamped",
        "geometry_msgs/msg/TwistStamped",
        "geometry_msgs/msg/PoseStamped",
    ],
)
def test_numpy_codec_agrees_with_the_msg_text(msg: str) -> None:
    """Encode with the numpy codec; mcap_ros2's decoder, built from the .msg text, agrees."""
    from mcap_ros2._dynamic import generate_dynamic

    decoder = generate_dynamic(msg, schema_text(msg))[msg]
    sizes = {
        "header.frame_id": 5,
        "forces": 3,
        "contact": 3,
        "contacts": 2,
        "limb": 3,
        "points": 2,
        "segment": 2,
        "segment_names": (2, 4),
        "vertices": 2,
        "triangles": 3,
    }
    dtype = cdr.layout(msg, {k: v for k, v in sizes.items() if _uses(msg, k)})
    messages = cdr.new_messages(msg, {k: v for k, v in sizes.items() if _uses(msg, k)}, 1)
    cdr.set_stamp(messages, np.array([3_000_000_007]), "world")
    rng = np.random.default_rng(0)
    for name in dtype.names:
        field = dtype.fields[name][0]
        if name.endswith(".len") or name.startswith(("encapsulation", "header")):
            continue
        if field.kind == "S":
            messages[name] = b"xyzw"[: field.itemsize - 1]
        elif field.subdtype and field.subdtype[0].names:  # array of Contact
            arr = np.zeros(field.shape, CONTACT_DTYPE)
            arr["position"] = rng.normal(size=(*field.shape, 3))
            arr["normal_force"] = 2.5
            arr["segment"] = 3
            messages[name] = arr
        else:
            messages[name] = rng.integers(0, 9, size=messages[name].shape)
    payload = cdr.to_payloads(messages)[0]
    decoded = decoder(payload)
    assert decoded.header.stamp.sec == 3 and decoded.header.stamp.nanosec == 7
    assert decoded.header.frame_id == "world"
    back = cdr.decode(msg, [payload])[0][0]
    assert back.tobytes() == messages[0].tobytes()
    _compare(decoded, messages[0], dtype)


def test_an_empty_sequence_of_float64s_takes_no_padding() -> None:
    """CDR aligns elements, so an empty sequence of 8-byte ones pads nothing: a scene
    entity's empty lists of primitives (float64 inside) sit between its other fields, and
    the codec padded them as if they held some. Bytes as rosbags serialises them."""
    from dresslog.io import drawn

    store = _ros2_and_foxglove_types()
    scene = store.types[drawn.SCENE_UPDATE]
    entity, tri = (
        store.types[f"foxglove_msgs/msg/{n}"] for n in ("SceneEntity", "TriangleListPrimitive")
    )
    Time, Duration, Pose, Point, Quaternion, Color = (  # noqa: N806 (classes)
        store.types[n] for n in ("builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration",
        "geometry_msgs/msg/Pose", "geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion",
        "foxglove_msgs/msg/Color"))  # fmt: skip
    vertices = np.array([[0.5, 0.25, 1.0], [0.75, 0.0, -1.0], [2.0, 1.5, 0.125]])
    mesh = tri(
        pose=Pose(position=Point(x=0.0, y=0.0, z=0.0),
                  orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
        points=[Point(x=x, y=y, z=z) for x, y, z in vertices],
        color=Color(r=0.3, g=0.5, b=0.85, a=0.75), colors=[],
        indices=np.array([0, 1, 2], np.uint32),
    )  # fmt: skip
    lists = ("metadata", "arrows", "cubes", "spheres", "cylinders", "lines", "texts", "models")
    empty: dict[str, list] = {name: [] for name in lists}
    theirs = store.serialize_cdr(scene(deletions=[], entities=[entity(
        timestamp=Time(sec=3, nanosec=7), frame_id="world", id="garment",
        lifetime=Duration(sec=0, nanosec=0), frame_locked=False, triangles=[mesh], **empty,
    )]), drawn.SCENE_UPDATE)  # fmt: skip
    ours = drawn.scene_update(3_000_000_007, "world", "garment", vertices, np.arange(3))
    assert cdr.to_payloads(ours)[0] == bytes(theirs)


def _uses(msg: str, key: str) -> bool:
    return key == "header.frame_id" or key in {f for _, f in _fields(msg)}


def _fields(msg: str) -> list[tuple[str, str]]:
    from dresslog.io.msgdefs import fields

    return fields(msg)


def _compare(decoded: object, message: np.void, dtype: np.dtype) -> None:
    for name in dtype.names:
        if name == "encapsulation" or name.endswith(".len") or name.startswith("header"):
            continue
        parts = name.split(".")
        value = decoded
        for part in parts:
            value = value[int(part)] if part.isdigit() else getattr(value, part)
        mine = message[name]
        if isinstance(value, str):
            assert value.encode() == bytes(mine)
        elif isinstance(value, list) and value and hasattr(value[0], "x"):
            np.testing.assert_array_equal([[v.x, v.y, v.z] for v in value], mine)
        elif isinstance(value, list) and value and hasattr(value[0], "position"):
            np.testing.assert_array_equal(
                [[v.position.x, v.position.y, v.position.z] for v in value], mine["position"]
            )
            assert [v.segment for v in value] == mine["segment"].tolist()
        elif hasattr(value, "x"):
            coords = [value.x, value.y, value.z] + ([value.w] if hasattr(value, "w") else [])
            np.testing.assert_array_equal(coords, mine)
        else:
            np.testing.assert_array_equal(np.asarray(value), mine)


def test_mcap_ros2_decodes_identical_values(make_trial) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path, sent = make_trial()
    wrench, forces, contacts = [], [], []
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            if channel.topic == wk.WRENCH:
                f, t = msg.wrench.force, msg.wrench.torque
                wrench.append([f.x, f.y, f.z, t.x, t.y, t.z])
            elif channel.topic == wk.FORCE_MAP:
                forces.append(msg.forces)
            elif channel.topic == wk.CONTACTS:
                contacts.append([c.normal_force for c in msg.contacts])
    np.testing.assert_array_equal(wrench, sent["wrench"])
    np.testing.assert_array_equal(np.array(forces, np.float32), sent["forces"])
    assert contacts == [c["normal_force"].tolist() for c in sent["contacts"]]


def test_the_file_says_its_qos_policies_are_integers_as_humbles_recorder_does(make_trial) -> None:
    """rosbag2 from Jazzy on reads QoS policies as names, and integers as `unknown`, unless
    a `rosbag2` metadata record without `serialized_metadata` marks the file (version 8)."""
    from mcap.reader import make_reader

    path, _ = make_trial(Task.GOWN)
    with path.open("rb") as stream:
        records = {m.name: m.metadata for m in make_reader(stream).iter_metadata()}
    assert records["rosbag2"] == {"ROS_DISTRO": "humble"}
    assert "reliability: 1\n" in wk.STREAM_QOS  # rmw's RELIABLE, as an integer


def test_rosbags_anyreader_decodes_identical_values(make_trial) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import QosDurability, QosReliability

    path, sent = make_trial(Task.SHORTS)
    with AnyReader([path]) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == {
            t: (wk.SCHEMAS | wk.DRAWN | wk.UNSTAMPED)[t] for t in reader.topics
        }
        # rosbag2's QoS, which the ros2 profile requires: reliable; the limb points latched.
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        assert all(
            len(q) == 1 and q[0].reliability == QosReliability.RELIABLE for q in qos.values()
        )
        for latched in (wk.LIMB_POINTS, wk.LIMB_MARKER, wk.PATH_MARKER, wk.TF_STATIC):
            assert qos[latched][0].durability == QosDurability.TRANSIENT_LOCAL
        assert qos[wk.TWIST][0].durability == QosDurability.VOLATILE
        assert qos[wk.METADATA_TOPIC][0].durability == QosDurability.TRANSIENT_LOCAL
        twist, points = [], None
        for conn, t_ns, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic == wk.TWIST:
                twist.append(
                    [
                        msg.twist.linear.x,
                        msg.twist.linear.y,
                        msg.twist.linear.z,
                        msg.twist.angular.x,
                        msg.twist.angular.y,
                        msg.twist.angular.z,
                    ]
                )
                assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == t_ns
            elif conn.topic == wk.LIMB_POINTS:
                points = msg
    np.testing.assert_array_equal(twist, sent["twist"])
    assert points.limb == "leg" and points.segment_names == ["a", "bb", "ccc"]
    np.testing.assert_array_equal([[p.x, p.y, p.z] for p in points.points], sent["limb"].points)


def test_rerun_imports_the_file(make_trial) -> None:
    from rerun.chunk import McapReader

    path, _ = make_trial()
    reader = McapReader(path, timeline_type="duration_ns")
    assert reader.info().profile == "ros2"
    entities = {str(chunk.entity_path) for chunk in reader.stream()}
    assert {wk.WRENCH, wk.TWIST, wk.FORCE_MAP, wk.CONTACTS} <= entities


def test_interrupted_write_leaves_nothing_under_the_final_name(tmp_path: Path) -> None:
    path = tmp_path / "t.mcap"
    with pytest.raises(RuntimeError), TrialWriter(path, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_wrench(0, np.zeros(6))
        assert list(tmp_path.glob(".t.mcap.*.partial"))
        raise RuntimeError("simulation blew up")
    assert list(tmp_path.iterdir()) == []


def test_two_writers_of_one_path_do_not_share_a_temporary(tmp_path: Path) -> None:
    """Each writes its own file; the one that finishes last is the file, whole."""
    path = tmp_path / "t.mcap"
    first = TrialWriter(path, TrialMetadata(task=Task.GOWN), overwrite=True).open()
    with TrialWriter(path, TrialMetadata(task=Task.SHORTS), overwrite=True) as second:
        for writer, value in ((first, 0.0), (second, 1.0)):
            writer.write_wrench(0, np.full(6, value))
            writer.write_twist(0, np.full(6, value))
    first.close()
    trial = read_trial(path)
    assert trial.metadata.task is Task.GOWN and np.all(trial.wrench.values == 0)
    assert list(tmp_path.iterdir()) == [path]


@pytest.mark.parametrize("stage", ["start", "finish"])
def test_ctrl_c_while_opening_or_finishing_leaves_no_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stage: str
) -> None:
    """Finishing compresses the last chunk, the likeliest place for a Ctrl-C to land."""
    from mcap.writer import Writer

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(Writer, stage, interrupted)
    metadata = TrialMetadata(task=Task.GOWN)
    with pytest.raises(KeyboardInterrupt), TrialWriter(tmp_path / "t.mcap", metadata) as writer:
        writer.write_wrench(0, np.zeros(6))
        writer.write_twist(0, np.zeros(6))
    assert list(tmp_path.iterdir()) == []


def test_writer_refuses_to_overwrite_unless_asked(make_trial) -> None:
    from dresslog.errors import TrialWriteError

    path, _ = make_trial()
    with pytest.raises(TrialWriteError, match="exists"):
        TrialWriter(path, TrialMetadata(task=Task.GOWN)).open()
    with TrialWriter(path, TrialMetadata(task=Task.SHORTS), overwrite=True) as writer:
        writer.write_wrench(0, np.zeros(6))
        writer.write_twist(0, np.zeros(6))
    assert read_trial(path).metadata.task is Task.SHORTS


def test_writer_rejects_nan(tmp_path: Path) -> None:
    from dresslog.errors import TrialWriteError

    with (
        pytest.raises(TrialWriteError, match="NaN"),
        TrialWriter(tmp_path / "t.mcap", TrialMetadata(task=Task.GOWN)) as writer,
    ):
        writer.write_wrench(0, [0, 0, np.nan, 0, 0, 0])
    assert not (tmp_path / "t.mcap").exists()


def _steps(writer: TrialWriter, t_ns: list[int] | None = None) -> None:
    times = np.array(t_ns or [0, 10_000_000])
    writer.write_wrench(times, np.zeros((len(times), 6)))
    writer.write_twist(times, np.zeros((len(times), 6)))


def _limb(points: int, *, nan: bool = False) -> LimbPoints:
    at = np.full((points, 3), np.nan if nan else 0.0)
    return LimbPoints("arm", at, np.zeros(points, np.uint32), ("fist",))


WRITTEN_WRONG = {  # what the reader refuses, refused as it is written
    "no twist": (
        lambda w: w.write_wrench(0, np.zeros(6)),
        "a trial needs /ee/wrench and /ee/twist at one or more common times",
    ),
    "no common time": (
        lambda w: (w.write_wrench([0, 2], np.zeros((2, 6))), w.write_twist(1, np.zeros(6))),
        "at one or more common times",
    ),
    "no common time, 100 ns apart at epoch times": (
        lambda w: (
            w.write_wrench(500_000_000_000_000_000, np.zeros(6)),  # after the 2020 origin: 2035
            w.write_twist(500_000_000_000_000_100, np.zeros(6)),
        ),
        "at one or more common times",
    ),
    "limb points with NaN": (
        lambda w: w.write_limb_points(0, _limb(3, nan=True)),
        "/limb/points have NaN or infinite positions",
    ),
    "maps narrower than the limb": (
        lambda w: (w.write_limb_points(0, _limb(3)), w.write_force_map(0, np.zeros(2))),
        "/limb/force_map maps of 2 points for 3 limb points",
    ),
    "limb wider than the maps": (
        lambda w: (w.write_force_map(0, np.zeros(2)), w.write_limb_points(0, _limb(3))),
        "/limb/points are 3, for maps of 2 points",
    ),
    "garment resized": (
        lambda w: (w.write_garment(0, np.zeros((4, 3))), w.write_garment(1, np.zeros((5, 3)))),
        "/garment/state keeps its 4 vertices",
    ),
    "triangles after the first message": (
        lambda w: (
            w.write_garment(0, np.zeros((4, 3))),
            w.write_garment(1, np.zeros((4, 3)), [[0, 1, 2]]),
        ),
        "its triangles go in the first message only",
    ),
    "a time past int32 seconds": (
        lambda w: _steps(w, [0, 2**31 * 1_000_000_000]),
        "past what a ROS 2 stamp holds",
    ),
}


@pytest.mark.parametrize("case", WRITTEN_WRONG)
def test_writer_refuses_what_its_reader_would_refuse(tmp_path: Path, case: str) -> None:
    """Found only on reading, after a whole recording; a triangle list was lost silently."""
    write, message = WRITTEN_WRONG[case]
    with (
        pytest.raises(TrialWriteError, match=message),
        TrialWriter(tmp_path / "t.mcap", TrialMetadata(task=Task.GOWN)) as writer,
    ):
        write(writer)
        if not case.startswith(("no twist", "no common time")):
            _steps(writer, [2**40, 2**40 + 10_000_000])
    assert list(tmp_path.iterdir()) == []


def test_a_writer_used_twice_refuses_rather_than_overwrite_a_good_trial(tmp_path: Path) -> None:
    """Its second file named channels registered only in the first: no reader opened it."""
    writer = TrialWriter(path := tmp_path / "t.mcap", TrialMetadata(task=Task.GOWN))
    with writer:
        _steps(writer)
    writer.overwrite = True
    with pytest.raises(TrialWriteError, match="a TrialWriter writes one file"), writer:
        _steps(writer, [20_000_000])
    assert len(read_trial(path).wrench) == 2 and [*tmp_path.iterdir()] == [path]


def test_a_reader_opened_again_reads_the_file_as_it_is_now(tmp_path: Path) -> None:
    """It served the streams it had decoded before, beside the new file's channels."""
    path = tmp_path / "t.mcap"
    reader = TrialReader(path)
    for value in (1.0, 2.0):
        with TrialWriter(path, TrialMetadata(task=Task.GOWN), overwrite=True) as writer:
            writer.write_wrench([0, 10_000_000], np.full((2, 6), value))
            writer.write_twist([0, 10_000_000], np.full((2, 6), value))
        with reader:
            assert (reader.measurements.phi == value).all()


def test_a_reader_whose_open_failed_serves_nothing(tmp_path: Path) -> None:
    """Reopened on a file since replaced by a bad one, it had served the old file's metadata
    (and a first open that failed on the metadata, an AssertionError): it is not open."""
    import shutil

    from dresslog.errors import TrialFormatError

    path = tmp_path / "t.mcap"
    with TrialWriter(path, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_wrench([0, 10_000_000], np.ones((2, 6)))
        writer.write_twist([0, 10_000_000], np.ones((2, 6)))
    reader = TrialReader(path).open()
    assert reader.metadata.task is Task.GOWN
    shutil.copy(SAMPLES / "gown.mcap", path)
    with path.open("r+b") as stream:  # the metadata record's JSON, made invalid in place
        data = stream.read()
        at = data.index(b'"format_version"')
        stream.seek(at)
        stream.write(b'"format_versio!"')
    for _ in range(2):  # a reopen, and a first open of a fresh reader
        with pytest.raises(TrialFormatError, match="metadata"):
            reader.open()
        with pytest.raises(TrialFormatError, match="reader is not open"):
            reader.metadata  # noqa: B018
        with pytest.raises(TrialFormatError, match="reader is not open"):
            reader.measurements  # noqa: B018
        reader = TrialReader(path)


def test_metadata_json_schema_in_schemas_is_current() -> None:
    import json
    from importlib import resources

    from dresslog.spec import SCHEMA_FILE, metadata_json_schema

    kept = resources.files("dresslog.schemas").joinpath(SCHEMA_FILE).read_text()
    assert json.loads(kept) == metadata_json_schema(), "run `python -m dresslog.spec`"


def test_the_schema_script_writes_only_when_run_bare_and_the_schema_changed() -> None:
    """`python -m dresslog.spec --help` had rewritten the installed schema file."""
    import subprocess
    import sys
    from importlib import resources

    from dresslog.spec import SCHEMA_FILE

    with resources.as_file(resources.files("dresslog.schemas").joinpath(SCHEMA_FILE)) as path:
        before = path.stat().st_mtime_ns
        script = [sys.executable, "-m", "dresslog.spec"]
        asked = subprocess.run([*script, "--help"], capture_output=True, text=True)
        assert asked.returncode == 1 and asked.stderr.startswith("usage: python -m dresslog.spec")
        bare = subprocess.run(script, capture_output=True, text=True, check=True)
        assert bare.stdout == f"up to date: {path}\n"
        assert path.stat().st_mtime_ns == before


def test_metadata_record_validates_against_the_json_schema(make_trial) -> None:
    import json

    import jsonschema
    from mcap.reader import make_reader

    from dresslog.spec import metadata_json_schema

    path, _ = make_trial()
    with path.open("rb") as stream:
        (record,) = [m for m in make_reader(stream).iter_metadata() if m.name == "dresslog"]
    jsonschema.validate(json.loads(record.metadata["trial"]), metadata_json_schema())


def test_dresslog_msgs_is_a_ros2_interface_package_of_exactly_its_msg_files() -> None:
    """colcon builds schemas/dresslog_msgs only if its package.xml and CMakeLists agree
    with the .msg files and declare every package those files use."""
    import re
    import xml.etree.ElementTree as ET

    folder = Path(__file__).resolve().parents[2] / "schemas" / "dresslog_msgs"
    package = ET.parse(folder / "package.xml").getroot()
    assert package.get("format") == "3" and package.findtext("name") == folder.name
    assert package.findtext("member_of_group") == "rosidl_interface_packages"
    depends = {d.text for d in package.findall("depend")}
    msgs = sorted(p.name for p in (folder / "msg").glob("*.msg"))
    cmake = (folder / "CMakeLists.txt").read_text()
    assert sorted(re.findall(r'"msg/(\w+\.msg)"', cmake)) == msgs
    used = {
        m.group(1)
        for name in msgs
        for m in re.finditer(r"^(\w+)/\w+", (folder / "msg" / name).read_text(), re.M)
    }
    assert used - {folder.name} <= depends, used
    assert f"DEPENDENCIES {' '.join(sorted(depends))}" in cmake


def _nan_contacts() -> np.ndarray:
    contacts = np.zeros(2, CONTACT_DTYPE)
    contacts["normal_force"] = np.nan
    return contacts


META = TrialMetadata(task=Task.GOWN)
T10 = np.arange(10, dtype=np.int64) * 10_000_000
BAD_WRITES = {
    "float times": (lambda w: w.write_wrench(T10 * 1e-9, np.zeros((10, 6))), "integer nanosec"),
    "times repeated": (
        lambda w: w.write_wrench(np.zeros(10, np.int64), np.zeros((10, 6))),
        "increase",
    ),
    "times going back": (
        lambda w: (w.write_wrench(T10[5], np.zeros(6)), w.write_wrench(T10[2], np.zeros(6))),
        "increase",
    ),
    "fewer times than rows": (
        lambda w: w.write_twist(T10[:5], np.zeros((10, 6))),
        "5 times for 10",
    ),
    "contacts not CONTACT_DTYPE": (lambda w: w.write_contacts(0, np.ones((3, 4))), "CONTACT_DTYPE"),
    "NaN contact force": (lambda w: w.write_contacts(0, _nan_contacts()), "NaN or infinite"),
    "NaN contact map": (
        lambda w: w.write_force_map(T10, np.zeros((10, 4)), np.full((10, 4), np.nan)),
        "NaN or infinite",
    ),
    "force maps changing width": (
        lambda w: (w.write_force_map(T10[0], np.zeros(4)), w.write_force_map(T10[1], np.zeros(3))),
        "maps of 3 points after maps of 4",
    ),
    "NaN garment": (lambda w: w.write_garment(0, np.full((3, 3), np.nan)), "finite"),
    "triangle past the vertices": (
        lambda w: w.write_garment(0, np.zeros((3, 3)), [[0, 1, 5]]),
        "index its vertices",
    ),
}


@pytest.mark.parametrize("case", BAD_WRITES)
def test_the_writer_refuses_what_its_reader_would_refuse_and_writes_nothing(
    tmp_path: Path, case: str
) -> None:
    """Every file TrialWriter lets through is one TrialReader reads back the same."""
    write, message = BAD_WRITES[case]
    path = tmp_path / "t.mcap"
    with pytest.raises(TrialWriteError, match=message), TrialWriter(path, META) as writer:
        write(writer)
    assert list(tmp_path.iterdir()) == []


def test_the_writer_refuses_metadata_that_is_not_a_trial_metadata_before_writing(
    tmp_path: Path,
) -> None:
    with pytest.raises(TrialWriteError, match="metadata must be a TrialMetadata, not dict"):
        TrialWriter(tmp_path / "t.mcap", {"task": "gown"})  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "name",
    sorted({n for n in map(str, (wk.SCHEMAS | wk.DRAWN).values()) if not n.startswith("dresslog")}),
)
def test_standard_schemas_are_ros2s_own_with_their_defaults(name: str) -> None:
    """ROS 2 tools read our standard messages as theirs: same fields, same default values.
    foxglove_msgs is no ROS 2 core package: tests/test_viewers.py checks it against
    Foxglove's own definitions; what it holds from the core packages is checked here."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    humble = get_typestore(Stores.ROS2_HUMBLE)
    types = [name, *msgdefs.dependencies(name)]
    for type_name in [n for n in types if not n.startswith("foxglove_msgs/")]:
        ours = get_types_from_msg(msgdefs.msg_text(type_name), type_name)[type_name]
        assert ours == humble.fielddefs[type_name], type_name
    assert "float64 w 1" in msgdefs.msg_text("geometry_msgs/msg/Quaternion")  # identity


def _rewritten_raw(good: Path, out: Path, order: np.ndarray, split: str | None = None) -> Path:
    """`good`'s messages by mcap's own writer in `order`; `split`'s on two channels."""
    messages, metadata = mcap_records(good)
    rows = []
    for i in order:
        schema, channel, message = messages[i]
        key = (channel.topic, i % 2 if channel.topic == split else 0)
        rows.append((key, schema, channel.topic, message.log_time, message.data,
                     message.publish_time))  # fmt: skip
    return write_mcap(out, "a merging tool", rows, metadata)


@pytest.mark.parametrize("shuffled", [False, True], ids=["merged", "merged-and-shuffled"])
def test_messages_out_of_order_or_on_two_channels_of_a_topic_read_as_recorded(
    make_trial, tmp_path: Path, shuffled: bool
) -> None:
    """MCAP promises no time order, and `mcap merge` can leave one topic on two channels."""
    good, _ = make_trial()
    with TrialReader(good) as reader:
        count = sum(info.count for info in reader.channels.values())
    order = np.random.default_rng(0).permutation(count) if shuffled else np.arange(count)
    path = _rewritten_raw(good, tmp_path / "merged.mcap", order, split=wk.WRENCH)
    want, got = read_trial(good), read_trial(path)
    with TrialReader(path) as reader:
        assert reader.channels[wk.WRENCH].count == len(want.wrench)
    for name in ("wrench", "twist", "pose"):
        np.testing.assert_array_equal(getattr(got, name).t_ns, getattr(want, name).t_ns)
        np.testing.assert_array_equal(getattr(got, name).values, getattr(want, name).values)
    np.testing.assert_array_equal(got.force_map.forces, want.force_map.forces)
    np.testing.assert_array_equal(got.garment.triangles, want.garment.triangles)
    np.testing.assert_array_equal(got.garment.vertices, want.garment.vertices)
    np.testing.assert_array_equal(got.contacts.t_ns, want.contacts.t_ns)


def test_a_trial_written_meanwhile_is_never_replaced_without_overwrite(tmp_path: Path) -> None:
    """A `convert` finished while a long `record` to the same name ran: its trial was
    replaced silently, though neither was asked to overwrite."""
    path = tmp_path / "t.mcap"
    with (
        pytest.raises(TrialWriteError, match="was written by another command meanwhile"),
        TrialWriter(path, TrialMetadata(task=Task.GOWN)) as writer,
    ):
        _steps(writer)
        path.write_bytes(b"the other command's trial")
    assert path.read_bytes() == b"the other command's trial"
    assert [*tmp_path.iterdir()] == [path]  # no temporary left
    with TrialWriter(path, TrialMetadata(task=Task.GOWN), overwrite=True) as writer:
        _steps(writer)
    assert len(read_trial(path).wrench) == 2


def test_a_full_disk_is_named_for_the_trial_being_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its OSError names no file: record and convert printed `No space left on device`."""
    import errno

    from mcap.writer import Writer

    def full(*args: object, **kwargs: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Writer, "finish", full)
    path = tmp_path / "t.mcap"
    with (
        pytest.raises(TrialWriteError, match=r"t\.mcap: cannot write it: No space left on device"),
        TrialWriter(path, TrialMetadata(task=Task.GOWN)) as writer,
    ):
        _steps(writer)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(sys.platform == "win32", reason="a file size limit is POSIX's")
@pytest.mark.parametrize("command", ["record", "convert"])
def test_a_disk_that_refuses_every_byte_leaves_no_temporary(tmp_path: Path, command: str) -> None:
    """A disk already full fails the finished trial's write and then, again, the flush of
    the bytes still buffered as the temporary is closed: that second error escaped the
    clean-up, so the temporary stayed and the line named no file. A file size limit of 0
    refuses writes as a full disk does, even to root."""
    import subprocess

    (csv := tmp_path / "ft.csv").write_text(
        "time,fx,fy,fz,tx,ty,tz,vx,vy,vz\n"
        + "".join(f"{t / 100},0,0,0,0,0,0,0,0,0\n" for t in range(50))
    )
    out = tmp_path / "out" / "t.mcap"
    args = {
        "record": ["record", "--task", "gown", "--duration", "0.1"],
        "convert": ["convert", str(csv), "--task", "gown"],
    }[command]
    code = (
        "import resource, signal, sys, tempfile\n"
        "tempfile.gettempdir()\n"  # found by writing a file, before the limit refuses it
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "hard = resource.getrlimit(resource.RLIMIT_FSIZE)[1]\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (0, hard))\n"
        "from dresslog.cli.main import main\n"
        "main(sys.argv[1:])"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, *args, "-o", str(out)], capture_output=True, text=True
    )
    assert done.returncode == 1, done.stderr
    assert done.stderr == f"Error: {out}: cannot write it: File too large\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ft.csv"]  # nor the folder made


def test_the_reader_and_writer_are_dresslog_ios_own_names_loaded_on_first_use() -> None:
    """`from dresslog.io import TrialReader` as the README reads; a module that only
    writes files (`dresslog.io.files`, what the model and dataset code import) loads no mcap."""
    import subprocess
    import sys

    import dresslog.io

    assert dresslog.io.TrialReader is TrialReader and dresslog.io.TrialWriter is TrialWriter
    assert sorted(dresslog.io.__all__) == ["TrialReader", "TrialWriter"]
    with pytest.raises(AttributeError, match="has no attribute 'TrialReeder'"):
        dresslog.io.TrialReeder  # noqa: B018
    code = "import sys, dresslog.io.files, dresslog.model; print('mcap' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _ros2_and_foxglove_types():  # rosbags.typesys.Typestore
    """ROS 2 Humble's own types, and foxglove_msgs' from our .msg files (Foxglove's own
    field by field: tests/test_viewers.py)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    scene = wk.DRAWN[wk.GARMENT_SCENE]
    for name in [scene, *msgdefs.dependencies(scene)]:
        if name.startswith("foxglove_msgs/"):
            store.register(get_types_from_msg(msgdefs.msg_text(name), name))
    return store


def _stamp(header) -> int:
    return header.stamp.sec * 10**9 + header.stamp.nanosec


def _on_position_grid(drawn: np.ndarray, positions: np.ndarray) -> None:
    """Drawn positions are `positions` rounded to multiples of `drawn.POSITION_STEP`."""
    from dresslog.io.drawn import POSITION_STEP

    np.testing.assert_array_equal(drawn / POSITION_STEP, np.round(drawn / POSITION_STEP))
    np.testing.assert_allclose(drawn, positions, rtol=0, atol=POSITION_STEP / 2)


def test_drawn_channels_decode_as_ros2s_own_types(make_trial) -> None:
    """The channels viewers draw decode with ROS 2 Humble's own definitions (rosbags'
    typestore, not the schema text in the file), with the trial's values in them: what
    is drawn on a grid within half its step."""
    from mcap.reader import make_reader

    from dresslog.io import drawn as dr

    path, sent = make_trial(steps=120)  # 1.5 s to 2.69 s, the garment every 100 ms
    store = _ros2_and_foxglove_types()
    got: dict[str, list] = {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            if channel.topic in wk.DRAWN:
                assert schema.name == wk.DRAWN[channel.topic]
                msg = store.deserialize_cdr(message.data, schema.name)
                got.setdefault(channel.topic, []).append((message.log_time, msg))
    limb = sent["limb"].points
    t_ns = sent["t_ns"] + wk.TIME_ORIGIN_NS  # stamps: trial time from the 2020 origin
    drawn = np.flatnonzero(np.diff(t_ns // dr.CLOUD_PERIOD_NS, prepend=-1) != 0)
    clouds = got[wk.FORCE_CLOUD]
    assert [t for t, _ in clouds] == t_ns[drawn].tolist()
    for (t, cloud), step in zip(clouds, drawn, strict=True):
        assert [f.name for f in cloud.fields] == ["x", "y", "z", "force"]
        assert (
            cloud.width == len(limb) and cloud.point_step == 16 and cloud.header.frame_id == "limb"
        )
        assert _stamp(cloud.header) == t
        points = cloud.data.view(np.float32).reshape(-1, 4)
        np.testing.assert_array_equal(points[:, :3], limb.astype(np.float32))
        forces = points[:, 3] / dr.FORCE_STEP
        np.testing.assert_array_equal(forces, np.round(forces))
        np.testing.assert_allclose(points[:, 3], sent["forces"][step], atol=dr.FORCE_STEP / 2)
    assert wk.ESTIMATE_CLOUD not in got  # no estimate written
    ((t, tf_static),) = got[wk.TF_STATIC]
    assert [(t.header.frame_id, t.child_frame_id) for t in tf_static.transforms] == [
        ("world", "limb")
    ]
    assert _stamp(tf_static.transforms[0].header) == t == t_ns[0]
    # every pose on /tf (written one at a time here, so one a message)
    frames = [f for _, tf in got[wk.TF] for f in tf.transforms]
    assert [_stamp(f.header) for f in frames[::2]] == t_ns.tolist()
    for gripper, sensor, pose in zip(frames[::2], frames[1::2], sent["pose"], strict=True):
        assert (gripper.child_frame_id, sensor.child_frame_id) == ("gripper", "ee")
        assert _stamp(sensor.header) == _stamp(gripper.header)
        r = gripper.transform.rotation
        assert [r.x, r.y, r.z, r.w] == pose[3:].tolist()
        assert [sensor.transform.translation.x, sensor.transform.rotation.w] == [pose[0], 1.0]
    garment_t = t_ns[::10]
    meshes = np.flatnonzero(np.diff(garment_t // dr.MESH_PERIOD_NS, prepend=-1) != 0)
    assert [t for t, _ in got[wk.GARMENT_SCENE]] == garment_t[meshes].tolist() != []
    for (t, scene), i in zip(got[wk.GARMENT_SCENE], meshes, strict=True):
        (entity,) = scene.entities
        stamp = entity.timestamp.sec * 10**9 + entity.timestamp.nanosec
        assert (entity.id, entity.frame_id, stamp) == ("garment", "world", t)
        (mesh,) = entity.triangles
        assert mesh.pose.orientation.w == 1.0 and mesh.color.a == dr.GARMENT_COLOR[3]
        np.testing.assert_array_equal(mesh.indices, sent["triangles"].ravel())
        points = np.array([[p.x, p.y, p.z] for p in mesh.points])
        _on_position_grid(points, sent["vertices"] + 10 * i)  # the garment: vertices + its step
    clouds = got[wk.GARMENT_CLOUD]  # the same vertices, float64, beside each mesh
    assert [t for t, _ in clouds] == [t for t, _ in got[wk.GARMENT_SCENE]]
    for (t, cloud), (_, scene) in zip(clouds, got[wk.GARMENT_SCENE], strict=True):
        assert [(f.name, f.offset, f.datatype) for f in cloud.fields] == [
            ("x", 0, 8), ("y", 8, 8), ("z", 16, 8)]  # fmt: skip
        assert (cloud.header.frame_id, _stamp(cloud.header), cloud.point_step) == ("world", t, 24)
        points = [[p.x, p.y, p.z] for p in scene.entities[0].triangles[0].points]
        np.testing.assert_array_equal(cloud.data.view(np.float64).reshape(-1, 3), points)
    ((_, path_marker),) = got[wk.PATH_MARKER]
    line = path_marker.markers[0]
    assert line.type == line.LINE_STRIP and _stamp(line.header) == t_ns[0]
    points = [[p.x, p.y, p.z] for p in line.points]
    along = np.flatnonzero(np.diff(t_ns // dr.PATH_PERIOD_NS, prepend=-1) != 0)
    _on_position_grid(np.array(points), sent["pose"][[*along, len(t_ns) - 1], :3])
    ((_, limb_marker),) = got[wk.LIMB_MARKER]
    _on_position_grid(np.array([[p.x, p.y, p.z] for p in limb_marker.markers[0].points]), limb)
    assert _stamp(limb_marker.markers[0].header) == t_ns[0]


def test_tf_holds_the_poses_of_each_100_ms_latest_first_logged_at_the_first() -> None:
    """Poses written together: one TFMessage a 100 ms, each transform at its own stamp,
    listed latest first so that the last one listed is at the message's log time."""
    from dresslog.io import drawn as dr

    t_ns = np.arange(25, dtype=np.int64) * 10_000_000 + 40_000_000  # 40 to 280 ms
    pose = np.concatenate([np.arange(75.0).reshape(25, 3), np.tile([0, 0, 0, 1.0], (25, 1))], 1)
    times, payloads = dr.moving_frames(t_ns, pose)
    assert times.tolist() == [40_000_000, 100_000_000, 200_000_000]
    store = _ros2_and_foxglove_types()
    messages = [store.deserialize_cdr(p, dr.TF_MESSAGE).transforms for p in payloads]
    assert [len(m) for m in messages] == [12, 20, 18]  # 6, 10 and 9 poses, two frames each
    for t, frames in zip(times, messages, strict=True):
        stamps = [_stamp(f.header) for f in frames[::2]]
        assert stamps == sorted(stamps, reverse=True) and stamps[-1] == t
        assert [_stamp(f.header) for f in frames[1::2]] == stamps
        for f in frames[::2]:
            at = np.flatnonzero(t_ns == _stamp(f.header))[0]
            assert f.transform.translation.z == pose[at, 2]


def test_a_writer_told_not_to_draw_writes_dresslogs_channels_alone(tmp_path: Path) -> None:
    """`draw=False`, the benchmarks' peer: the same trial without the standard channels."""
    from dresslog.io.reader import summary_counts

    path, sent = tmp_path / "plain.mcap", write_synthetic_trial(tmp_path / "drawn.mcap")
    with TrialWriter(path, read_trial(tmp_path / "drawn.mcap").metadata, draw=False) as writer:
        writer.write_limb_points(int(sent["t_ns"][0]), sent["limb"])
        writer.write_wrench(sent["t_ns"], sent["wrench"])
        writer.write_twist(sent["t_ns"], sent["twist"])
        writer.write_pose(sent["t_ns"], sent["pose"])
        writer.write_force_map(sent["t_ns"], sent["forces"])
    counts = summary_counts(path)
    assert counts is not None and set(counts) == {
        wk.METADATA_TOPIC,
        wk.LIMB_POINTS,
        wk.WRENCH,
        wk.TWIST,
        wk.POSE,
        wk.FORCE_MAP,
    }
    assert set(wk.DRAWN) <= set(summary_counts(tmp_path / "drawn.mcap") or {}) | {wk.ESTIMATE_CLOUD}
