"""`dresslog live` end to end on loopback ROS 2: the sample bag replayed on topics, `live` in
its own process beside it, its published estimate against `convert` + `infer` of the bag.

ROS 2 here is PyPI's Jazzy wheels (the test extra pulls `dresslog[ros2]`); every test talks
on its own domain, discovery kept to this machine.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.convert.rosbag import read_bag
from dresslog.errors import LiveError
from dresslog.io.reader import read_trial
from dresslog.live import LiveOptions, LiveSession, LiveWarning
from dresslog.live.options import HIGH_FORCE_N
from dresslog.live.ros import SUMMARY_FIELDS
from dresslog.model.bundled import resolve_model

ROOT = Path(__file__).resolve().parents[2]
BAG = ROOT / "samples" / "robot" / "bag"
WRENCH, POSE = "/ft_sensor/wrench", "/tool_pose"
#: The README's options for the sample bag (its pose here on a topic, not from /tf).
SIGNAL = ["--wrench-frame", "pose", "--tare", "0.5", "--rotate", "0", "0", "-0.7071068",
          "0.7071068", "--translate", "0.1", "0.6", "-0.25"]  # fmt: skip
DRESSLOG = str(Path(sys.executable).with_name("dresslog"))


@pytest.fixture(scope="module")
def ros_env() -> Iterator[dict[str, str]]:
    """One ROS 2 domain for this module's processes, found only on this machine."""
    saved = {k: os.environ.get(k) for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")}
    os.environ["ROS_DOMAIN_ID"] = str(10 + os.getpid() % 80)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    yield dict(os.environ)
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@pytest.fixture(scope="module")
def bag_source() -> Any:
    """The bag's wrench and its gripper pose (tool0 in base_link, from its /tf)."""
    return read_bag(BAG, pose_tf="base_link:tool0")


@pytest.fixture(scope="module")
def converted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Any]:
    """`convert` + `infer` of the bag: the trial and its copy with the estimate."""
    folder = tmp_path_factory.mktemp("converted")
    trial, copy = folder / "bag.mcap", folder / "copy.mcap"
    args = ["convert", str(BAG), "-o", str(trial), "--task", "gown", "--pose-tf", "base_link:tool0"]
    assert CliRunner().invoke(main, [*args, *SIGNAL]).exit_code == 0
    result = CliRunner().invoke(main, ["infer", str(trial), "-o", str(folder / "bag.rrd"),
                                       "--mcap-out", str(copy)])  # fmt: skip
    assert result.exit_code == 0, result.output
    return read_trial(trial), read_trial(copy)


class Robot:
    """A node that publishes the bag's messages and listens to what `live` publishes."""

    def __init__(self) -> None:
        import rclpy
        from geometry_msgs.msg import PoseStamped, WrenchStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import PointCloud2
        from std_msgs.msg import Float32MultiArray

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("robot", context=self.context)
        qos = QoSProfile(depth=10_000)
        self.wrench = self.node.create_publisher(WrenchStamped, WRENCH, qos)
        self.pose = self.node.create_publisher(PoseStamped, POSE, qos)
        self.maps: list[tuple[int, np.ndarray]] = []
        self.summaries: list[np.ndarray] = []
        self.node.create_subscription(PointCloud2, "/dresslog/force_map", self._on_map, qos)
        self.node.create_subscription(Float32MultiArray, "/dresslog/summary", self._on_summary, qos)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._spinning = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _on_map(self, msg: Any) -> None:
        cloud = np.frombuffer(bytes(msg.data), dtype=np.float32).reshape(-1, 4)
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.maps.append((stamp, cloud[:, 3].copy()))

    def _on_summary(self, msg: Any) -> None:
        self.summaries.append(np.array(msg.data))

    def _spin(self) -> None:
        while self._spinning:
            self.executor.spin_once(timeout_sec=0.05)

    def wait_for_live(self, timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if (
                self.wrench.get_subscription_count()
                and self.pose.get_subscription_count()
                and self.node.count_publishers("/dresslog/force_map")
            ):
                return
            time.sleep(0.05)
        raise AssertionError("live never subscribed")

    def play(self, source: Any, speed: float) -> None:
        """Publish the bag's samples in its log order, paced at `speed` times its rate."""
        from geometry_msgs.msg import PoseStamped, WrenchStamped

        events = [(int(t), 0, i) for i, t in enumerate(source.wrench.log_ns)]
        events += [(int(t), 1, i) for i, t in enumerate(source.pose.log_ns)]
        events.sort()
        start, first = time.monotonic(), events[0][0]
        for log_ns, kind, i in events:
            while (ahead := (log_ns - first) / 1e9 / speed - (time.monotonic() - start)) > 0:
                time.sleep(min(ahead, 0.002))
            stream = source.pose if kind else source.wrench
            t = int(stream.t_ns[i])
            v = stream.values[i].tolist()
            msg: Any = PoseStamped() if kind else WrenchStamped()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t, 1_000_000_000)
            msg.header.frame_id = stream.frame_id
            if kind:
                p, q = msg.pose.position, msg.pose.orientation
                p.x, p.y, p.z, q.x, q.y, q.z, q.w = v
                self.pose.publish(msg)
            else:
                f, tq = msg.wrench.force, msg.wrench.torque
                f.x, f.y, f.z, tq.x, tq.y, tq.z = v
                self.wrench.publish(msg)

    def settle(self, quiet: float = 1.0, timeout: float = 20.0) -> None:
        """Wait until no estimate has come for `quiet` s."""
        deadline, seen, since = time.monotonic() + timeout, -1, time.monotonic()
        while time.monotonic() < deadline:
            if len(self.maps) != seen:
                seen, since = len(self.maps), time.monotonic()
            elif time.monotonic() - since > quiet:
                return
            time.sleep(0.05)

    def close(self) -> None:
        self._spinning = False
        self._thread.join()
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_live(args: list[str], env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [DRESSLOG, "live", "--task", "gown", *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.parametrize("speed", [1.0, 4.0], ids=["recorded-rate", "4x-and-to-rerun"])
def test_live_publishes_what_convert_and_infer_make_of_the_bag_and_records_it(
    tmp_path: Path, ros_env: dict[str, str], bag_source: Any, converted: Any, speed: float
) -> None:
    session = tmp_path / "session.mcap"
    args = ["--wrench-topic", WRENCH, "--pose-topic", POSE, *SIGNAL, "-o", str(session)]
    server = None
    if speed > 1:  # and to a Rerun viewer elsewhere, as `record --connect` streams
        import rerun as rr

        server = rr.RecordingStream("dresslog-test-server")  # stands in for the viewer
        args += ["--connect", rr.serve_grpc(grpc_port=_free_port(), recording=server)]
    live = start_live(args, ros_env)
    robot = Robot()
    try:
        robot.wait_for_live()
        robot.play(bag_source, speed)
        robot.settle()
        live.send_signal(signal.SIGTERM)  # as a robot's launch file stops it
        out, err = live.communicate(timeout=30)
    finally:
        if live.poll() is None:
            live.kill()
        robot.close()
        if server is not None:
            server.disconnect()
    assert live.returncode == 0, err
    assert "Traceback" not in err and f"-> {session}" in out

    trial, copy = converted
    grid = copy.estimate.t_ns + trial.metadata.source["start_ns"]
    stamps = np.array([s for s, _ in robot.maps])
    published = np.stack([f for _, f in robot.maps])
    # every step but the last (whose next bin a live stream never closes), in order
    assert len(stamps) == len(grid) - 1 and np.array_equal(stamps, grid[:-1])
    np.testing.assert_allclose(published, copy.estimate.forces[:-1], atol=2e-5)
    assert published.sum(axis=1).max() > HIGH_FORCE_N  # a real dressing's estimate, not zeros

    summary = np.stack(robot.summaries)
    assert summary.shape == (len(stamps), len(SUMMARY_FIELDS))
    np.testing.assert_allclose(summary[:, 0], published.sum(axis=1), rtol=1e-5)
    assert set(summary[:, 4]) == {0.0, 1.0}  # the gown's 14.9 N peak is over the default
    assert np.array_equal(summary[:, 4] == 1.0, summary[:, 0] > HIGH_FORCE_N)

    info = CliRunner().invoke(main, ["info", str(session)])
    assert (
        info.exit_code == 0 and "/received/wrench" in info.output and "estimate yes" in info.output
    )
    recorded = read_trial(session)
    np.testing.assert_array_equal(recorded.estimate.forces, published)
    again = tmp_path / "again.mcap"
    result = CliRunner().invoke(main, ["infer", str(session), "-o", str(tmp_path / "s.rrd"),
                                       "--mcap-out", str(again)])  # fmt: skip
    assert result.exit_code == 0, result.output
    np.testing.assert_array_equal(read_trial(again).estimate.forces, recorded.estimate.forces)


def test_live_names_a_silent_topic_and_a_topic_of_another_type(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    import rclpy
    from std_msgs.msg import Float32MultiArray

    session = tmp_path / "s.mcap"
    args = ["--wrench-topic", "/nothing", "--twist-topic", "/nor_this", "--wait", "1"]
    silent = start_live([*args, "-o", str(session)], ros_env)
    _, err = silent.communicate(timeout=30)
    assert silent.returncode == 1 and "Traceback" not in err
    assert "Error: no message on /nothing within 1 s" in err and not session.exists()
    assert not list(tmp_path.iterdir())  # no temporary left either

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("imposter", context=context)
    node.create_publisher(Float32MultiArray, "/typed_wrong", 10)
    try:
        wrong = start_live(["--wrench-topic", "/typed_wrong", "--twist-topic", "/t"], ros_env)
        _, err = wrong.communicate(timeout=30)
    finally:
        node.destroy_node()
        context.try_shutdown()
    assert wrong.returncode == 1 and "Traceback" not in err
    assert (
        "Error: /typed_wrong is published as std_msgs/msg/Float32MultiArray, not "
        "geometry_msgs/msg/WrenchStamped" in err
    )


def test_live_without_rclpy_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "rclpy", None)  # as where the extra is not installed
    args = ["live", "--task", "gown", "--wrench-topic", "/w", "--twist-topic", "/t"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and result.exception is not None
    line = result.output.strip()
    assert line.startswith("Error: dresslog live needs ROS 2's rclpy: pip install 'dresslog[ros2]'")
    assert "\n" not in line


def test_live_refuses_a_model_of_the_other_task(ros_env: dict[str, str]) -> None:
    args = ["live", "--task", "shorts", "--model", str(ROOT / "samples/models/gown"),
            "--wrench-topic", "/w", "--twist-topic", "/t"]  # fmt: skip
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and "gown" in result.output and "shorts" in result.output
    assert result.output.startswith("Error: ") and result.output.count("\n") == 1


def test_live_options_that_contradict_each_other_are_usage_errors() -> None:
    base = ["live", "--task", "gown", "--wrench-topic", "/w"]
    cases = [
        ([], "give --twist-topic or --pose-topic"),
        (["--twist-topic", "/t", "--wrench-frame", "pose"], "--wrench-frame pose needs the "),
        (["--twist-topic", "/t", "--sensor-offset", "0", "0", "0.1"], "--sensor-offset places"),
        (["--twist-topic", "/w"], "one topic for two streams"),
    ]
    for extra, message in cases:
        result = CliRunner().invoke(main, [*base, *extra])
        assert result.exit_code == 2 and message in result.output, result.output


# -- the session itself, fed samples directly (no ROS) ---------------------------------
def _session(tmp_path: Path, **options: Any) -> LiveSession:
    settings = LiveOptions.build(
        "gown", wrench_topic=WRENCH, pose_topic=POSE, output=tmp_path / "s.mcap", **options
    )
    loaded = resolve_model(None, "gown", None)
    assert loaded is not None
    return LiveSession(settings, loaded.estimator())


def _feed(session: LiveSession, source: Any, upto_s: float | None = None) -> None:
    events = [(int(t), "wrench", i) for i, t in enumerate(source.wrench.log_ns)]
    events += [(int(t), "pose", i) for i, t in enumerate(source.pose.log_ns)]
    events.sort()
    first = events[0][0]
    for log_ns, kind, i in events:
        if upto_s is not None and log_ns - first > upto_s * 1e9:
            return
        stream = source.wrench if kind == "wrench" else source.pose
        session.receive(kind, int(stream.t_ns[i]), stream.values[i], stream.frame_id)


def test_a_stamp_going_back_a_little_is_dropped_and_a_clock_reset_ends_a_valid_session(
    tmp_path: Path, bag_source: Any
) -> None:
    session = _session(tmp_path, wrench_frame="pose", tare_s=0.5)
    _feed(session, bag_source, upto_s=2.0)
    t = session._last["wrench"]
    with pytest.warns(LiveWarning, match=f"{WRENCH}: a message stamped 1 ms before"):
        assert session.receive("wrench", t - 1_000_000, np.zeros(6)) == []
    with pytest.raises(LiveError, match=f"{WRENCH}: time goes back 5 s .a clock reset"):
        session.receive("wrench", t - 5_000_000_000, np.zeros(6))
    path = session.finish()
    assert path is not None
    info = CliRunner().invoke(main, ["info", str(path)])
    assert info.exit_code == 0, info.output
    trial = read_trial(path)
    assert len(trial.estimate.t_ns) == session.steps > 100
    assert trial.metadata.source["streams"]["wrench"]["dropped_late"] == 1  # type: ignore[index]


def test_a_stream_far_below_the_models_rate_is_refused_and_a_slow_one_warned_of(
    tmp_path: Path,
) -> None:
    for rate, expect in ((5, "too slow"), (50, "slower than the model's 100 Hz")):
        session = _session(tmp_path / str(rate))
        period = 1_000_000_000 // rate
        pose = np.array([0.0, 0, 0, 0, 0, 0, 1])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                for i in range(60):
                    session.receive("wrench", i * period, np.zeros(6), "base")
                    session.receive("pose", i * period, pose, "base")
                raised = ""
            except LiveError as err:
                raised = str(err)
        said = raised + " ".join(str(w.message) for w in caught)
        assert f"{WRENCH} arrives at {rate:g} Hz" in said and expect in said
        assert bool(raised) == (rate == 5)
        session.finish()


def test_a_wrench_in_a_frame_the_options_do_not_place_is_warned_of(
    tmp_path: Path, bag_source: Any
) -> None:
    session = _session(tmp_path)  # the bag's wrench is in the sensor's axes: world assumed
    with pytest.warns(LiveWarning, match="the wrench is in frame 'ft_sensor', the motion in "):
        _feed(session, bag_source, upto_s=0.5)
    assert session.finish() is not None


def test_unset_header_stamps_are_timed_by_arrival_with_a_warning(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    """A driver that never fills its headers: `live` runs in this process, on its clock."""
    import rclpy
    from geometry_msgs.msg import PoseStamped, WrenchStamped

    from dresslog.live import run_live

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("unstamped", context=context)
    wrench_pub = node.create_publisher(WrenchStamped, "/raw_wrench", 100)
    pose_pub = node.create_publisher(PoseStamped, "/raw_pose", 100)

    def play() -> None:
        while not (wrench_pub.get_subscription_count() and pose_pub.get_subscription_count()):
            time.sleep(0.02)
        pose = PoseStamped()
        pose.pose.orientation.w = 1.0
        for i in range(150):  # 1.5 s at 100 Hz, stamps left 0
            pose.pose.position.x = 0.001 * i
            wrench_pub.publish(WrenchStamped())
            pose_pub.publish(pose)
            time.sleep(0.01)

    options = LiveOptions.build(
        "gown", wrench_topic="/raw_wrench", pose_topic="/raw_pose", output=tmp_path / "s.mcap"
    )
    player = threading.Thread(target=play)
    player.start()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            report = run_live(options, stop_after=3.0, context=context)
    finally:
        player.join()
        node.destroy_node()
        context.try_shutdown()
    said = sorted(str(w.message) for w in caught if w.category is LiveWarning)
    assert said == [f"{topic}: header stamps unset, timed by their arrival"
                    for topic in ("/raw_pose", "/raw_wrench")]  # fmt: skip
    assert report.steps > 50 and report.output == tmp_path / "s.mcap"
    assert CliRunner().invoke(main, ["info", str(report.output)]).exit_code == 0
