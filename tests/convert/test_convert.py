"""`dresslog convert` on ROS bags: values on the 100 Hz grid match the analytic signals."""

from __future__ import annotations

import json
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from mcap.writer import Writer

from dresslog.cli.main import main
from dresslog.convert import ConversionWarning, convert, rosbag
from dresslog.errors import ConversionError
from dresslog.io import well_known as wk
from dresslog.io.reader import TrialReader, read_trial
from dresslog.io.summary import format_summary, summarize
from dresslog.io.writer import TrialWriter
from dresslog.spec import Outcome, Task, TrialMetadata
from tests.conftest import SAMPLES, prints_warnings
from tests.convert.signals import (
    YAW_RATE,
    pose,
    quat_rotate,
    seconds_of,
    standard_topics,
    tf_topics,
    times,
    tool_in_world,
    tool_twist_in_world,
    twist,
    wrench,
    write_bag,
)

pytest.importorskip("rosbags")

LAYOUTS = ["ros1", "sqlite3", "mcap", "bare-mcap"]


def make_bag(tmp_path: Path, topics, layout: str, **options) -> Path:
    """A bag of `layout`; `bare-mcap` is the .mcap file inside a ROS 2 mcap bag folder.
    `options` go to `write_bag`."""
    if layout == "ros1":
        return write_bag(tmp_path / "log.bag", topics, "ros1", **options)
    kind = "mcap" if layout == "bare-mcap" else layout
    folder = write_bag(tmp_path / "log", topics, kind, **options)
    return next(folder.glob("*.mcap")) if layout == "bare-mcap" else folder


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    topics = standard_topics()
    return {layout: make_bag(tmp_path_factory.mktemp(layout), topics, layout) for layout in LAYOUTS}


def no_partials(folder: Path) -> bool:
    return not list(folder.glob(".*.partial"))


@pytest.mark.parametrize("layout", LAYOUTS)
def test_a_bag_becomes_a_100_hz_trial_matching_the_analytic_signals(
    bags: dict[str, Path], tmp_path: Path, layout: str
) -> None:
    out = tmp_path / "trial.mcap"
    report = convert(bags[layout], out, "gown")
    with TrialReader(out) as reader:
        wrench_out, twist_out, pose_out = reader.wrench, reader.twist, reader.pose
        metadata = reader.metadata
    assert wrench_out.t_ns[0] == 0
    assert set(np.diff(wrench_out.t_ns).tolist()) == {10_000_000}
    assert len(wrench_out) == report.steps > 290  # 3 s, less the edges the streams share
    t = seconds_of(wrench_out.t_ns + report.source["start_ns"])
    # the 200 Hz vibration is averaged away, not aliased into the 100 Hz samples
    np.testing.assert_allclose(wrench_out.values, wrench(t, vibration=False), atol=5e-4)
    np.testing.assert_allclose(twist_out.values, twist(t), atol=2e-4)
    assert pose_out is not None
    np.testing.assert_allclose(pose_out.values, pose(t), atol=1e-4)
    assert metadata.spec is None and metadata.outcome is Outcome.UNKNOWN
    assert metadata.task is Task.GOWN
    streams = metadata.source["streams"]
    assert streams["wrench"]["topic"] == "/ft_sensor/wrench"
    assert streams["wrench"]["rate_hz"] == 1000.0
    assert streams["pose"]["rate_hz"] == 50.0
    assert "differentiated from pose" in metadata.source["processing"]["twist"]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_a_bag_decoded_in_blocks_as_it_is_read_gives_the_same_trial(
    bags: dict[str, Path], tmp_path: Path, layout: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A long log's topics are decoded `BLOCK` messages at a time while the bag is read,
    not held whole as payloads (30 minutes at 1 kHz peaked at 0.75-0.97 GB so): blocks
    of 7 messages, the last one short, give the trial one block gives, messages out of
    order in the bag (the ROS 1 fast path sorts them at the end) too."""
    topics = standard_topics(1.0)
    kind, stamps, values = topics["/ft_sensor/wrench"]
    order = np.arange(len(stamps))
    order[[500, 501]] = order[[501, 500]]
    topics["/ft_sensor/wrench"] = (kind, stamps[order], values[order])
    (tmp_path / "messy").mkdir()
    messy = make_bag(tmp_path / "messy", topics, layout)
    for bag in (bags[layout], messy):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConversionWarning)  # the messy bag's, both ways
            whole = convert(bag, tmp_path / "whole.mcap", "gown", overwrite=True)
            with monkeypatch.context() as patched:
                patched.setattr(rosbag, "BLOCK", 7)
                blocks = convert(bag, tmp_path / "blocks.mcap", "gown", overwrite=True)
        assert blocks.steps == whole.steps and blocks.source == whole.source
        got, want = read_trial(tmp_path / "blocks.mcap"), read_trial(tmp_path / "whole.mcap")
        for name in ("wrench", "twist", "pose"):
            np.testing.assert_array_equal(getattr(got, name).t_ns, getattr(want, name).t_ns)
            np.testing.assert_array_equal(getattr(got, name).values, getattr(want, name).values)


def test_a_jittery_clock_and_a_noisy_fast_pose_are_averaged_not_aliased(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    tw = times(1000, 3.0) + rng.integers(-2000, 2001, 3000)  # +-2 us of driver jitter
    tp = times(1000, 3.0, 0.0004)
    noisy = pose(seconds_of(tp))
    noisy[:, :3] += rng.normal(0.0, 2e-4, (len(tp), 3))  # 0.2 mm of position noise
    topics = {
        "/ft_sensor/wrench": ("wrench", tw, wrench(seconds_of(tw))),
        "/arm/ee_pose": ("pose", tp, noisy),
    }
    out = tmp_path / "trial.mcap"
    report = convert(write_bag(tmp_path / "log", topics, "mcap"), out, "gown")
    with TrialReader(out) as reader:
        got, vel = reader.wrench.values, reader.twist.values
        t = seconds_of(reader.wrench.t_ns + report.source["start_ns"])
    # a 10 ms bin edge on a sample would let jitter move it across and the 200 Hz leak in
    np.testing.assert_allclose(got, wrench(t, vibration=False), atol=1e-3)
    # differences of a noisy 1 kHz pose are averaged over each bin, not picked
    assert np.abs(vel[:, :3] - twist(t)[:, :3]).std() < 0.03
    assert report.source["processing"]["twist"].endswith("mean over 10 ms bins")


def test_info_describes_a_converted_trial(bags: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "trial.mcap"
    convert(bags["ros1"], out, "shorts")
    summary = summarize(out)
    assert summary.task == "shorts" and summary.rate_hz == 100.0
    assert not summary.has_ground_truth
    assert summary.metadata.source["format"] == "ros1"
    lines = format_summary(summary).splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("  source "))
    assert lines[at] == f"  source    ros1 {bags['ros1'].resolve()}"
    streams = {line.split()[0]: line for line in lines[at + 1 : at + 4]}
    assert set(streams) == {"wrench", "twist", "pose"}
    assert "geometry_msgs/WrenchStamped" not in streams["wrench"]  # topic, rate, how resampled
    assert " Hz (/" in streams["wrench"] and streams["pose"].endswith("quaternions normalised")
    assert streams["twist"].split(None, 1)[1].startswith("differentiated from pose")


def test_tare_and_rotation_are_applied_and_recorded(bags: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "trial.mcap"
    quarter_turn_z = (0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))
    # the analytic log moves from its first step, so a tare takes in its motion: said
    with pytest.warns(ConversionWarning, match="the gripper moves from the first step"):
        report = convert(bags["sqlite3"], out, "gown", tare_s=0.5, rotate=quarter_turn_z)
    with TrialReader(out) as reader:
        got, vel = reader.wrench.values, reader.twist.values
        t = seconds_of(reader.wrench.t_ns + report.source["start_ns"])
        first = reader.wrench.t_ns < 500_000_000  # in integer ns, as the tare counts
    expected = wrench(t, vibration=False)
    expected -= expected[first].mean(axis=0)
    rotated = expected.copy()  # a quarter turn about z: (x, y) -> (-y, x)
    rotated[:, [0, 3]], rotated[:, [1, 4]] = -expected[:, [1, 4]], expected[:, [0, 3]]
    np.testing.assert_allclose(got, rotated, atol=5e-4)
    np.testing.assert_allclose(vel[:, 0], -twist(t)[:, 1], atol=2e-4)
    assert report.source["processing"]["tare_s"] == 0.5
    assert report.source["processing"]["rotation_xyzw"][3] == pytest.approx(np.cos(np.pi / 4))


@pytest.mark.filterwarnings("ignore:the wrench is in frame 'ft', as the motion is")
@pytest.mark.parametrize("scale", [1e300, 1e-300])
@pytest.mark.parametrize("option", ["rotate", "sensor_rotation"])
def test_a_rotation_quaternion_turns_the_same_at_any_scale(
    bags: dict[str, Path], tmp_path: Path, option: str, scale: float
) -> None:
    """A quaternion is normalised, so (0 0 1e300 1e300) is a quarter turn about z; its norm
    overflowed to inf, which made --rotate's poses nan (an error naming the output) and
    --sensor-rotation no turn at all (a trial converted as though it were not given), and
    (0 0 1e-300 1e-300)'s underflowed to 0, refused as the all-zero quaternion."""
    quarter_turn_z = np.array([0.0, 0.0, 1.0, 1.0])
    frame = {"wrench_frame": "pose"} if option == "sensor_rotation" else {}
    unit, huge = tmp_path / "unit.mcap", tmp_path / "huge.mcap"
    convert(bags["sqlite3"], unit, "gown", **frame, **{option: tuple(quarter_turn_z)})
    convert(bags["sqlite3"], huge, "gown", **frame, **{option: tuple(quarter_turn_z * scale)})
    got, want = read_trial(huge), read_trial(unit)
    np.testing.assert_allclose(got.wrench.values, want.wrench.values, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got.pose.values, want.pose.values, rtol=1e-12, atol=1e-12)


def test_a_dresslog_trial_exported_as_a_ros2_bag_converts_back_unchanged(tmp_path: Path) -> None:
    from rosbags.rosbag2 import Writer

    from tests.convert.signals import typestore

    t_ns = np.arange(400, dtype=np.int64) * 10_000_000  # 4 s at 100 Hz, as the simulator records
    t = t_ns / 1e9
    original = tmp_path / "sim.mcap"
    metadata = TrialMetadata(task=Task.GOWN)
    with TrialWriter(original, metadata) as writer:
        writer.write_wrench(t_ns, wrench(t, vibration=False))
        writer.write_twist(t_ns, twist(t))
        writer.write_pose(t_ns, pose(t))
    bag = tmp_path / "exported"
    with TrialReader(original) as reader, Writer(bag, version=9) as out:
        for topic in (wk.WRENCH, wk.TWIST, wk.POSE):
            connection = out.add_connection(topic, wk.SCHEMAS[topic], typestore=typestore(False))
            for message in reader.messages(topic):  # on the trial's clock, from 0
                out.write(connection, message.t_ns + 5_000_000_000, message.data)  # logged later
        before = reader.measurements
    back = tmp_path / "back.mcap"
    report = convert(bag, back, "gown")
    with TrialReader(back) as reader:
        after = reader.measurements
    # the trial's first stamp is its time origin, and it is still the header clock that counts
    assert report.source["start_ns"] == wk.TIME_ORIGIN_NS and "notes" not in report.source
    assert {s["clock"] for s in report.source["streams"].values()} == {"header"}
    np.testing.assert_array_equal(after.t_ns, before.t_ns)
    np.testing.assert_allclose(after.phi, before.phi, atol=1e-6)


def test_a_bag_with_unset_header_stamps_converts_on_its_log_times(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "log.bag", topics := standard_topics(), "ros1", unstamped=topics)
    out = tmp_path / "trial.mcap"
    report = convert(bag, out, "gown")
    with TrialReader(out) as reader:
        got = reader.wrench
    # the log times are the true times here, so the signal lands where it belongs
    t = seconds_of(got.t_ns + report.source["start_ns"])
    np.testing.assert_allclose(got.values, wrench(t, vibration=False), atol=5e-4)
    assert {s["clock"] for s in report.source["streams"].values()} == {"log"}
    assert (
        "/ft_sensor/wrench: header stamps unset, used the bag's log times"
        in (report.source["notes"])
    )


def test_a_stream_falling_back_to_log_times_is_warned_about(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "log.bag", standard_topics(), "ros1", unstamped=["/arm/ee_pose"])
    with pytest.warns(ConversionWarning, match=r"streams on different clocks \(/ft_sensor/wrench"):
        convert(bag, tmp_path / "t.mcap", "gown")


# -- the pose from tf ----------------------------------------------------------------------

WORLD_WRENCH, BASE_WRENCH = {"/ft_sensor/wrench": "world"}, {"/ft_sensor/wrench": "base"}


@pytest.mark.parametrize("layout", ["ros1", "mcap"])
@pytest.mark.parametrize("parent", ["base", "world"])
def test_a_bag_with_tf_instead_of_a_pose_topic_converts_to_the_tools_analytic_motion(
    tmp_path: Path, layout: str, parent: str
) -> None:
    """world -> base (static) -> link1 (100 Hz /tf) -> tool (static): the tool's pose in
    PARENT, and its velocity by differentiation, as a PoseStamped topic of it would give."""
    bag = make_bag(tmp_path, tf_topics(), layout, frames={"/ft_sensor/wrench": parent})
    out = tmp_path / "trial.mcap"
    report = convert(bag, out, "gown", pose_tf=f"{parent}:tool")
    with TrialReader(out) as reader:
        wrench_out, twist_out, pose_out = reader.wrench, reader.twist, reader.pose
    assert len(wrench_out) == report.steps > 290
    t = seconds_of(wrench_out.t_ns + report.source["start_ns"])
    want_pose = pose(t) if parent == "base" else tool_in_world(t)
    want_twist = twist(t) if parent == "base" else tool_twist_in_world(t)
    np.testing.assert_allclose(wrench_out.values, wrench(t, vibration=False), atol=5e-4)
    assert pose_out is not None
    np.testing.assert_allclose(pose_out.values, want_pose, atol=1e-4)
    np.testing.assert_allclose(twist_out.values, want_twist, atol=2e-4)
    stream = report.source["streams"]["pose"]
    assert stream["topic"] == f"/tf {parent}->tool" and stream["rate_hz"] == 100.0
    assert stream["type"] == "tf2_msgs/msg/TFMessage" and stream["frame_id"] == parent
    assert "differentiated from pose" in report.source["processing"]["twist"]
    lines = format_summary(summarize(out)).splitlines()
    # every message read counts: 3,000 wrenches, 300 /tf and 1 /tf_static (its 3 transforms)
    assert report.messages_in == 3301
    assert any(line.startswith(f"    pose    301 messages at 100 Hz (/tf {parent}->tool, header")
               for line in lines), lines  # fmt: skip


def test_a_tf_link_at_another_rate_is_interpolated_at_the_fastest_ones_stamps(
    tmp_path: Path,
) -> None:
    bag = make_bag(tmp_path, tf_topics(base_on_tf_hz=25.0), "sqlite3", frames=WORLD_WRENCH)
    # ROS 1's tf named frames with a leading slash, tf2 without: either finds them
    report = convert(bag, tmp_path / "t.mcap", "gown", pose_tf="/world:tool")
    got = read_trial(tmp_path / "t.mcap")
    t = seconds_of(got.pose.t_ns + report.source["start_ns"])
    np.testing.assert_allclose(got.pose.values, tool_in_world(t), atol=1e-4)
    assert report.source["streams"]["pose"]["rate_hz"] == 100.0


def test_the_pose_from_tf_honours_the_bags_receive_times(tmp_path: Path) -> None:
    topics = tf_topics(2.0)
    lead = {"/tf": 300_000_000}
    bag = write_bag(tmp_path / "log", topics, "mcap", stamp_lead_ns=lead, frames=BASE_WRENCH)
    report = convert(bag, tmp_path / "t.mcap", "gown", pose_tf="base:tool", clock="log")
    got = read_trial(tmp_path / "t.mcap")
    assert report.source["streams"]["pose"]["clock"] == "log"
    t = seconds_of(got.pose.t_ns + report.source["start_ns"])
    np.testing.assert_allclose(got.pose.values, pose(t), atol=1e-4)


@pytest.mark.parametrize("layout", ["ros1", "mcap"])
def test_tf_with_unset_header_stamps_is_timed_by_the_bags_log_times(
    tmp_path: Path, layout: str
) -> None:
    """A driver that leaves its TransformStamped stamps 0: the moving links in the chain fall
    back to the bag's log times, as any other topic does, and say so; static ones need none."""
    trials = []
    for unstamped in ((), ("/ft_sensor/wrench", "/tf", "/tf_static")):
        (folder := tmp_path / ("unset" if unstamped else "set")).mkdir()
        bag = make_bag(folder, tf_topics(), layout, unstamped=unstamped, frames=BASE_WRENCH)
        report = convert(bag, folder / "t.mcap", "gown", pose_tf="base:tool")
        trials.append(read_trial(folder / "t.mcap"))
    # the log times are the stamps here: the trial is the stamped bag's
    stamped, unset = trials
    for kind in ("wrench", "twist", "pose"):
        before, after = getattr(stamped, kind), getattr(unset, kind)
        np.testing.assert_array_equal(after.t_ns, before.t_ns)
        np.testing.assert_array_equal(after.values, before.values)
    assert report.source["streams"]["pose"]["clock"] == "log"
    # a note for each topic and moving link of the chain: not base->elbow, nor static links
    assert report.source["notes"] == [
        "/tf base->link1: header stamps unset, used the bag's log times",
        "/ft_sensor/wrench: header stamps unset, used the bag's log times",
    ]
    lines = format_summary(summarize(folder / "t.mcap")).splitlines()
    assert "    note    /tf base->link1: header stamps unset, used the bag's log times" in lines


@pytest.mark.parametrize(
    ("pose_tf", "match"),
    [
        ("base/tool", r"--pose-tf 'base/tool': give PARENT:CHILD, .* e\.g\. base_link:tool0$"),
        ("base:gripper", r"frame gripper is not in the bag's tf tree \(frames: base, camera, "
                         r"elbow, link1, tool, world\)$"),
        ("camera:tool", r"camera is not above tool in the tf tree: tool's chain reaches the "
                        r"root world;"),
        ("link1:tool", r"every transform from tool up to link1 is static, so the pose never "
                       "moves"),
    ],
)  # fmt: skip
def test_a_pose_tf_the_tree_cannot_give_is_refused_in_one_line(
    tmp_path: Path, pose_tf: str, match: str
) -> None:
    bad(tmp_path, tf_topics(1.0), match, layout="mcap", pose_tf=pose_tf)


@pytest.mark.parametrize(
    ("extra", "pose_tf", "match"),
    [
        ([("world", "link1")], "world:tool", r"frame link1 has 2 parents in tf \(base, world\)"),
        ([("x", "y"), ("y", "x")], "world:x", "the tf tree loops at x"),
    ],
)  # fmt: skip
def test_a_tf_tree_that_is_no_tree_is_refused_in_one_line(
    tmp_path: Path, extra: list[tuple[str, str]], pose_tf: str, match: str
) -> None:
    topics = tf_topics(1.0)
    kind, stamps, (static,) = topics["/tf_static"]
    unturned = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    topics["/tf_static"] = (kind, stamps, [static + [(*edge, unturned) for edge in extra]])
    bad(tmp_path, topics, match, layout="sqlite3", pose_tf=pose_tf)


def test_a_pose_tf_needs_a_bag_with_tf_and_no_pose_topic_beside_it(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    bad(tmp_path / "a", standard_topics(1.0), r"--pose-tf: no /tf in the bag \(no tf2_msgs/msg/"
        r"TFMessage topic with messages; topics: /arm/ee_pose", pose_tf="base:tool")  # fmt: skip
    bad(tmp_path / "b", tf_topics(1.0), "--pose-tf and --pose-topic both give the pose",
        pose_tf="base:tool", pose_topic="/arm/ee_pose")  # fmt: skip
    bag = make_bag(tmp_path, tf_topics(1.0), "ros1", frames=BASE_WRENCH)
    args = ["convert", str(bag), "-o", str(tmp_path / "t.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, [*args, "--pose-tf", "base:tool", "--pose-topic", "/x"])
    assert result.exit_code == 2 and "--pose-tf and --pose-topic both give the pose" in (
        result.output
    )
    (tmp_path / "x.csv").write_text("t,fx,fy,fz,tx,ty,tz,vx,vy,vz\n")
    args[1] = str(tmp_path / "x.csv")
    result = CliRunner().invoke(main, [*args, "--pose-tf", "base:tool"])
    assert result.exit_code == 1 and "--pose-tf: applies to bags, not to a CSV" in result.output
    result = CliRunner().invoke(main, [*args[:1], str(bag), *args[2:], "--pose-tf", "base:tool"])
    assert result.exit_code == 0, result.output


# -- bad input -----------------------------------------------------------------------------


def bad(tmp_path: Path, topics, match: str, layout: str = "ros1", **options) -> None:
    """Converting `topics` fails with a ConversionError matching `match`; nothing is written."""
    bag = make_bag(tmp_path, topics, layout)
    out = tmp_path / "out.mcap"
    with pytest.raises(ConversionError, match=match):
        convert(bag, out, "gown", **options)
    assert not out.exists() and no_partials(tmp_path)


def test_an_empty_bag_is_refused(tmp_path: Path) -> None:
    bad(tmp_path, {}, "no messages")


def test_a_bag_without_a_wrench_names_the_topics_it_has(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    del topics["/ft_sensor/wrench"]
    bad(tmp_path, topics, r"no WrenchStamped topic .*/arm/ee_pose \(PoseStamped\)")


def test_a_bag_without_velocity_or_pose_is_refused(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    del topics["/arm/ee_pose"]
    bad(tmp_path, topics, "no TwistStamped or PoseStamped topic", layout="sqlite3")
    # a bag whose pose is in its tf tree is told how to take it from there
    bad(tmp_path, tf_topics(1.0), r"force, torque and velocity; the bag has /tf: give the "
        r"gripper's frame as --pose-tf PARENT:CHILD$")  # fmt: skip


def test_two_wrench_topics_need_a_choice(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    topics["/ft_raw"] = topics["/ft_sensor/wrench"]
    bad(tmp_path, topics, r"2 WrenchStamped topics \(/ft_raw, /ft_sensor/wrench\).*--wrench-topic")
    report = convert(tmp_path / "log.bag", tmp_path / "ok.mcap", "gown", wrench_topic="/ft_raw")
    assert report.source["streams"]["wrench"]["topic"] == "/ft_raw"
    kind, stamps, values = topics["/ft_raw"]
    topics["/ft_raw"] = (kind, stamps[:0], values[:0])  # advertised, never published: no rival
    for layout, name in (("ros1", "empty.bag"), ("sqlite3", "empty")):
        bag = write_bag(tmp_path / name, topics, layout)
        report = convert(bag, tmp_path / f"{layout}.mcap", "gown")
        assert report.source["streams"]["wrench"]["topic"] == "/ft_sensor/wrench"


def test_a_topic_of_the_wrong_type_is_refused(tmp_path: Path) -> None:
    bad(tmp_path, standard_topics(1.0), "is std_msgs/msg/String", wrench_topic="/rosout_text")


def test_messages_out_of_order_or_logged_twice_are_sorted_and_dropped_with_a_warning(
    tmp_path: Path,
) -> None:
    """A transport's reordering and a message logged twice give the trial of the clean log."""
    topics = standard_topics(1.0)
    clean = convert(make_bag(tmp_path / "clean", topics, "mcap"), tmp_path / "clean.mcap", "gown")
    kind, stamps, values = topics["/ft_sensor/wrench"]
    order = np.arange(len(stamps))
    order[[500, 501]], order[[700, 702]] = order[[501, 500]], order[[702, 700]]
    order = np.insert(order, 300, 299)  # message 299 twice
    topics["/ft_sensor/wrench"] = (kind, stamps[order], values[order])
    bag = make_bag(tmp_path / "messy", topics, "mcap")
    with pytest.warns(ConversionWarning, match=r"of 1001 samples, 3 stamped before one logged "
                      r"earlier, sorted and 1 logged twice, dropped"):  # fmt: skip
        report = convert(bag, tmp_path / "messy.mcap", "gown")
    assert report.warnings[0].startswith("/ft_sensor/wrench: of 1001 samples")
    got, want = read_trial(tmp_path / "messy.mcap"), read_trial(tmp_path / "clean.mcap")
    np.testing.assert_array_equal(got.wrench.values, want.wrench.values)
    assert clean.steps == report.steps


def test_sensors_on_their_own_clocks_are_named_and_convert_on_receive_times(
    tmp_path: Path,
) -> None:
    """Header stamps 0.3 s ahead on one topic: by stamp the streams are shifted, a warning
    says so, and --clock log aligns them as they arrived, as the clean log does."""
    topics = standard_topics(2.0)
    clean = make_bag(tmp_path / "clean", topics, "mcap")
    skewed = write_bag(
        tmp_path / "skewed", topics, "mcap", stamp_lead_ns={"/arm/ee_pose": 300_000_000}
    )
    with pytest.warns(ConversionWarning) as caught:  # and the 0.3 s the shift cuts off
        convert(skewed, tmp_path / "by_stamp.mcap", "gown")
    assert any(re.search(r"/arm/ee_pose \+0\.300 s.*--clock log", str(w.message)) for w in caught)
    convert(clean, tmp_path / "clean.mcap", "gown")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # receive times agree: nothing to warn about
        report = convert(skewed, tmp_path / "by_log.mcap", "gown", clock="log")
    assert report.source["streams"]["pose"]["clock"] == "log"
    kind, stamps, values = topics["/arm/ee_pose"]
    order = np.arange(len(stamps))
    order[[5, 7]] = order[[7, 5]]  # two poses arrive swapped
    topics["/arm/ee_pose"] = (kind, stamps[order], values[order])
    swapped = make_bag(tmp_path / "swapped", topics, "mcap")
    report = convert(swapped, tmp_path / "swapped.mcap", "gown", clock="log")
    assert any("2 message(s) arrived before one stamped earlier" in n
               for n in report.source["notes"])  # fmt: skip
    got, want = read_trial(tmp_path / "by_log.mcap"), read_trial(tmp_path / "clean.mcap")
    np.testing.assert_allclose(got.twist.values, want.twist.values, atol=1e-9)


def test_clock_log_applies_to_bags_only(tmp_path: Path) -> None:
    (tmp_path / "x.csv").write_text("t,fx,fy,fz,tx,ty,tz,vx,vy,vz\n")
    code = CliRunner().invoke(
        main, ["convert", str(tmp_path / "x.csv"), "-o", str(tmp_path / "t.mcap"),
               "--task", "gown", "--clock", "log"],
    )  # fmt: skip
    assert code.exit_code == 1 and "--clock log: applies to bags, not to a CSV" in code.output


def test_a_wrench_in_the_grippers_axes_is_turned_into_world_axes_by_the_pose(
    tmp_path: Path,
) -> None:
    """A wrist sensor turns with the gripper (here yawing 0.3 rad/s): --wrench-frame pose
    gives the trial of the same wrench logged in world axes; without it, a warning."""
    topics = standard_topics(2.0)
    world = convert(make_bag(tmp_path / "w", topics, "mcap"), tmp_path / "world.mcap", "gown")
    kind, stamps, values = topics["/ft_sensor/wrench"]
    yaw = YAW_RATE * seconds_of(stamps)  # the pose's orientation at each wrench sample
    c, s = np.cos(yaw), np.sin(yaw)
    local = values.copy()
    for k in (0, 3):  # R(yaw)^T v: world axes into the gripper's
        x, y = values[:, k], values[:, k + 1]
        local[:, k], local[:, k + 1] = c * x + s * y, -s * x + c * y
    topics["/ft_sensor/wrench"] = (kind, stamps, local)
    frames = {"/ft_sensor/wrench": "ft_sensor_link", "/arm/ee_pose": "base_link"}
    bag = write_bag(tmp_path / "g", topics, "mcap", frames=frames)
    with pytest.warns(ConversionWarning, match=r"'ft_sensor_link', the motion in 'base_link'"):
        convert(bag, tmp_path / "as_is.mcap", "gown")
    report = convert(bag, tmp_path / "turned.mcap", "gown", wrench_frame="pose")
    assert not report.warnings and report.steps == world.steps
    got, want = read_trial(tmp_path / "turned.mcap"), read_trial(tmp_path / "world.mcap")
    np.testing.assert_allclose(got.wrench.values, want.wrench.values, atol=0.02)
    assert (
        np.abs(read_trial(tmp_path / "as_is.mcap").wrench.values - want.wrench.values).max() > 0.5
    )
    mounted = local.copy()  # a sensor turned 90 deg about z on the gripper: R_mount^T v
    for k in (0, 3):
        mounted[:, k], mounted[:, k + 1] = local[:, k + 1], -local[:, k]
    topics["/ft_sensor/wrench"] = (kind, stamps, mounted)
    bag = write_bag(tmp_path / "m", topics, "mcap", frames=frames)
    mount = (0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))
    convert(bag, tmp_path / "mounted.mcap", "gown", wrench_frame="pose", sensor_rotation=mount)
    got = read_trial(tmp_path / "mounted.mcap")
    np.testing.assert_allclose(got.wrench.values, want.wrench.values, atol=0.02)
    with pytest.raises(ConversionError, match="--sensor-rotation places a sensor on the"):
        convert(bag, tmp_path / "no.mcap", "gown", sensor_rotation=mount)
    offset = np.array([0.0, 0.02, 0.05])  # the sensor's origin 5 cm above the gripper centre
    at_sensor = local.copy()  # torque about the sensor's origin: tau_C - r x F
    at_sensor[:, 3:] = local[:, 3:] - np.cross(offset, local[:, :3])
    topics["/ft_sensor/wrench"] = (kind, stamps, at_sensor)
    bag = write_bag(tmp_path / "o", topics, "mcap", frames=frames)
    convert(bag, tmp_path / "offset.mcap", "gown", wrench_frame="pose", sensor_offset=offset)
    got = read_trial(tmp_path / "offset.mcap")
    np.testing.assert_allclose(got.wrench.values, want.wrench.values, atol=0.02)


#: tool -> ft (static): a sensor 4 cm behind the tool centre and 3 cm aside, turned 90 deg
#: about the tool's z, as a flange-mounted sensor's frame hangs off the tool frame
SENSOR_IN_TOOL = (0.03, 0.0, -0.04, 0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))


@pytest.mark.parametrize("layout", ["ros1", "mcap"])
def test_a_sensor_frame_the_tf_tree_fixes_on_the_gripper_places_the_wrench(
    tmp_path: Path, layout: str
) -> None:
    """--pose-tf base:tool --wrench-frame pose, the wrench stamped in frame `ft`, which
    /tf_static fixes on `tool`: its axes and origin come from the tree, as
    --sensor-rotation and --sensor-offset would give them (which still win), and the
    trial is the one of the same wrench logged in the tool's own frame."""
    topics = tf_topics(2.0)
    kind, stamps, at_tool = topics["/ft_sensor/wrench"]
    for folder in ("t", "m"):
        (tmp_path / folder).mkdir()
    tool = make_bag(tmp_path / "t", topics, layout, frames={"/ft_sensor/wrench": "tool"})
    options = {"pose_tf": "base:tool", "wrench_frame": "pose"}
    plain = convert(tool, tmp_path / "tool.mcap", "gown", **options)
    position, turn = np.asarray(SENSOR_IN_TOOL[:3]), np.asarray(SENSOR_IN_TOOL[3:])
    back = turn * np.array([-1.0, -1.0, -1.0, 1.0])
    at_sensor = np.concatenate(  # in the sensor's axes, the torque about its origin
        [quat_rotate(back, at_tool[:, :3]),
         quat_rotate(back, at_tool[:, 3:] - np.cross(position, at_tool[:, :3]))], axis=1,
    )  # fmt: skip
    _, latched, [fixed] = topics["/tf_static"]
    topics["/tf_static"] = ("tf", latched, [[*fixed, ("tool", "ft", SENSOR_IN_TOOL)]])
    topics["/ft_sensor/wrench"] = (kind, stamps, at_sensor)
    mounted = make_bag(tmp_path / "m", topics, layout)  # frame `ft`
    report = convert(mounted, tmp_path / "mounted.mcap", "gown", **options)
    want = read_trial(tmp_path / "tool.mcap").wrench.values
    np.testing.assert_allclose(read_trial(tmp_path / "mounted.mcap").wrench.values, want,
                               atol=1e-9)  # fmt: skip
    assert report.steps == plain.steps
    assert report.source["notes"][-1] == (
        "the wrench's frame ft is fixed on tool in the tf tree, at (+0.03, +0, -0.04) m "
        "turned (+0, +0, +0.7071, +0.7071): taken as --sensor-offset and --sensor-rotation"
    )
    given = convert(mounted, tmp_path / "given.mcap", "gown", **options,
                    sensor_offset=(0.0, 0.0, 0.0))  # fmt: skip
    assert not any("tf tree" in note for note in given.source.get("notes", []))
    assert np.abs(read_trial(tmp_path / "given.mcap").wrench.values - want).max() > 0.1


def test_a_sensor_above_the_tool_or_beside_it_is_placed_by_the_fixed_links_between() -> None:
    """The sensor's frame may hang below the tool's (as above), above it (flange -> ft ->
    tool) or beside it (flange -> ft, flange -> tool): its place in the tool's frame is
    the fixed links' between; a moving link between them, a frame not in the tree, or
    the tool's own frame gives none."""
    from dresslog.convert.tf import Edge, sensor_mount

    def placed(edges: dict[str, list[Edge]], frame: str) -> list[float] | None:
        mount = sensor_mount(edges, "tool", frame)
        return None if mount is None else [*mount.offset, *mount.rotation]

    def edge(parent: str, child: str, pose, static: bool = True) -> Edge:
        one = np.asarray([pose], dtype=float)
        return Edge(parent, child, static, np.zeros(1, np.int64), np.zeros(1, np.int64), one)

    quarter = (0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))  # 90 deg about z
    tool_in_ft = (0.0, 0.1, 0.0, *quarter)
    above = {"ft": [edge("flange", "ft", (0, 0, 0.02, 0, 0, 0, 1))],
             "tool": [edge("ft", "tool", tool_in_ft)]}  # fmt: skip
    # ft in tool, the inverse of tool in ft: 10 cm back along the tool's x (ft's y), and
    # turned back the quarter
    np.testing.assert_allclose(placed(above, "ft"),
                               [-0.1, 0, 0, 0, 0, -quarter[2], quarter[3]], atol=1e-12)  # fmt: skip
    beside = {"ft": [edge("flange", "ft", (0, 0, 0.02, 0, 0, 0, 1))],
              "tool": [edge("flange", "tool", (0, 0, 0.12, 0, 0, 0, 1))]}  # fmt: skip
    np.testing.assert_allclose(placed(beside, "ft"), [0, 0, -0.1, 0, 0, 0, 1],
                               atol=1e-12)  # fmt: skip
    beside["tool"] = [edge("flange", "tool", (0, 0, 0.12, 0, 0, 0, 1), static=False)]
    assert placed(beside, "ft") is None
    assert placed(above, "camera") is None
    assert placed(above, "tool") is None  # the tool's own frame: no mount at all


def test_naming_the_pose_topic_keeps_the_measured_twist(tmp_path: Path) -> None:
    """--pose-topic picks the orientation; the velocity still comes from the twist."""
    topics = standard_topics(1.0)
    stamps = topics["/arm/ee_pose"][1]
    topics["/arm/twist"] = ("twist", stamps, 2 * twist(seconds_of(stamps)))  # tells them apart
    report = convert(make_bag(tmp_path, topics, "mcap"), tmp_path / "t.mcap", "gown",
                     pose_topic="/arm/ee_pose")  # fmt: skip
    assert report.source["processing"]["twist"] == "linear interpolation"
    trial = read_trial(tmp_path / "t.mcap")
    t = seconds_of(trial.twist.t_ns + report.source["start_ns"])
    np.testing.assert_allclose(trial.twist.values, 2 * twist(t), atol=1e-3)


def test_a_wrench_frame_of_pose_needs_an_orientation(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    stamps = topics.pop("/arm/ee_pose")[1]
    topics["/arm/ee_twist"] = ("twist", stamps, twist(seconds_of(stamps)))
    bad(tmp_path, topics, "--wrench-frame pose turns the wrench by the gripper's orientation",
        wrench_frame="pose")  # fmt: skip


def test_a_zero_quaternion_is_refused_not_read_as_no_rotation(tmp_path: Path) -> None:
    """ROS 1's unset orientation: normalised it would be the identity, silently."""
    topics = standard_topics(1.0)
    kind, stamps, values = topics["/arm/ee_pose"]
    values = values.copy()
    values[20:25, 3:] = 0.0
    topics["/arm/ee_pose"] = (kind, stamps, values)
    bad(tmp_path, topics, r"/arm/ee_pose: pose orientation is the zero quaternion at 5 of 50 "
        r"samples \(first: sample 20\)")  # fmt: skip


def test_an_unset_pose_beside_a_twist_is_left_out_with_a_warning(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    kind, stamps, values = topics["/arm/ee_pose"]
    topics["/arm/ee_pose"] = (kind, stamps, np.concatenate([values[:, :3], 0 * values[:, 3:]], 1))
    topics["/arm/twist"] = ("twist", stamps, twist(seconds_of(stamps)))
    with pytest.warns(ConversionWarning, match="orientation unset.*velocity comes from /arm/twist"):
        convert(make_bag(tmp_path, topics, "mcap"), tmp_path / "t.mcap", "gown")
    assert read_trial(tmp_path / "t.mcap").pose is None


def test_turning_a_wrench_already_in_the_motions_frame_is_warned_about(tmp_path: Path) -> None:
    frames = {"/ft_sensor/wrench": "/base_link", "/arm/ee_pose": "base_link"}
    bag = write_bag(tmp_path / "b.bag", standard_topics(1.0), "ros1", frames=frames)
    with pytest.warns(ConversionWarning, match="as the motion is.*turns the wrench a second"):
        convert(bag, tmp_path / "t.mcap", "gown", wrench_frame="pose")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # same frame, left as is: nothing to say
        convert(bag, tmp_path / "u.mcap", "gown")


def test_a_stamp_repeated_with_other_values_is_refused(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    kind, stamps, values = topics["/ft_sensor/wrench"]
    stamps = stamps.copy()
    stamps[501] = stamps[500]  # a driver stamping a batch of two with one time
    topics["/ft_sensor/wrench"] = (kind, stamps, values)
    bad(tmp_path, topics, r"samples 500 and 501 of 1000 share the stamp \d+ ns \(header clock\) "
        "with other values: a driver stamping a batch", layout="mcap")  # fmt: skip


def test_a_clock_that_jumps_back_is_refused_not_sorted_into_the_rest(tmp_path: Path) -> None:
    """Two publishers' seconds apart, or a clock reset: sorting would interleave them."""
    topics = standard_topics(2.0)
    kind, stamps, values = topics["/ft_sensor/wrench"]
    stamps = stamps.copy()
    stamps[1500:] -= 1_000_000_000  # back by 1 s halfway
    topics["/ft_sensor/wrench"] = (kind, stamps, values)
    bad(tmp_path, topics, r"time goes back 0.999 s at sample 1500 of 2000 \(header clock\): "
        "a clock reset", layout="mcap")  # fmt: skip


def test_a_gap_longer_than_100_ms_is_named_in_a_warning(tmp_path: Path) -> None:
    topics = standard_topics(2.0)
    kind, stamps, values = topics["/ft_sensor/wrench"]
    keep = (stamps < stamps[0] + 800_000_000) | (stamps >= stamps[0] + 1_100_000_000)
    topics["/ft_sensor/wrench"] = (kind, stamps[keep], values[keep])
    bag = make_bag(tmp_path, topics, "ros1")
    with pytest.warns(ConversionWarning, match=r"gap of 0\.301 s in /ft_sensor/wrench"):
        report = convert(bag, tmp_path / "out.mcap", "gown")
    assert report.warnings and report.source["warnings"] == report.warnings


def test_without_rosbags_the_error_says_how_to_install_it(
    bags: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "rosbags", None)
    with pytest.raises(ConversionError, match=r"pip install 'dresslog\[ros\]'"):
        convert(bags["ros1"], tmp_path / "out.mcap", "gown")


def test_inputs_that_are_not_logs_are_refused(tmp_path: Path) -> None:
    (tmp_path / "folder").mkdir()
    (tmp_path / "notes.pdf").write_bytes(b"%PDF")
    for path, match in [
        (tmp_path / "missing.bag", "no such file"),
        (tmp_path / "folder", "no metadata.yaml"),
        (tmp_path / "notes.pdf", "unknown input"),
    ]:
        with pytest.raises(ConversionError, match=match):
            convert(path, tmp_path / "out.mcap", "gown")


def test_a_truncated_bag_is_refused_with_the_tool_that_may_repair_it(
    bags: dict[str, Path], tmp_path: Path
) -> None:
    whole = bags["ros1"].read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(whole[: len(whole) // 2])
    with pytest.raises(ConversionError, match=r"cannot read bag: .*`rosbag reindex` may repair"):
        convert(cut, tmp_path / "out.mcap", "gown")
    assert not (tmp_path / "out.mcap").exists()
    bare = tmp_path / "cut.mcap"  # a ROS 2 MCAP file without its bag folder: not reindex's
    bare.write_bytes((SAMPLES / "gown.mcap").read_bytes()[:300_000])
    with pytest.raises(ConversionError, match=r"`mcap recover` may repair it"):
        convert(bare, tmp_path / "out.mcap", "gown")


def _foreign_mcap(path: Path, profile: str, schema: str, encoding: str) -> Path:
    """An MCAP file of another tool's, by mcap's own writer: a wrench topic of `profile`,
    its schema and messages in `schema` and `encoding`."""
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile=profile, library="another tool")
        sid = writer.register_schema("geometry_msgs/msg/WrenchStamped", schema, b"{}")
        cid = writer.register_channel("/ft", encoding, sid)
        for i in range(20):
            writer.add_message(cid, i * 10_000_000, b'{"force": [0, 0, 1]}', i * 10_000_000, i)
        writer.finish()
    return path


READS = "convert reads ROS 1 bags, ROS 2 bags (a folder, or an MCAP file of profile 'ros2' "


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("ros1", f"an MCAP file of profile 'ros1', not ROS 2's 'ros2'; {READS}"),
        ("no-profile", f"an MCAP file with no profile, not ROS 2's 'ros2'; {READS}"),
        ("json", f"MCAP channels not in ROS 2's CDR: /ft (json); {READS}"),
        ("json-schema", f"MCAP channels not in ROS 2's CDR: /ft (schema jsonschema); {READS}"),
        ("not-mcap", f"not an MCAP file (it does not begin as one); {READS}"),
        ("truncated", "MCAP file is truncated (no end record), as when its recording was cut "
                      "short; `mcap recover` may repair it"),
    ],
)  # fmt: skip
def test_an_mcap_file_convert_cannot_read_is_named_for_what_it_is(
    tmp_path: Path, kind: str, message: str
) -> None:
    """A foreign MCAP file was told "Profile is not ros2." with a truncated file's cure,
    `mcap recover`, and one of JSON schemas ended in rosbags' KeyError."""
    path = tmp_path / f"{kind}.mcap"
    if kind == "ros1":
        _foreign_mcap(path, "ros1", "ros1msg", "ros1")
    elif kind == "no-profile":
        _foreign_mcap(path, "", "jsonschema", "json")
    elif kind == "json":
        _foreign_mcap(path, "ros2", "jsonschema", "json")
    elif kind == "json-schema":
        _foreign_mcap(path, "ros2", "jsonschema", "cdr")
    elif kind == "not-mcap":
        path.write_text("time,fx,fy,fz\n0,1,2,3\n")
    else:
        whole = write_bag(tmp_path / "log", standard_topics(1.0), "mcap")
        path.write_bytes(next(whole.glob("*.mcap")).read_bytes()[:2000])
    args = ["convert", str(path), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert result.output.startswith(f"Error: {path}: {message}"), result.output
    assert len(result.output.splitlines()) == 1 and not (tmp_path / "out.mcap").exists()
    assert ("recover" in result.output) is (kind == "truncated")


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b"", "file is empty"),
        (b"time,fx,fy,fz\n0,1,2,3\n", "not a ROS 1 bag (it does not begin as one)"),
    ],
    ids=["empty", "text"],
)
def test_a_bag_file_that_is_no_ros1_bag_is_named_for_what_it_is(
    tmp_path: Path, content: bytes, problem: str
) -> None:
    """rosbags' "File magic is invalid." (or "seems to be empty.") came with the cure of a
    bag cut short, `rosbag reindex`, which mends a bag's end, not its start."""
    (path := tmp_path / "log.bag").write_bytes(content)
    args = ["convert", str(path), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert result.output.startswith(f"Error: {path}: {problem}; {READS}"), result.output
    assert len(result.output.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.bag"]


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("ros1", f"an MCAP file of profile 'ros1', not ROS 2's 'ros2'; {READS}"),
        ("json", f"MCAP channels not in ROS 2's CDR: /ft (json); {READS}"),
    ],
)
def test_a_ros2_bag_folder_whose_mcap_convert_cannot_read_names_that_file(
    tmp_path: Path, kind: str, message: str
) -> None:
    """The bare file was checked, not a bag folder's storage: another profile was "cannot
    read bag: Profile is not ros2." with `ros2 bag reindex` to repair it, JSON a KeyError."""
    bag = write_bag(tmp_path / "log", standard_topics(1.0), "mcap")
    (storage,) = bag.glob("*.mcap")  # rosbags' own, replaced: metadata.yaml still names it
    if kind == "ros1":
        _foreign_mcap(storage, "ros1", "ros1msg", "ros1")
    else:
        _foreign_mcap(storage, "ros2", "jsonschema", "json")
    args = ["convert", str(bag), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert result.output.startswith(f"Error: {storage}: {message}"), result.output
    assert len(result.output.splitlines()) == 1 and not (tmp_path / "out.mcap").exists()


def test_an_mcap_in_a_ros2_bag_folder_that_metadata_does_not_list_is_left_alone(
    tmp_path: Path,
) -> None:
    """rosbags reads the storage metadata.yaml lists, yet every MCAP in the folder was
    checked: another tool's export saved beside the bag made convert refuse the bag."""
    bag = write_bag(tmp_path / "log", standard_topics(1.0), "mcap")
    alone = convert(bag, tmp_path / "alone.mcap", "gown")
    _foreign_mcap(bag / "export.mcap", "", "jsonschema", "json")  # as Foxglove exports JSON
    args = ["convert", str(bag), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    got, want = read_trial(tmp_path / "out.mcap"), read_trial(tmp_path / "alone.mcap")
    assert len(got.wrench) == alone.steps and got.metadata.source == want.metadata.source
    for name in ("wrench", "twist", "pose"):
        np.testing.assert_array_equal(getattr(got, name).t_ns, getattr(want, name).t_ns)
        np.testing.assert_array_equal(getattr(got, name).values, getattr(want, name).values)


@pytest.mark.parametrize(
    ("layout", "name", "said"),
    [
        ("ros1", "LOG.BAG", "rosbags knows a bag by the lower-case .bag only; rename it LOG.bag"),
        ("bare-mcap", "LOG.MCAP", "rosbags knows a bag by the lower-case .mcap only; rename it "
         "LOG.mcap"),
        ("sqlite3", "day1.bag", "rosbags reads a folder named .bag as a ROS 1 bag, not a ROS 2 "
         "bag folder; rename it day1"),
    ],
)  # fmt: skip
def test_a_bag_named_as_rosbags_would_misread_it_is_told_the_name_to_give(
    bags: dict[str, Path], tmp_path: Path, layout: str, name: str, said: str
) -> None:
    """rosbags tells a bag's kind by its name, exactly: an upper-case suffix, or a ROS 2 bag
    folder named .bag, was "Unrecognized storage format '.BAG'" or "Is a directory", with
    the cure of a bag cut short."""
    import shutil

    bag = tmp_path / name
    copy = shutil.copytree if bags[layout].is_dir() else shutil.copyfile
    copy(bags[layout], bag)
    args = ["convert", str(bag), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert result.output == f"Error: {bag}: {said}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("noise.bag", "not a ROS 1 bag (it does not begin as one)"),
        ("bag/metadata.yaml", "cannot read bag: 'utf-8' codec can't decode"),
    ],
)
def test_a_bag_of_bytes_that_are_not_text_is_one_line(tmp_path: Path, name: str, said: str) -> None:
    """A .bag file (or a bag folder's metadata.yaml) of binary bytes where rosbags reads
    text had ended `convert` in a traceback of UnicodeDecodeError."""
    path = tmp_path / name
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(bytes(range(128, 256)) * 20)
    bag = path if path.suffix == ".bag" else path.parent
    args = ["convert", str(bag), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and len(result.output.splitlines()) == 1, result.output
    assert result.output.startswith(f"Error: {bag}: {said}")
    assert not (tmp_path / "out.mcap").exists()


def test_a_ros2_bag_with_broken_metadata_is_one_line(tmp_path: Path) -> None:
    bag = make_bag(tmp_path, standard_topics(1.0), "ros2")
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9")
    args = ["convert", str(bag), "-o", str(tmp_path / "out.mcap"), "--task", "gown"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and len(result.output.splitlines()) == 1, result.output
    assert "cannot read bag:" in result.output and "ros2 bag reindex" in result.output


# -- command line --------------------------------------------------------------------------


def test_the_command_converts_and_reports_errors_in_one_line(
    bags: dict[str, Path], tmp_path: Path
) -> None:
    out = tmp_path / "trial.mcap"
    runner = CliRunner()
    result = runner.invoke(main, ["convert", str(bags["ros1"]), "-o", str(out), "--task", "gown"])
    assert result.exit_code == 0, result.output
    assert "steps" in result.output and out.exists()
    again = runner.invoke(main, ["convert", str(bags["ros1"]), "-o", str(out), "--task", "gown"])
    assert again.exit_code == 1
    assert again.output.strip().count("\n") == 0 and "file exists" in again.output
    wrong = runner.invoke(
        main,
        ["convert", str(bags["ros1"]), "-o", str(tmp_path / "x.mcap"), "--task", "gown",
         "--pose-topic", "/nope"],
    )  # fmt: skip
    assert wrong.exit_code == 1 and "topic /nope not found" in wrong.output
    assert "Traceback" not in wrong.output


def test_an_output_inside_the_bag_folder_being_read_is_refused(bags: dict[str, Path]) -> None:
    folder = bags["mcap"]
    before = {p: p.read_bytes() for p in folder.iterdir()}
    (inside,) = [p for p in before if p.suffix == ".mcap"]  # the bag's own data file
    for out in (inside, folder / "trial.mcap"):
        args = ["convert", str(folder), "-o", str(out), "--task", "gown", "--overwrite"]
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 1 and "is inside log, the folder being read" in result.output
    assert {p: p.read_bytes() for p in folder.iterdir()} == before


@prints_warnings
def test_the_command_prints_gap_warnings(tmp_path: Path) -> None:
    topics = standard_topics(1.0)
    kind, stamps, values = topics["/arm/ee_pose"]
    keep = np.ones(len(stamps), bool)
    keep[20:30] = False
    topics["/arm/ee_pose"] = (kind, stamps[keep], values[keep])
    bag = make_bag(tmp_path, topics, "ros1")
    result = CliRunner().invoke(
        main, ["convert", str(bag), "-o", str(tmp_path / "t.mcap"), "--task", "gown"]
    )
    assert result.exit_code == 0, result.output
    assert "Warning: gap of 0.220 s in /arm/ee_pose" in result.output


@pytest.mark.parametrize("layout", ["ros1", "mcap"])
def test_info_on_a_bag_shows_its_topics_what_convert_takes_and_its_tf_tree(
    tmp_path: Path, layout: str
) -> None:
    """What `convert`'s options are chosen from: the topics, the wrench's frame, and the tf
    frames drawn as a tree from the root, each static or moving, so that PARENT:CHILD
    and --wrench-frame can be read off it."""
    bag = make_bag(tmp_path, tf_topics(1.0), layout, frames={"/ft_sensor/wrench": "tool"})
    result = CliRunner().invoke(main, ["info", str(bag)])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert re.match(r"log(\.bag)?: ROS [12] bag, 1101 messages over 1\.50 s$", lines[0]), lines[0]
    assert re.search(r"/tf_static +1  tf2_msgs/msg/TFMessage$", result.output, re.M)
    assert "  convert  takes wrench /ft_sensor/wrench; the pose needs --pose-tf" in result.output
    assert "  wrench   in frame tool (in the tf tree below)\n" in result.output
    tree = lines[lines.index("  tf tree") + 1 :]
    assert tree == [
        "    world",
        "      base  (static)",
        "        elbow  (/tf, 100 transforms at 100 Hz, never moving)",
        "        link1  (/tf, 100 transforms at 100 Hz)",
        "          tool  (static)",
        "      camera  (static)",
    ]
    as_json = CliRunner().invoke(main, ["info", str(bag), "--json"])
    listed = json.loads(as_json.output)
    assert {(e["parent"], e["child"], e["static"]) for e in listed["tf"]} == {
        ("world", "base", True), ("base", "link1", False), ("base", "elbow", False),
        ("link1", "tool", True), ("world", "camera", True),
    }  # fmt: skip
    assert listed["wrench_frame"] == "tool"
    (tmp_path / "ft").mkdir()
    elsewhere = make_bag(tmp_path / "ft", tf_topics(1.0), layout)  # the default frame `ft`
    shown = CliRunner().invoke(main, ["info", str(elsewhere)])
    assert "  wrench   in frame ft (not in the tf tree)\n" in shown.output, shown.output


def test_info_on_a_bag_with_a_pose_topic_names_the_topics_convert_takes(tmp_path: Path) -> None:
    bag = make_bag(tmp_path, standard_topics(1.0), "sqlite3")
    result = CliRunner().invoke(main, ["info", str(bag)])
    assert result.exit_code == 0, result.output
    assert "tf tree" not in result.output
    assert re.search(r"  convert  takes wrench /ft_sensor/wrench, \w+ /", result.output)
    topics = standard_topics(1.0)
    topics["/ft_raw"] = topics["/ft_sensor/wrench"]
    (tmp_path / "two").mkdir()
    two = make_bag(tmp_path / "two", topics, "ros1")
    result = CliRunner().invoke(main, ["info", str(two)])
    assert result.exit_code == 0, result.output
    assert (
        "  convert  refuses it as it stands: 2 WrenchStamped topics (/ft_raw, /ft_sensor/wrench); "
        "choose one with --wrench-topic" in result.output
    )


def test_info_on_an_empty_bag_says_there_is_nothing_to_convert(tmp_path: Path) -> None:
    bag = make_bag(tmp_path, {}, "sqlite3")
    result = CliRunner().invoke(main, ["info", str(bag)])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[1:] == [
        "  topics   none",
        "  convert  has nothing to convert: the bag holds no messages",
    ]


def test_info_on_a_bag_that_is_not_one_says_so_in_one_line(tmp_path: Path) -> None:
    bag = tmp_path / "log.bag"
    bag.write_bytes(b"not a bag at all")
    result = CliRunner().invoke(main, ["info", str(bag)])
    assert result.exit_code == 1
    assert len(lines := result.output.strip().splitlines()) == 1
    assert lines[0].startswith(f"Error: {bag}: not a ROS 1 bag (it does not begin as one); {READS}")
