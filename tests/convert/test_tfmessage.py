"""The TFMessages read in bulk give exactly the edges and pose rosbags' per-message path gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dresslog.convert import tf, tfmessage
from tests.convert.signals import tf_topics, write_bag

pytest.importorskip("rosbags")

STILL = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def varied_tf(seconds: float = 1.0):
    """`tf_topics`' /tf with every layout trouble a bag's /tf may hold: a frame added midway
    (a longer message), a second publisher whose frames have names of other lengths, one
    whose names differ from the first's at equal length, a ROS 1 name with a leading slash
    (the same edge as without), and that one stamped twice with other values."""
    topics = tf_topics(seconds)
    kind, stamps, moving = topics["/tf"]
    out = []
    for i, edges in enumerate(moving):
        (_, _, link1), (_, _, elbow) = edges
        if i % 5 == 1:  # another publisher: other names, other lengths
            edges = (("world", "forearm_camera", link1),)
        elif i % 5 == 2:  # equal length, other names: "elbow" -> "wrist"
            edges = (("base", "link1", link1), ("base", "wrist", elbow))
        elif i % 5 == 3:  # the edge of i - 1 with a leading slash, its stamp given again
            edges = (("/base", "link1", link1 * 0.5), ("base", "elbow", elbow))
        if i >= len(moving) // 2:  # a frame added midway
            edges = (*edges, ("elbow", "finger", link1))
        out.append(edges)
    stamps = stamps.copy()
    stamps[3::5] = stamps[2::5][: len(stamps[3::5])]
    topics["/tf"] = (kind, stamps, out)
    return topics


def raw_tf(reader) -> list[tuple[bool, list[int], list]]:
    """Each tf topic of an open AnyReader as `collect_edges` takes it."""
    connections = [c for c in reader.connections if c.msgtype == tf.TF_TYPE]
    topics: dict[str, tuple[list[int], list]] = {}
    for connection, t_ns, raw in reader.messages(connections):
        times, payloads = topics.setdefault(connection.topic, ([], []))
        times.append(t_ns)
        payloads.append(raw)
    return [(topic == "/tf_static", *topics[topic]) for topic in sorted(topics)]


def edges_and_pose(reader, topics, path: Path, calls: list[int]):
    def deserialize(raw):
        calls.append(1)
        return reader.deserialize(raw, tf.TF_TYPE)

    edges = tf.collect_edges(topics, deserialize, ros1=not reader.is2)
    return edges, tf.pose_stream(edges, "world", "finger", path)


@pytest.mark.parametrize("layout", ["ros1", "mcap"])
@pytest.mark.parametrize("layouts", [1, tfmessage.MAX_LAYOUTS])
def test_tf_read_in_bulk_gives_exactly_the_per_message_edges_and_pose(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, layout: str, layouts: int
) -> None:
    from rosbags.highlevel import AnyReader

    name = "log.bag" if layout == "ros1" else "log"
    path = write_bag(tmp_path / name, varied_tf(), layout)
    with AnyReader([path]) as reader:
        topics = raw_tf(reader)
        bulk_calls: list[int] = []
        monkeypatch.setattr(tfmessage, "MAX_LAYOUTS", layouts)
        edges, pose = edges_and_pose(reader, topics, path, bulk_calls)
        monkeypatch.setattr(tfmessage, "MAX_LAYOUTS", 0)  # every message deserialised alone
        calls: list[int] = []
        want_edges, want_pose = edges_and_pose(reader, topics, path, calls)
    assert len(calls) == sum(len(payloads) for _, _, payloads in topics)
    # with one layout a length, the equal-length other names go one by one, in CDR the
    # "/base" ones too (its padding makes "/base" and "base" equal length); else none do
    _, _, moving = topics[0]
    alone = len(moving[2::5]) + (0 if layout == "ros1" else len(moving[3::5]))
    assert len(bulk_calls) == (alone if layouts == 1 else 0)
    assert list(edges) == list(want_edges)
    assert sorted(edges) == ["base", "camera", "elbow", "finger", "forearm_camera", "link1",
                             "tool", "wrist"]  # fmt: skip
    for child, found in want_edges.items():
        assert [(e.parent, e.static) for e in edges[child]] == [(e.parent, e.static) for e in found]
        for got, want in zip(edges[child], found, strict=True):
            assert np.array_equal(got.t_ns, want.t_ns) and np.array_equal(got.log_ns, want.log_ns)
            assert np.array_equal(got.values, want.values)
    assert np.array_equal(pose.t_ns, want_pose.t_ns)
    assert np.array_equal(pose.values, want_pose.values)


def test_a_payload_that_is_no_plain_tf_message_is_left_to_rosbags() -> None:
    assert tfmessage.layout(b"\x00\x01\x00\x00\x00\x00\x00\x00", ros1=False) is not None
    assert tfmessage.layout(b"\x00\x00\x00\x00\x00\x00\x00\x00", ros1=False) is None  # big end
    assert tfmessage.layout(b"\x00\x01\x00\x00\x01\x00\x00\x00", ros1=False) is None  # short
    assert tfmessage.layout(b"\x00\x00\x00\x00\x00", ros1=True) is None  # a byte too many
