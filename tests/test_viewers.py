"""Viewers draw a trial with no dresslog code: Rerun's MCAP importer, Foxglove's decoders
(run through Node) and the Foxglove layout shipped with the package."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.io import TrialReader
from dresslog.io import well_known as wk
from dresslog.io.drawn import CLOUD_PERIOD_NS, FORCE_STEP, MESH_PERIOD_NS, POSITION_STEP
from tests.conftest import SAMPLES

FOXGLOVE = Path(__file__).parent / "foxglove"


@pytest.fixture(scope="module")
def trial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The recorded gown sample with the bundled model's estimate: `infer --mcap-out`."""
    out = tmp_path_factory.mktemp("viewers")
    args = ["infer", str(SAMPLES / "gown.mcap"), "-o", str(out / "g.rrd")]
    result = CliRunner().invoke(main, [*args, "--mcap-out", str(out / "g.mcap")])
    assert result.exit_code == 0, result.output
    return out / "g.mcap"


def _drawn_steps(t_ns: np.ndarray, period_ns: int = CLOUD_PERIOD_NS) -> np.ndarray:
    """The steps drawn: the first of each period (clouds 100 ms, the mesh 500 ms)."""
    bins = t_ns // period_ns
    return np.flatnonzero(np.diff(bins, prepend=-1) != 0)


def _on_grid(drawn: np.ndarray, values: np.ndarray, step: float) -> None:
    """`drawn` is `values` rounded to multiples of `step`."""
    np.testing.assert_array_equal(np.round(drawn / step), drawn / step)
    np.testing.assert_allclose(drawn, values, rtol=0, atol=step / 2)


def _rerun_columns(path: Path) -> dict[str, dict[str, list]]:
    """Every entity's non-empty columns (as Python lists of rows) from Rerun's importer."""
    from rerun.chunk import McapReader

    columns: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for chunk in McapReader(path, timeline_type="duration_ns").stream():
        batch = chunk.to_record_batch()
        for name, column in zip(batch.schema.names, batch.columns, strict=True):
            columns[str(chunk.entity_path)][name] += [v for v in column.to_pylist() if v]
    return columns


def test_rerun_imports_force_clouds_with_a_force_column_the_mesh_and_the_frames(
    trial: Path,
) -> None:
    with TrialReader(trial) as reader:
        limb = reader.limb_points.points
        maps = {wk.FORCE_CLOUD: reader.force_map, wk.ESTIMATE_CLOUD: reader.estimate}
        garment = reader.garment
        pose = reader.pose
    columns = _rerun_columns(trial)
    for topic, fm in maps.items():
        cloud = columns[topic]
        drawn = _drawn_steps(fm.t_ns)
        assert len(cloud["Points3D:force"]) == len(drawn) == 70, topic
        _on_grid(np.array(cloud["Points3D:force"]), fm.forces[drawn], FORCE_STEP)
        positions = np.array(cloud["Points3D:positions"][0])
        np.testing.assert_array_equal(positions, limb.astype(np.float32))
        assert cloud["CoordinateFrame:frame"][0] == ["limb"]
    assert columns[wk.FORCE_CLOUD]["Points3D:force"] != columns[wk.ESTIMATE_CLOUD]["Points3D:force"]
    # Rerun 0.41 draws no scene types: the mesh arrives as its message, vertices indexed,
    mesh = columns[wk.GARMENT_SCENE]["foxglove_msgs.msg.SceneUpdate:message"]
    steps = _drawn_steps(garment.t_ns, MESH_PERIOD_NS)
    assert len(mesh) == len(steps) == 14
    (entity,) = mesh[-1][0]["entities"]
    (triangles,) = entity["triangles"]
    assert triangles["indices"] == garment.triangles.ravel().tolist()
    points = [[p["x"], p["y"], p["z"]] for p in triangles["points"]]
    _on_grid(np.array(points), garment.vertices[steps[-1]], POSITION_STEP)
    # ... and draws the same vertices, beside it, as points
    vertices = columns[wk.GARMENT_CLOUD]["Points3D:positions"]
    assert len(vertices) == len(steps)
    np.testing.assert_array_equal(np.array(vertices[-1]), np.array(points, np.float32))
    assert columns[wk.GARMENT_CLOUD]["CoordinateFrame:frame"][0] == ["world"]
    # every transform arrives, each message's at its log time, where its last one (its
    # first pose) wins: the frames at 10 Hz, each at its own time
    tf = columns[wk.TF]
    assert len(tf["Transform3D:translation"]) == 2 * len(pose)  # gripper and sensor
    assert {p[0] for p in tf["Transform3D:parent_frame"]} == {"world"}
    assert {c[0] for c in tf["Transform3D:child_frame"]} == {"gripper", "ee"}
    times = np.array(tf["message_log_time"], "timedelta64[ns]").astype(np.int64) - wk.TIME_ORIGIN_NS
    ends = np.flatnonzero(np.diff(times, append=times[-1] + 1))  # a message's last row
    gripper = ends - 1  # listed gripper, ee for each pose
    assert len(ends) == len(_drawn_steps(pose.t_ns))
    np.testing.assert_array_equal(times[ends], pose.t_ns[_drawn_steps(pose.t_ns)])
    np.testing.assert_allclose(
        np.array(tf["Transform3D:translation"], np.float64)[gripper, 0],
        pose.values[_drawn_steps(pose.t_ns), :3].astype(np.float32),
    )
    assert columns[wk.TF_STATIC]["Transform3D:child_frame"] == [["limb"]]


def _node_modules() -> Path:
    """Foxglove's packages, as `tests/foxglove/package-lock.json` pins them, installed once
    per lock file in the user's cache (`npm ci`)."""
    lock = (FOXGLOVE / "package-lock.json").read_bytes()
    home = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    folder = home / "dresslog-tests" / f"foxglove-{hashlib.sha256(lock).hexdigest()[:12]}"
    if not (folder / "node_modules" / ".package-lock.json").is_file():
        folder.mkdir(parents=True, exist_ok=True)
        for name in ("package.json", "package-lock.json"):
            shutil.copy(FOXGLOVE / name, folder / name)
        subprocess.run(
            ["npm", "ci", "--ignore-scripts", "--no-audit", "--no-fund"],
            cwd=folder, check=True, capture_output=True, timeout=600,
        )  # fmt: skip
    for script in ("decode.mjs", "script.mjs", "rosmsg.mjs"):
        shutil.copy(FOXGLOVE / script, folder / script)
    return folder


NEEDS_NODE = pytest.mark.skipif(
    not (shutil.which("node") and shutil.which("npm")), reason="needs Node"
)


@NEEDS_NODE
def test_foxglove_decoders_read_every_channel(trial: Path) -> None:
    """@mcap/core reads the file and @foxglove/rosmsg2-serialization decodes every message
    of every channel from the schema text in the file, with no bytes left over."""
    from mcap.reader import make_reader

    folder = _node_modules()
    run = subprocess.run(
        ["node", "decode.mjs", str(trial)], cwd=folder, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr
    decoded = json.loads(run.stdout)
    with trial.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None
    counts = summary.statistics.channel_message_counts
    expected = {c.topic: counts[cid] for cid, c in summary.channels.items()}
    assert {t: d["count"] for t, d in decoded.items()} == expected
    assert set(wk.DRAWN) <= set(decoded)
    with TrialReader(trial) as reader:
        estimate, limb = reader.estimate, reader.limb_points.points
    cloud = decoded[wk.ESTIMATE_CLOUD]["last"]
    assert cloud["fields"] == ["x", "y", "z", "force"] and cloud["width"] == len(limb)
    points = np.array(cloud["points"], np.float32).reshape(-1, 4)
    np.testing.assert_array_equal(points[:, :3], limb.astype(np.float32))
    _on_grid(points[:, 3], estimate.forces[_drawn_steps(estimate.t_ns)[-1]], FORCE_STEP)
    assert decoded[wk.LIMB_MARKER]["last"][0]["type"] == 7  # SPHERE_LIST
    with TrialReader(trial) as reader:
        garment = reader.garment
    mesh = decoded[wk.GARMENT_SCENE]["last"]
    assert mesh == [{"id": "garment", "frame": "world", "triangles": [
        {"points": len(garment.vertices[0]), "indices": garment.triangles.size}]}]  # fmt: skip
    cloud = decoded[wk.GARMENT_CLOUD]["last"]
    assert cloud["fields"] == ["x", "y", "z"] and cloud["width"] == len(garment.vertices[0])
    last = garment.vertices[_drawn_steps(garment.t_ns, MESH_PERIOD_NS)[-1]]
    _on_grid(np.array(cloud["points"]).reshape(-1, 3), last, POSITION_STEP)
    last = decoded[wk.TF]["last"]  # the last poses, two frames each
    assert [t[:2] for t in last] == [["world", "gripper"], ["world", "ee"]] * (len(last) // 2)


@NEEDS_NODE
def test_our_foxglove_msgs_are_foxgloves_own_definitions() -> None:
    """schemas/foxglove_msgs (the garment's SceneUpdate and what it holds) has the fields,
    types and constants of the ROS 2 definitions Foxglove's @foxglove/schemas generates
    its foxglove_msgs package from: the names Foxglove's 3D panel reads."""
    from rosbags.typesys import get_types_from_msg

    from dresslog.io import msgdefs

    ours = [n for n in [wk.DRAWN[wk.GARMENT_SCENE], *msgdefs.dependencies(wk.DRAWN[
        wk.GARMENT_SCENE])] if n.startswith("foxglove_msgs/")]  # fmt: skip
    assert len(ours) == 13
    short = [n.rsplit("/", 1)[1] for n in ours]
    run = subprocess.run(
        ["node", "rosmsg.mjs", *short], cwd=_node_modules(), capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    theirs = json.loads(run.stdout)
    for name, type_ in zip(ours, short, strict=True):
        want = get_types_from_msg(theirs[type_], name)[name]
        assert get_types_from_msg(msgdefs.msg_text(name), name)[name] == want, name


def test_the_foxglove_layout_draws_our_channels_on_one_force_scale() -> None:
    """The shipped layout names only channels a trial has, colours truth and estimate by
    `force` on one fixed scale, and plots the wrench, the twist and the total force."""
    from dresslog.replay.foxglove import layout

    panels = layout()["configById"]
    clouds = {}
    for panel in (p for name, p in panels.items() if name.startswith("3D!")):
        assert set(panel["topics"]) <= set(wk.DRAWN)
        for topic, settings in panel["topics"].items():
            if topic in (wk.FORCE_CLOUD, wk.ESTIMATE_CLOUD):
                assert settings["colorField"] == "force"
                clouds[topic] = (settings["minValue"], settings["maxValue"], settings["colorMap"])
    assert set(clouds) == {wk.FORCE_CLOUD, wk.ESTIMATE_CLOUD} and len(set(clouds.values())) == 1
    plotted = [s["value"] for n, p in panels.items() if n.startswith("Plot!") for s in p["paths"]]
    assert {v.split(".")[0] for v in plotted} == {wk.WRENCH, wk.TWIST, "/studio_script/total_force"}
    script = layout()["userNodes"]["dresslog-total-force"]["sourceCode"]
    assert f'"{wk.FORCE_MAP}"' in script and f'"{wk.ESTIMATE}"' in script


@NEEDS_NODE
def test_the_layouts_total_force_script_sums_each_map_as_foxglove_runs_it(
    trial: Path, tmp_path: Path
) -> None:
    """The layout's user script, transpiled by TypeScript and fed the trial's maps in turn,
    publishes the total of the truth and of the estimate that the Rerun view plots."""
    from dresslog.replay.foxglove import LAYOUT_FILE

    with TrialReader(trial) as reader:
        truth, estimate = reader.force_map, reader.estimate
    steps = range(100, 140)
    events = []
    for i in steps:
        for topic, maps in ((wk.FORCE_MAP, truth), (wk.ESTIMATE, estimate)):
            sec, nanosec = divmod(int(maps.t_ns[i]), 10**9)
            header = {"stamp": {"sec": sec, "nanosec": nanosec}}
            message = {"header": header, "forces": maps.forces[i].tolist()}
            events.append({"topic": topic, "message": message})
    (tmp_path / "events.json").write_text(json.dumps(events))
    layout = Path(__file__).parents[1] / "dresslog" / "replay" / LAYOUT_FILE
    run = subprocess.run(
        ["node", "script.mjs", str(layout), str(tmp_path / "events.json")],
        cwd=_node_modules(), capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    (script,) = json.loads(run.stdout).values()
    assert script["inputs"] == [wk.FORCE_MAP, wk.ESTIMATE]
    assert script["output"] == "/studio_script/total_force"
    both = script["results"][1::2]  # after each step's second map: both sums are that step's
    sums = np.array([[r["truth"], r["estimate"]] for r in both])
    expected = [[truth.forces[i].sum(), estimate.forces[i].sum()] for i in steps]
    np.testing.assert_allclose(sums, expected, rtol=1e-5)
    assert sums[:, 0].max() > 1  # the gown presses on the arm by then
    sec, nsec = divmod(int(truth.t_ns[100]), 10**9)
    assert both[0]["header"]["stamp"] == {"sec": sec, "nsec": nsec}


def test_the_layout_is_written_out_of_the_package(tmp_path: Path) -> None:
    import sys

    out = tmp_path / "layout.json"
    subprocess.run([sys.executable, "-m", "dresslog.replay.foxglove", str(out)], check=True)
    assert json.loads(out.read_text())["layout"]["first"]["first"] == "3D!truth"


def test_a_converted_log_carries_its_frames_and_its_estimate_copy_the_heat_map(
    tmp_path: Path,
) -> None:
    """`convert` writes the frames and the path from the robot's pose; the limb, and with it
    the clouds, come with `infer --mcap-out`, on the nominal limb the estimate is drawn on."""
    from dresslog.io.reader import summary_counts

    robot = SAMPLES / "robot"
    args = ["convert", str(robot / "ft.csv"), "--motion", str(robot / "pose.csv")]
    args += ["-o", str(tmp_path / "t.mcap"), "--task", "gown", "--wrench-frame", "pose"]
    args += ["--tare", "0.5", "--rotate", "0", "0", "-0.7071068", "0.7071068"]
    result = CliRunner().invoke(main, [*args, "--translate", "0.1", "0.6", "-0.25"])
    assert result.exit_code == 0, result.output
    converted = summary_counts(tmp_path / "t.mcap") or {}
    with TrialReader(tmp_path / "t.mcap") as reader:
        poses = reader.pose.t_ns
    assert converted[wk.TF] == len(_drawn_steps(poses)) and converted[wk.PATH_MARKER] == 1
    assert wk.FORCE_CLOUD not in converted and wk.LIMB_MARKER not in converted  # no limb
    args = ["infer", str(tmp_path / "t.mcap"), "-o", str(tmp_path / "t.rrd")]
    result = CliRunner().invoke(main, [*args, "--mcap-out", str(tmp_path / "e.mcap")])
    assert result.exit_code == 0, result.output
    copied = summary_counts(tmp_path / "e.mcap") or {}
    with TrialReader(tmp_path / "e.mcap") as reader:
        steps = len(_drawn_steps(reader.estimate.t_ns))
    assert copied[wk.ESTIMATE_CLOUD] == steps and copied[wk.LIMB_MARKER] == 1
    assert copied[wk.TF] == converted[wk.TF]
