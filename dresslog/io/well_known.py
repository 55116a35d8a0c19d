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

#: Channels without which a file is not a trial the model can run on.
REQUIRED = (WRENCH, TWIST)
