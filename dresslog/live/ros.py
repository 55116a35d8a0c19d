"""ROS 2 around a `LiveSession`: rclpy subscriptions in, PointCloud2 and a summary out.

Only this module imports rclpy and the message packages, and only when `live` runs:
PyPI's ROS 2 Jazzy wheels (`pip install 'dresslog[ros2]'`) or a sourced ROS 2's own.

What is published, under the options' prefix (default `/dresslog`):

- `force_map` (`sensor_msgs/msg/PointCloud2`): the limb's points, float32 x, y, z and
  `force` (N, the estimate after Eq. 2), in `frame_id`, stamped with the step's time on
  the robot's clock; RViz and Foxglove colour points by a field.
- `contact_map` (`PointCloud2`): the same points with float32 `contact`, the model's
  contact probability.
- `summary` (`std_msgs/msg/Float32MultiArray`), one per step, `SUMMARY_FIELDS` in order
  (the layout's dimension label lists them): total force (N), peak force (N), the peak's
  point index, its limb part (index into the limb's part names, which the layout's second
  label lists), and 1.0 when the total is above `--high-force`, else 0.0. Numbers at fixed
  places, so a controller reads them without parsing text (a `DiagnosticStatus` carries
  strings); its stamp is the force map's, published just before it.
"""

from __future__ import annotations

import time
from array import array
from typing import TYPE_CHECKING, Any

import numpy as np

from dresslog.errors import LiveError
from dresslog.live.options import LiveOptions
from dresslog.replay.engine import StepResult, TrialContext

if TYPE_CHECKING:
    from dresslog.live.session import LiveSession

SUMMARY_FIELDS = ("total_force_n", "peak_force_n", "peak_point", "peak_part", "high_force")
#: rclpy's message types of the streams `live` subscribes to.
TYPE_NAMES = {
    "wrench": "geometry_msgs/msg/WrenchStamped",
    "twist": "geometry_msgs/msg/TwistStamped",
    "pose": "geometry_msgs/msg/PoseStamped",
}
INSTALL = (
    "dresslog live needs ROS 2's rclpy: pip install 'dresslog[ros2]' (PyPI's ROS 2 Jazzy "
    "wheels), or source a ROS 2 Jazzy install"
)
#: Messages a subscription holds if `live` falls behind (10 s of a 1 kHz sensor).
DEPTH = 10_000


def import_rclpy() -> Any:
    """rclpy, or a LiveError saying how to install it."""
    try:
        import rclpy
        from geometry_msgs.msg import PoseStamped  # noqa: F401
        from sensor_msgs.msg import PointCloud2  # noqa: F401
        from std_msgs.msg import Float32MultiArray  # noqa: F401
    except ImportError as err:
        raise LiveError(f"{INSTALL} ({err})") from None
    return rclpy


def _cloud(points: np.ndarray, field: str, frame_id: str) -> tuple[Any, np.ndarray]:
    """A PointCloud2 of `points` (N, 3) with float32 x y z and `field`, and the (N, 4) float32
    buffer its data is made from (column 3: the field's values)."""
    from sensor_msgs.msg import PointCloud2, PointField

    msg = PointCloud2()
    msg.header.frame_id = frame_id
    msg.height, msg.width = 1, len(points)
    msg.fields = [
        PointField(name=name, offset=4 * i, datatype=PointField.FLOAT32, count=1)
        for i, name in enumerate(("x", "y", "z", field))
    ]
    msg.is_bigendian, msg.point_step, msg.row_step = False, 16, 16 * len(points)
    msg.is_dense = True
    buffer = np.zeros((len(points), 4), dtype=np.float32)
    buffer[:, :3] = points
    return msg, buffer


class Publisher:
    """A replay sink that publishes each step's estimate on ROS 2 (see the module's doc)."""

    def __init__(self, node: Any, options: LiveOptions, session: LiveSession) -> None:
        from std_msgs.msg import Float32MultiArray, MultiArrayDimension

        self.session = session
        self.threshold = options.high_force_n
        prefix = options.prefix.rstrip("/")
        qos = 10
        from sensor_msgs.msg import PointCloud2

        self._force = node.create_publisher(PointCloud2, f"{prefix}/force_map", qos)
        self._contact = node.create_publisher(PointCloud2, f"{prefix}/contact_map", qos)
        self._summary = node.create_publisher(Float32MultiArray, f"{prefix}/summary", qos)
        limb = session.limb
        self._segment = limb.segment
        self._force_msg, self._force_buf = _cloud(limb.points, "force", options.frame_id)
        self._contact_msg, self._contact_buf = _cloud(limb.points, "contact", options.frame_id)
        self._summary_msg = Float32MultiArray()
        self._summary_msg.layout.dim = [
            MultiArrayDimension(label=",".join(SUMMARY_FIELDS), size=5, stride=5),
            MultiArrayDimension(label="parts:" + ",".join(limb.segment_names), size=0, stride=0),
        ]

    def open(self, context: TrialContext) -> None:
        """Nothing to open: the publishers exist before the first step."""

    def write(self, result: StepResult) -> None:
        """Publish one step's estimate, contact map and summary, stamped on the robot's clock."""
        if result.estimate is None or result.contact is None:
            return
        assert self.session.origin_ns is not None
        t_ns = result.step.t_ns + self.session.origin_ns
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        estimate = result.estimate
        total = float(estimate.sum())
        peak = int(np.argmax(estimate))
        self._summary_msg.data = [
            total,
            float(estimate[peak]),
            float(peak),
            float(self._segment[peak]),
            1.0 if total > self.threshold else 0.0,
        ]
        for msg, buf, values, pub in (
            (self._force_msg, self._force_buf, estimate, self._force),
            (self._contact_msg, self._contact_buf, result.contact, self._contact),
        ):
            buf[:, 3] = values
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
            msg.data = buf.tobytes()
            pub.publish(msg)
        self._summary.publish(self._summary_msg)

    def close(self) -> None:
        """Nothing to close: the node, and its publishers, belong to the session."""

    def commit(self) -> None:
        """Nothing to keep: what was published is already out."""

    def abort(self) -> None:
        """Nothing to undo: a published message cannot be taken back."""


class LiveNode:
    """The `dresslog_live` node: subscribes to the options' topics, feeds the session."""

    def __init__(self, options: LiveOptions, session: LiveSession, node: Any) -> None:
        from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        self.options, self.session, self.node = options, session, node
        reliability = (
            ReliabilityPolicy.BEST_EFFORT if options.best_effort else (ReliabilityPolicy.RELIABLE)
        )
        qos = QoSProfile(depth=DEPTH, reliability=reliability)
        self.started = time.monotonic()
        self.last_message: dict[str, float] = {}
        #: per wrench message that completed a step: ns from its arrival to the last publication
        self.latency_ns = array("q")
        #: per wrench message: ns from its arrival to the end of its handling
        self.handled_ns = array("q")
        kinds = {"wrench": WrenchStamped, "twist": TwistStamped, "pose": PoseStamped}
        #: what a callback raised (a clock reset, Ctrl-C), for `spin` to raise in its stead:
        #: rclpy's executors log a callback's exception with its traceback first
        self.failure: BaseException | None = None
        self.subscriptions = [
            node.create_subscription(kinds[kind], topic, self._guarded(self._callback(kind)), qos)
            for kind, topic in options.topics.items()
        ]
        self._silent_said: set[str] = set()
        self._unstamped: set[str] = set()

    def _guarded(self, callback: Any) -> Any:
        """`callback`, its exception kept in `failure` (and every message after it ignored)."""

        def guarded(msg: Any) -> None:
            if self.failure is not None:
                return
            try:
                callback(msg)
            except BaseException as err:  # Ctrl-C landing in a callback too
                self.failure = err

        return guarded

    def _stamp_ns(self, kind: str, msg: Any) -> int:
        """The message's header stamp; where a driver left it unset (0), the node's clock
        as it arrives, said once, as `convert` takes a bag's receive times then."""
        stamp = msg.header.stamp
        if stamp.sec or stamp.nanosec:
            return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
        if kind not in self._unstamped:
            self._unstamped.add(kind)
            self.session.warn(
                f"{self.options.topics[kind]}: header stamps unset, timed by their arrival"
            )
        return int(self.node.get_clock().now().nanoseconds)

    def _callback(self, kind: str) -> Any:
        receive, clock, stamp = self.session.receive, time.perf_counter_ns, self._stamp_ns
        last = self.last_message
        latency, handled = self.latency_ns, self.handled_ns

        if kind == "wrench":

            def on_wrench(msg: Any) -> None:
                arrived = clock()
                f, tq = msg.wrench.force, msg.wrench.torque
                values = np.array([f.x, f.y, f.z, tq.x, tq.y, tq.z])
                published = receive("wrench", stamp("wrench", msg), values, msg.header.frame_id)
                took = clock() - arrived
                handled.append(took)
                if published:
                    latency.append(took)
                last["wrench"] = time.monotonic()

            return on_wrench
        if kind == "twist":

            def on_twist(msg: Any) -> None:
                v, w = msg.twist.linear, msg.twist.angular
                values = np.array([v.x, v.y, v.z, w.x, w.y, w.z])
                receive("twist", stamp("twist", msg), values, msg.header.frame_id)
                last["twist"] = time.monotonic()

            return on_twist

        def on_pose(msg: Any) -> None:
            p, q = msg.pose.position, msg.pose.orientation
            values = np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w])
            receive("pose", stamp("pose", msg), values, msg.header.frame_id)
            last["pose"] = time.monotonic()

        return on_pose

    def _published(self) -> list[str]:
        """The topics other nodes publish (what the user may have meant)."""
        found = []
        for name, _ in self.node.get_topic_names_and_types():
            if name in ("/parameter_events", "/rosout"):
                continue
            infos = self.node.get_publishers_info_by_topic(name)
            if any(info.node_name != self.node.get_name() for info in infos):
                found.append(name)
        return sorted(found)

    def check_topics(self) -> None:
        """A topic published with another type, or silent since the start for longer than
        `wait_s`: a LiveError. One that fell silent later: a warning, once."""
        for kind, topic in self.options.topics.items():
            others = sorted(
                {info.topic_type for info in self.node.get_publishers_info_by_topic(topic)}
                - {TYPE_NAMES[kind]}
            )
            if others:
                raise LiveError(
                    f"{topic} is published as {', '.join(others)}, not {TYPE_NAMES[kind]}; "
                    f"give the {kind} topic"
                )
        now = time.monotonic()
        for kind, topic in self.options.topics.items():
            since = self.last_message.get(kind)
            if since is None and now - self.started > self.options.wait_s:
                listed = ", ".join(self._published())
                raise LiveError(
                    f"no message on {topic} within {self.options.wait_s:g} s (topics seen: "
                    f"{listed or 'none'}); is it the right topic, and its publisher running?"
                )
            if since is not None and now - since > self.options.wait_s:
                if topic not in self._silent_said:
                    self._silent_said.add(topic)
                    self.session.warn(
                        f"no message on {topic} for {self.options.wait_s:g} s; waiting (Ctrl-C "
                        "ends the session)"
                    )
            elif since is not None:
                self._silent_said.discard(topic)


def _executor(context: Any) -> Any:
    """rclpy's events executor (C++, Jazzy's `rclpy.experimental`), where there is one: at
    1 kHz the Python executor's wait set alone took a third of a core; else the usual one."""
    try:
        from rclpy.experimental import EventsExecutor
    except ImportError:
        from rclpy.executors import SingleThreadedExecutor

        return SingleThreadedExecutor(context=context)
    return EventsExecutor(context=context)


def spin(
    options: LiveOptions,
    session: LiveSession,
    *,
    stop_after: float | None = None,
    context: Any = None,
) -> LiveNode:
    """Run the node until Ctrl-C or SIGTERM (or `stop_after` seconds, for a benchmark): the
    caller finishes the session. rclpy leaves the signals to Python, so an interrupt lands
    here as KeyboardInterrupt and the session file is still finished."""
    rclpy = import_rclpy()
    from rclpy.signals import SignalHandlerOptions

    own = context is None
    if own:
        context = rclpy.Context()
        rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("dresslog_live", context=context)
    executor = _executor(context)
    try:
        publisher = Publisher(node, options, session)
        session.replay.sinks.insert(0, publisher)
        live = LiveNode(options, session, node)
        session.node = live  # its timings, for the report however the session ends
        executor.add_node(node)
        checked = time.monotonic()
        end = None if stop_after is None else time.monotonic() + stop_after
        while end is None or time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
            if live.failure is not None:
                raise live.failure
            if time.monotonic() - checked > 0.5:
                live.check_topics()
                checked = time.monotonic()
        return live
    finally:
        executor.shutdown()
        node.destroy_node()
        if own:
            context.try_shutdown()
