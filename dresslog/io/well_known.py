"""Names of the trial format in one place: profile, encodings, topics, schemas."""

from __future__ import annotations

PROFILE = "ros2"
MESSAGE_ENCODING = "cdr"
SCHEMA_ENCODING = "ros2msg"
METADATA_NAME = "dresslog"
LIBRARY = "dresslog"

WRENCH = "/ee/wrench"
TWIST = "/ee/twist"
POSE = "/ee/pose"
CONTACTS = "/limb/contacts"
FORCE_MAP = "/limb/force_map"
ESTIMATE = "/limb/force_map/estimate"
LIMB_POINTS = "/limb/points"
GARMENT = "/garment/state"

#: Topic -> ROS 2 message type; the schema every dresslog file registers for it.
SCHEMAS: dict[str, str] = {
    WRENCH: "geometry_msgs/msg/WrenchStamped",
    TWIST: "geometry_msgs/msg/TwistStamped",
    POSE: "geometry_msgs/msg/PoseStamped",
    CONTACTS: "dresslog_msgs/msg/ContactArray",
    FORCE_MAP: "dresslog_msgs/msg/ForceMap",
    ESTIMATE: "dresslog_msgs/msg/ForceMap",
    LIMB_POINTS: "dresslog_msgs/msg/LimbPoints",
    GARMENT: "dresslog_msgs/msg/GarmentState",
}

#: A live session's signal as it arrived (`dresslog live -o`), before resampling: on the
#: robot's clock less the session's start, in the sensor's and robot's own frames. Standard
#: messages that ROS 2 tools read; dresslog's reader only counts them.
RECEIVED: dict[str, str] = {
    "wrench": "/received/wrench",
    "twist": "/received/twist",
    "pose": "/received/pose",
}
RECEIVED_SCHEMAS: dict[str, str] = {
    RECEIVED["wrench"]: SCHEMAS[WRENCH],
    RECEIVED["twist"]: SCHEMAS[TWIST],
    RECEIVED["pose"]: SCHEMAS[POSE],
}

#: A live session's `source.format` in its metadata (a converted log's is its input's kind).
LIVE_FORMAT = "ros2 live"

#: The standard channels a 3D viewer draws (`dresslog.io.drawn`), written beside ours from
#: the same data. Readers of the trial ignore them: they are views, never read back.
FORCE_CLOUD = "/limb/force_map/cloud"
ESTIMATE_CLOUD = "/limb/force_map/estimate/cloud"
LIMB_MARKER = "/limb/marker"
GARMENT_SCENE = "/garment/scene"
GARMENT_CLOUD = "/garment/cloud"
PATH_MARKER = "/ee/path"
TF = "/tf"
TF_STATIC = "/tf_static"
DRAWN: dict[str, str] = {
    FORCE_CLOUD: "sensor_msgs/msg/PointCloud2",
    ESTIMATE_CLOUD: "sensor_msgs/msg/PointCloud2",
    LIMB_MARKER: "visualization_msgs/msg/MarkerArray",
    GARMENT_SCENE: "foxglove_msgs/msg/SceneUpdate",
    GARMENT_CLOUD: "sensor_msgs/msg/PointCloud2",
    PATH_MARKER: "visualization_msgs/msg/MarkerArray",
    TF: "tf2_msgs/msg/TFMessage",
    TF_STATIC: "tf2_msgs/msg/TFMessage",
}

#: The real-number fields of a contact (the rest are indices), which must be finite.
CONTACT_REALS = ("position", "normal", "friction", "normal_force")

#: The two 3-vector fields of each end-effector message: its columns 0-2 and 3-5 (3-6).
VECTOR_FIELDS: dict[str, tuple[str, str]] = {
    WRENCH: ("wrench.force", "wrench.torque"),
    TWIST: ("twist.linear", "twist.angular"),
    POSE: ("pose.position", "pose.orientation"),
    RECEIVED["wrench"]: ("wrench.force", "wrench.torque"),
    RECEIVED["twist"]: ("twist.linear", "twist.angular"),
    RECEIVED["pose"]: ("pose.position", "pose.orientation"),
}

#: Header frame of each topic: measurements at the end effector, ground truth in the world.
FRAMES: dict[str, str] = {
    WRENCH: "ee",
    TWIST: "world",
    POSE: "world",
    CONTACTS: "world",
    FORCE_MAP: "world",
    ESTIMATE: "world",
    LIMB_POINTS: "world",
    GARMENT: "world",
}

#: rosbag2's `offered_qos_profiles` for a stream: reliable, volatile, keep the last 10. The
#: MCAP ros2 profile requires it on every channel; `ros2 bag play` publishes with it. Policies
#: are rmw's enum integers, as up to Humble; durations 0 mean "the default". rosbag2 from Jazzy
#: on reads policies as names unless the file has a `rosbag2` metadata record without
#: `serialized_metadata`, which marks it as written the Humble way: `ROSBAG2_METADATA`.
_QOS = """\
- history: 1
  depth: {depth}
  reliability: 1
  durability: {durability}
  deadline:
    sec: 0
    nsec: 0
  lifespan:
    sec: 0
    nsec: 0
  liveliness: 1
  liveliness_lease_duration:
    sec: 0
    nsec: 0
  avoid_ros_namespace_conventions: false
"""
STREAM_QOS = _QOS.format(depth=10, durability=2)
#: Written once: latched (transient local, keep the last 1), so a late subscriber still gets it.
LATCHED_QOS = _QOS.format(depth=1, durability=1)
#: The trial's metadata record again, as the JSON text of a std_msgs/msg/String on a
#: latched channel: generic tools (rosbags-convert to a ROS 1 bag and back) drop MCAP
#: metadata records but keep messages. Not stamped, so not one of `SCHEMAS`' streams.
METADATA_TOPIC = "/dresslog/metadata"
#: Topic -> ROS 2 message type of dresslog's channels without a header.
UNSTAMPED: dict[str, str] = {METADATA_TOPIC: "std_msgs/msg/String"}
#: The stamp of a trial's time 0 in files of format 2 (2020-01-01T00:00:00Z, ns since the
#: Unix epoch): viewers that show stamps as dates (Foxglove, Rerun's MCAP importer) show
#: a date near today's, not 1970, and the same spec still gives the same bytes.
TIME_ORIGIN_NS = 1_577_836_800 * 1_000_000_000
#: Every topic a `TrialWriter` writes -> its ROS 2 type: dresslog's streams, a live
#: session's received signal, the metadata channel and the drawn channels, in one map.
TYPES: dict[str, str] = SCHEMAS | RECEIVED_SCHEMAS | UNSTAMPED | DRAWN
QOS: dict[str, str] = dict.fromkeys([*SCHEMAS, *DRAWN], STREAM_QOS) | dict.fromkeys(
    (LIMB_POINTS, LIMB_MARKER, PATH_MARKER, TF_STATIC, *UNSTAMPED), LATCHED_QOS
)
#: The metadata record Humble's recorder writes (name, contents); see `_QOS`.
ROSBAG2_METADATA = ("rosbag2", {"ROS_DISTRO": "humble"})

#: Channels without which a file is not a trial the model can run on.
REQUIRED = (WRENCH, TWIST)
