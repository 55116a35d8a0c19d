"""The Rerun recording, read back with Rerun's own reader: entities, steps, values, layout."""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.errors import DresslogWarning
from dresslog.io.reader import read_trial
from dresslog.model import load_model
from dresslog.replay import blueprint as bp
from dresslog.replay.engine import run, trial_context, trial_steps
from dresslog.spec import Task
from tests.replay.conftest import STEPS, save_random_model

rc = pytest.importorskip("rerun.chunk")


def temporal(rrd: Path) -> dict[str, list]:
    """Entity path (no leading slash) -> its non-static chunks as Arrow record batches."""
    out: dict[str, list] = {}
    for chunk in rc.RrdReader(rrd).store().stream():
        if not chunk.is_static:
            out.setdefault(chunk.entity_path.lstrip("/"), []).append(chunk.to_record_batch())
    return out


def column(batches: list, name: str) -> list:
    return [v for batch in batches for v in batch.column(name).to_pylist()]


def static_paths(rrd: Path) -> set[str]:
    return {c.entity_path.lstrip("/") for c in rc.RrdReader(rrd).store().stream() if c.is_static}


def spec_text(rrd: Path) -> str:
    """The trial panel's markdown, as the viewer shows it: the version logged last (a live
    view sends it again at the end), by row id, not by where the store lists its chunk."""
    texts = []
    for chunk in rc.RrdReader(rrd).store().stream():
        if chunk.is_static and chunk.entity_path.lstrip("/") == bp.SPEC:
            batch = chunk.to_record_batch()
            row_id = batch.column("rerun.controls.RowId").to_pylist()[-1]
            texts.append((row_id, batch.column("TextDocument:text").to_pylist()[-1][0]))
    assert texts, "no trial panel"
    return max(texts)[1]


def view_names(rrd: Path) -> set[str]:
    """The names of the views in the recording's default blueprint."""
    reader = rc.RrdReader(rrd)
    names: set[str] = set()
    for chunk in reader.store(store=reader.blueprints()[0]).stream():
        batch = chunk.to_record_batch()
        for field in batch.schema.names:
            if field.endswith(":display_name"):
                names.update(n for row in batch.column(field).to_pylist() for n in row or [])
    return names


def view_queries(rrd: Path) -> list[list[str]]:
    """Each view's contents (its entity queries) in the recording's default blueprint."""
    reader = rc.RrdReader(rrd)
    queries = []
    for chunk in reader.store(store=reader.blueprints()[0]).stream():
        batch = chunk.to_record_batch()
        if "ViewContents:query" in batch.schema.names:
            queries += batch.column("ViewContents:query").to_pylist()
    return queries


def colour_key(rrd: Path) -> tuple[np.ndarray, list[str]]:
    """The force maps' colour key: its swatches' RGB and its labels, as logged."""
    logged = {}
    for chunk in rc.RrdReader(rrd).store().stream():
        if chunk.entity_path.lstrip("/") in (bp.LEGEND, bp.LEGEND_LABELS):
            logged[chunk.entity_path.lstrip("/")] = chunk.to_record_batch()
    rgba = np.array(logged[bp.LEGEND].column("Points3D:colors").to_pylist()[-1], np.uint32)
    rgb = np.stack([(rgba >> shift) & 255 for shift in (24, 16, 8)], axis=1)
    return rgb, logged[bp.LEGEND_LABELS].column("Points3D:labels").to_pylist()[-1]


def time_panel(rrd: Path) -> dict[str, object]:
    """The time panel's settings in the recording's default blueprint, by field name."""
    reader = rc.RrdReader(rrd)
    fields: dict[str, object] = {}
    for chunk in reader.store(store=reader.blueprints()[0]).stream():
        if chunk.entity_path.lstrip("/") == "time_panel":
            batch = chunk.to_record_batch()
            for name in batch.schema.names:
                if name.startswith("TimePanelBlueprint:"):
                    fields[name.split(":")[1]] = batch.column(name).to_pylist()[-1][0]
    return fields


@pytest.fixture
def inferred(make_trial, tmp_path: Path) -> tuple[Path, Path, Path]:
    trial, _ = make_trial(Task.GOWN, STEPS)
    model = save_random_model(tmp_path)
    rrd = tmp_path / "trial.rrd"
    result = CliRunner().invoke(main, ["infer", str(trial), "-m", str(model), "-o", str(rrd)])
    assert result.exit_code == 0, result.output
    return trial, model, rrd


def test_recording_has_every_entity_for_every_step(inferred) -> None:
    _, _, rrd = inferred
    entities = temporal(rrd)
    per_step = [
        bp.TRUTH_LIMB, bp.ESTIMATE_LIMB, bp.EE, bp.CONTACTS, bp.CONTACT_FORCES, bp.EE_FORCE,
        bp.EE_TORQUE, bp.EE_VELOCITY, bp.TOTAL_TRUTH, bp.TOTAL_ESTIMATE, bp.RMSE,
        bp.EE_FORCE_ARROW,
    ]  # fmt: skip
    for path in per_step:
        assert column(entities[path], bp.STEP) == list(range(STEPS)), path
    assert column(entities[bp.GARMENT], bp.STEP) == list(range(0, STEPS, 10))
    seconds = column(entities[bp.EE_FORCE], bp.TIME)
    assert (seconds[1] - seconds[0]).total_seconds() == pytest.approx(0.01)
    assert bp.TIMESTAMP not in entities[bp.EE_FORCE][0].schema.names  # simulated: no wall clock
    assert {bp.SPEC, bp.EE, bp.EE_PATH, bp.GARMENT} <= static_paths(rrd)
    text = spec_text(rrd)
    assert f"outcome {read_trial(inferred[0]).metadata.outcome.value}: seed " in text
    # which model made the estimate, and how it did on this trial
    assert f"Estimate by model {inferred[1]} (3x50 LSTM)." in text
    assert re.search(r"Trial RMSE [0-9.e-]+ N against [0-9.e-]+ N for an all-zero", text)
    # the scale tops out at the truth's 99.5th percentile: brighter points are not "at most"
    assert re.search(r"dark to bright = 0 to [0-9.e-]+ N and over \(one scale", text)
    names = view_names(rrd)
    assert {"Force map: ground truth", "Force map: estimate", "RMSE per step (N)"} <= names
    # one application per task: a viewer keeps one layout per application, and a shorts
    # trial opened beside a gown one took the arm's layout
    (entry,) = rc.RrdReader(rrd).recordings()
    assert entry.application_id == "dresslog-gown"


def test_the_grippers_measured_force_is_an_arrow_at_the_gripper_in_both_maps(inferred) -> None:
    """From the gripper's position along the measured force (world axes), longer for a
    stronger pull but never past 15 cm."""
    trial = read_trial(inferred[0])
    arrows = temporal(inferred[2])[bp.EE_FORCE_ARROW]
    origins = np.array([row[0] for row in column(arrows, "Arrows3D:origins")])
    vectors = np.array([row[0] for row in column(arrows, "Arrows3D:vectors")])
    assert trial.pose is not None
    np.testing.assert_allclose(origins, trial.pose.values[:, :3], atol=1e-6)
    force = trial.measurements.phi[:, :3]
    moving = np.linalg.norm(force, axis=1) > 1e-3
    along = np.sum(vectors * force, axis=1) / (
        np.linalg.norm(vectors, axis=1) * np.linalg.norm(force, axis=1) + 1e-12
    )
    assert np.all(along[moving] > 0.999)
    lengths = np.linalg.norm(vectors, axis=1)
    strength = np.linalg.norm(force, axis=1)
    assert np.all(lengths < 0.15) and np.all(np.diff(lengths[np.argsort(strength)]) >= -1e-6)
    maps = [q for q in view_queries(inferred[2]) if f"+ /{bp.EE}/**" in q]
    assert len(maps) == 2 and all(f"+ /{bp.EE_FORCE_ARROW}" in q for q in maps)


def test_a_recording_opens_playing_from_its_first_step_in_real_time(inferred) -> None:
    """Read from a stream (a browser's `view --web`), the viewer left to itself opens at the
    last step; told to play, it starts at the first, as it does a file it reads itself."""
    import rerun.blueprint as rrb

    panel = time_panel(inferred[2])
    assert panel["timeline"] == bp.TIME  # seconds: playback speed 1 is the trial's own
    assert panel["play_state"] == rrb.components.PlayState.Playing.value
    assert panel["playback_speed"] == 1.0
    assert "loop_mode" not in panel  # off: once through, then it stops at the last step


def test_every_plots_legend_sits_top_left_where_a_trial_starting_from_rest_leaves_room(
    inferred,
) -> None:
    """Bottom left, the viewer's default, hid the gripper's steady -x speed and each
    total's zero line over the first 0.4 s."""
    import rerun.blueprint as rrb

    reader = rc.RrdReader(inferred[2])
    corners = []
    for chunk in reader.store(store=reader.blueprints()[0]).stream():
        batch = chunk.to_record_batch()
        if "PlotLegend:corner" in batch.schema.names:
            corners += [row[0] for row in batch.column("PlotLegend:corner").to_pylist()]
    # force, torque, velocity; total force, RMSE
    assert corners == [rrb.components.Corner2D.LeftTop.value] * 5


def test_each_force_map_has_its_colour_key_in_the_trials_scale(inferred) -> None:
    """Under the limb in both maps: grey for no force, then the ramp to the top of the scale
    the note gives, each swatch the colour a limb point of that force gets."""
    from dresslog.replay.colors import color_scale, heat_colors

    trial, _, rrd = inferred
    vmax = color_scale(read_trial(trial).force_map.forces)  # fitted to the truth
    assert f"dark to bright = 0 to {vmax:.3g} N and over" in spec_text(rrd)
    rgb, labels = colour_key(rrd)
    assert labels[0] == "0 N" and labels[-1] == f"{vmax:.3g} N +"
    middle = [float(label) for label in labels[2:-1]]
    assert middle == pytest.approx([vmax / 4, vmax / 2, 3 * vmax / 4], rel=0.05)
    forces = np.array([0.0, 1e-6 * vmax, *middle, vmax])
    np.testing.assert_array_equal(rgb, heat_colors(forces, vmax))
    maps = [q for q in view_queries(rrd) if any(bp.ESTIMATE in e or bp.TRUTH in e for e in q)]
    assert len(maps) == 2 and all(f"+ /{bp.LEGEND}/**" in q for q in maps)


def _bearings(camera, points: np.ndarray) -> np.ndarray:
    """Degrees left (-) or right (+) of the camera's axis at which it sees each point."""
    position, target = (np.array(c.as_arrow_array().to_pylist()[0]) for c in
                        (camera.position, camera.look_target))  # fmt: skip
    ahead = (target - position) / np.linalg.norm(target - position)
    right = np.cross(ahead, [0, 0, 1])
    rays = points - position
    return np.degrees(np.arctan2(rays @ right / np.linalg.norm(right), rays @ ahead))


@pytest.mark.parametrize(
    ("alone", "across", "edge"), [(False, 90, 57), (True, 55, 37)], ids=["stacked", "alone"]
)
def test_the_legs_view_shows_the_leg_across_most_of_its_width(
    alone: bool, across: int, edge: int
) -> None:
    """A stacked map is over three times as wide as tall: about 120 degrees across at the
    viewer's 55 degrees tall; a map alone (no truth, or no model) about 80. The leg had 80
    and 42 of them (half the view, the rest empty floor); it has over `across`, and the
    gripper's start beyond the foot stays within `edge` degrees of the view's middle."""
    from dresslog.limb import build_limb, limb_points

    leg = limb_points(build_limb(Task.SHORTS)).points
    camera = bp.eye(leg, alone=alone)
    bearings = _bearings(camera, leg)
    assert bearings.max() - bearings.min() > across
    (gripper,) = _bearings(camera, np.array([[1.12, 0.0, 0.19]]))  # README: where it starts
    assert abs(gripper) < edge


def test_logged_estimate_equals_the_engines_output(inferred) -> None:
    trial_path, model_path, rrd = inferred
    trial = read_trial(trial_path)
    results = run(trial_context(trial), trial_steps(trial), load_model(model_path).estimator())
    entities = temporal(rrd)
    logged = np.array(column(entities[bp.ESTIMATE_LIMB], bp.FORCE_FIELD), dtype=np.float32)
    engine = np.stack([r.estimate for r in results])
    np.testing.assert_array_equal(logged, engine)
    truth = np.array(column(entities[bp.TRUTH_LIMB], bp.FORCE_FIELD), dtype=np.float32)
    np.testing.assert_array_equal(truth, trial.force_map.forces)
    rmse = np.array(column(entities[bp.RMSE], "Scalars:scalars")).ravel()
    np.testing.assert_allclose(rmse, [r.rmse for r in results], rtol=1e-12)
    total = np.array(column(entities[bp.TOTAL_ESTIMATE], "Scalars:scalars")).ravel()
    np.testing.assert_allclose(total, engine.sum(axis=1), rtol=1e-5)


def test_rerun_verifies_the_recording(inferred) -> None:
    _, _, rrd = inferred
    check = subprocess.run(
        [sys.executable, "-m", "rerun", "rrd", "verify", str(rrd)], capture_output=True, text=True
    )
    assert check.returncode == 0, check.stderr[-2000:]


def test_view_save_without_a_model_shows_ground_truth_alone(make_trial, tmp_path, monkeypatch):
    monkeypatch.setattr("dresslog.model.bundled.bundled_model", lambda task: None)
    trial, _ = make_trial(Task.GOWN, 12)
    rrd = tmp_path / "view.rrd"
    result = CliRunner().invoke(main, ["view", str(trial), "--save", str(rrd)])
    assert result.exit_code == 0, result.output
    assert "ground truth only" in result.output
    entities = temporal(rrd)
    assert bp.TRUTH_LIMB in entities and bp.ESTIMATE_LIMB not in entities
    # the one map says why no estimate is beside it, as a log's estimate says it has no truth
    assert "Force map: ground truth (no estimate: no model for this trial)" in view_names(rrd)


def test_view_of_a_converted_log_without_any_model_asks_for_one(tmp_path, monkeypatch):
    monkeypatch.setattr("dresslog.model.bundled.bundled_model", lambda task: None)
    log = _converted_log(tmp_path)
    rrd = tmp_path / "view.rrd"
    result = CliRunner().invoke(main, ["view", str(log), "--save", str(rrd)])
    assert result.exit_code == 1
    assert "no bundled gown model" in result.output and "--model" in result.output
    assert not rrd.exists()


def test_view_save_copies_an_rrd(inferred, tmp_path: Path) -> None:
    _, _, rrd = inferred
    out = tmp_path / "copy.rrd"
    result = CliRunner().invoke(main, ["view", str(rrd), "--save", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_bytes() == rrd.read_bytes()


@pytest.mark.parametrize("keep", [0.5, 0.001])  # cut mid-file, or inside the first message
def test_view_save_refuses_to_copy_a_cut_rrd(inferred, tmp_path: Path, keep: float) -> None:
    _, _, rrd = inferred
    data = rrd.read_bytes()
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(data[: int(len(data) * keep)])
    out = tmp_path / "copy.rrd"
    out.write_bytes(b"earlier")
    result = CliRunner().invoke(main, ["view", str(cut), "--save", str(out), "--overwrite"])
    assert result.exit_code == 1 and "cut short or damaged" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1
    assert out.read_bytes() == b"earlier"


def test_view_save_checks_with_rerun_itself_whatever_the_folder_or_name(
    inferred, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`python -m rerun` ran a `rerun.py` of the working folder (which could pass a cut
    recording), and a name starting with `-` was taken for an option."""
    _, _, rrd = inferred
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rerun.py").write_text('print("1 file verified without error")\n')
    named = tmp_path / "-x.rrd"
    named.write_bytes(rrd.read_bytes())
    result = CliRunner().invoke(main, ["view", "./-x.rrd", "--save", "copy.rrd"])
    assert result.exit_code == 0 and (tmp_path / "copy.rrd").read_bytes() == rrd.read_bytes()
    named.write_bytes(rrd.read_bytes()[: rrd.stat().st_size // 2])
    result = CliRunner().invoke(main, ["view", "./-x.rrd", "--save", "cut.rrd"])
    assert result.exit_code == 1 and "cut short or damaged" in result.output, result.output


def test_view_refuses_a_file_that_is_not_a_rerun_recording(tmp_path: Path) -> None:
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"junk\n")
    out = tmp_path / "copy.rrd"
    result = CliRunner().invoke(main, ["view", str(junk), "--save", str(out)])
    assert result.exit_code == 1 and "not a Rerun recording" in result.output
    assert not out.exists()


def test_view_knows_a_recording_by_its_bytes_and_refuses_a_model_for_it(
    inferred, tmp_path: Path
) -> None:
    _, model, rrd = inferred
    renamed = tmp_path / "recording.bin"
    renamed.write_bytes(rrd.read_bytes())
    out = tmp_path / "copy.rrd"
    result = CliRunner().invoke(main, ["view", str(renamed), "--save", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_bytes() == rrd.read_bytes()
    for shown, save in [(rrd, ["--save", str(out)]), (renamed, []), (rrd, [])]:
        again = CliRunner().invoke(main, ["view", str(shown), "-m", str(model), *save])
        assert again.exit_code == 2 and again.output.startswith("Usage:"), again.output
        assert again.output.splitlines()[-1] == (
            f"Error: {shown}: is a Rerun recording, which already holds its estimates; "
            "--model applies only to an MCAP trial"
        )
    assert out.read_bytes() == rrd.read_bytes()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="X11/Wayland are Linux's")
def test_view_without_a_display_says_so_before_any_work(
    inferred, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(name, raising=False)
    trial, model, _ = inferred
    result = CliRunner().invoke(main, ["view", str(trial), "-m", str(model)])
    assert result.exit_code == 1 and "RMSE" not in result.output  # nothing inferred first
    assert result.output.startswith(f"Error: {trial}: the Rerun viewer needs a display")
    assert "--web" in result.output and "--save" in result.output
    folder = trial.parent  # a typo or a folder is named first: no display would not cure it
    result = CliRunner().invoke(main, ["view", str(folder)])
    assert result.exit_code == 1
    assert result.output == (
        f"Error: {folder}: is a folder; view opens one trial or recording, such as {trial}\n"
    )
    result = CliRunner().invoke(main, ["view", str(folder / "typo.mcap")])
    assert result.output == f"Error: {folder / 'typo.mcap'}: no such file\n"
    notes = tmp_path / "notes.md"  # a file of another kind, too
    notes.write_text("# day 1\n")
    result = CliRunner().invoke(main, ["view", str(notes)])
    assert result.exit_code == 1 and result.output.startswith(f"Error: {notes}: not an MCAP file")


@pytest.mark.parametrize(
    "options",
    [["--port", "9000"], ["--web", "--port", "-5"], ["--web", "--save", "x.rrd"],
     ["--grpc-port", "9000"], ["--overwrite"]],
    ids=["port-without-web", "port-out-of-range", "web-save", "grpc-port-without-web",
         "overwrite-without-save"],
)  # fmt: skip
def test_view_options_that_cannot_go_together_are_a_usage_error(
    inferred, options: list[str]
) -> None:
    _, _, rrd = inferred
    result = CliRunner().invoke(main, ["view", str(rrd), *options])
    assert result.exit_code == 2 and "Usage:" in result.output


def _software_vulkan() -> bool:
    return any(Path("/usr/share/vulkan/icd.d").glob("lvp_icd*.json"))


@pytest.mark.slow
@pytest.mark.skipif(not _software_vulkan(), reason="needs Mesa's software Vulkan (lavapipe)")
def test_default_layout_renders_headless(inferred, tmp_path: Path) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
    from screenshot import capture

    _, _, rrd = inferred
    png = tmp_path / "shot.png"
    capture(rrd, png, step=20, port=9871, settle=1.0)
    import matplotlib.image

    image = matplotlib.image.imread(png)[..., :3]
    h, w, _ = image.shape
    # the default layout: the limbs on a light 3D view at the left, the plots dark at the right
    assert image[h // 10 : h * 8 // 10, w // 50 : w * 55 // 100].mean() > 0.6
    assert image[h // 10 : h * 8 // 10, w * 62 // 100 :].mean() < 0.35


@pytest.mark.slow
@pytest.mark.skipif(not _software_vulkan(), reason="needs Mesa's software Vulkan (lavapipe)")
def test_every_plot_has_room_for_the_viewer_to_label_its_axes(inferred, tmp_path: Path) -> None:
    """In the 1920x1080 window, each plot is wide enough for the viewer to label a 7 s
    trial's time axis each second, and the force tall enough to label the sample's 14 N of
    range each newton (at 380 by 220 and 760 by 300 pixels it had shown "+0s" and "0"
    only); the force maps keep their size."""
    import socket
    import time

    import matplotlib.image
    from rerun.experimental import ViewerClient

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    viewer = ViewerClient.spawn(headless=True, port=port)
    sizes: dict[str, tuple[int, int]] = {}
    plots = []
    try:
        viewer.open(str(inferred[2]))
        time.sleep(1.0)
        for view in viewer.get_state().views:
            png = tmp_path / "view.png"
            viewer.save_screenshot(str(png), view_id=view.view_id)
            h, w = matplotlib.image.imread(png).shape[:2]
            sizes[view.name] = (w, h)
            if view.view_class == "TimeSeries":
                plots.append(view.name)
    finally:
        viewer.quit()
    assert len(plots) == 5, sizes
    for name in plots:
        assert sizes[name][0] >= 600, (name, sizes[name])
    assert sizes["End-effector force (N)"][1] >= 340, sizes
    for name in ("Force map: ground truth", "Force map: estimate"):
        assert sizes[name][0] >= 560 and sizes[name][1] >= 700, (name, sizes[name])


@pytest.mark.slow
def test_record_live_streams_the_simulation_through_the_engine(tmp_path: Path) -> None:
    import rerun as rr

    from dresslog.replay.live import record_live
    from dresslog.sim import random_spec

    model = save_random_model(tmp_path)
    rrd = tmp_path / "live.rrd"
    rec = rr.RecordingStream("dresslog-test")
    rec.save(rrd)
    spec = random_spec(Task.GOWN, 3, duration=0.25)
    result, metrics = record_live(spec, tmp_path / "live.mcap", model=model, recording=rec)
    rec.flush()
    rec.disconnect()
    assert metrics.steps == result.steps == 25
    assert metrics.rmse is not None
    entities = temporal(rrd)
    assert column(entities[bp.ESTIMATE_LIMB], bp.STEP) == list(range(25))
    assert len(column(entities[bp.GARMENT], bp.STEP)) >= 2
    assert read_trial(tmp_path / "live.mcap").force_map.forces.shape == (25, 300)
    # the note, sent again as the trial ends, gives its RMSE and leaves out the outcome,
    # which the simulation decides after the last step (`record` prints it)
    text = spec_text(rrd)
    assert f"Trial RMSE {metrics.rmse:.4g} N" in text and '"outcome"' not in text
    # a live view follows the newest step, as the viewer does unless told otherwise
    assert "play_state" not in time_panel(rrd)


def test_record_live_warns_of_a_trial_the_model_was_not_trained_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`record --live --speed 0.25` shows the bundled model's estimate of a trial faster
    than any it was trained on: said before the simulation starts, as `infer` says it."""
    import rerun as rr

    from dresslog.model.bundled import MODELS_ENV
    from dresslog.replay.live import record_live
    from dresslog.sim import random_spec

    monkeypatch.delenv(MODELS_ENV, raising=False)

    rec = rr.RecordingStream("dresslog-test")
    rec.save(tmp_path / "live.rrd")
    trial = tmp_path / "fast.mcap"
    spec = random_spec(Task.GOWN, 3, duration=0.05, speed=0.25)
    with pytest.warns(DresslogWarning) as caught:
        record_live(spec, trial, recording=rec)
    rec.disconnect()
    assert [str(w.message) for w in caught] == [
        f"{trial}: outside the model's training (speeds 0.1-0.15 m/s, the limb never turned): "
        "speed 0.25 m/s, so the estimate measures how it generalises"
    ]


#: 2024-12-03, in ns: a converted log's first stamp on the wall clock.
LOG_START_NS = 1_733_234_567_000_000_000


def _converted_log(tmp_path: Path, steps: int = 15) -> Path:
    """A gown trial as `convert` makes it: `steps` of wrench and twist, no ground truth."""
    from dresslog.io.writer import TrialWriter
    from dresslog.spec import TrialMetadata

    t_ns = np.arange(steps, dtype=np.int64) * 10_000_000
    log = tmp_path / f"converted-{steps}.mcap" if steps != 15 else tmp_path / "converted.mcap"
    # the log's own clock was the wall clock
    source = {"file": "/robot/logs/ft.csv", "start_ns": LOG_START_NS}
    with TrialWriter(log, TrialMetadata(task=Task.GOWN, source=source)) as writer:
        writer.write_wrench(t_ns, np.random.default_rng(0).normal(size=(steps, 6)))
        writer.write_twist(t_ns, np.random.default_rng(1).normal(size=(steps, 6)))
    return log


def _replay_peak(log: Path, **outputs: Any) -> int:
    """`replay_file(log, **outputs)`'s peak of Python-allocated memory, bytes."""
    import tracemalloc

    from dresslog.replay.pipeline import replay_file

    tracemalloc.start()
    try:
        replay_file(log, **outputs)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_long_log_is_recorded_in_memory_that_does_not_grow_with_its_length(
    tmp_path: Path,
) -> None:
    """A 30-minute log held whole until the outputs closed took 3.5 GB: the steps go
    out as they come, so four times the steps take about the memory of one part."""
    model = save_random_model(tmp_path)
    peaks = []
    for steps in (1000, 4000):
        log = _converted_log(tmp_path, steps)
        rrd, copy = tmp_path / f"{steps}.rrd", tmp_path / f"estimate-{steps}.mcap"
        peaks.append(_replay_peak(log, model=model, rrd=rrd, mcap=copy))
        assert len(column(temporal(rrd)[bp.ESTIMATE_LIMB], bp.STEP)) == steps
        estimate = read_trial(copy).estimate
        assert estimate is not None and len(estimate.t_ns) == steps
    assert peaks[1] < 1.5 * peaks[0], [f"{p / 1e6:.1f} MB" for p in peaks]


def test_a_converted_log_is_drawn_on_the_tasks_nominal_limb(tmp_path: Path) -> None:
    from dresslog.replay.pipeline import replay_file

    log = _converted_log(tmp_path)
    rrd = tmp_path / "converted.rrd"
    report = replay_file(log, model=save_random_model(tmp_path), rrd=rrd)
    assert report.steps == 15 and report.rmse is None
    entities = temporal(rrd)
    assert len(column(entities[bp.ESTIMATE_LIMB], bp.FORCE_FIELD)[0]) == 300
    # no ground-truth limb at all (not even a grey one), and a layout that says so
    assert bp.TRUTH_LIMB not in entities and bp.TRUTH_LIMB not in static_paths(rrd)
    names = view_names(rrd)
    assert "Force map: estimate (the trial has no ground truth)" in names
    assert "RMSE per step (N)" not in names and "Force map: ground truth" not in names
    # nothing that needs a pose or a truth: no gripper axes at the origin, no empty series
    assert not {bp.EE, bp.TOTAL_TRUTH, bp.RMSE} & static_paths(rrd)
    # the log's wall-clock time beside the time since its start, to line up other recordings
    stamps = np.array(column(entities[bp.EE_FORCE], bp.TIMESTAMP), dtype="datetime64[ns]")
    assert stamps.astype(np.int64).tolist() == [LOG_START_NS + 10_000_000 * i for i in range(15)]
    # a fixed colour scale, not one stretched to a weak estimate; the limb said to be nominal
    text = spec_text(rrd)
    assert "the task's nominal limb" in text and "0 to 0.5 N and over." in text
    # what it was converted from; no outcome, spec or failure reason it cannot have
    assert "trial from `converted.mcap`, converted from `ft.csv`." in text
    absent = ('"outcome"', '"spec"', '"failure_reason"', "null")
    assert not [word for word in absent if word in text]
    assert colour_key(rrd)[1][-1] == "0.5 N +"


def _camera(rrd: Path) -> tuple[np.ndarray, np.ndarray]:
    """The force map's camera in the recording's default blueprint: position, look target."""
    reader = rc.RrdReader(rrd)
    eye = {}
    for chunk in reader.store(store=reader.blueprints()[0]).stream():
        batch = chunk.to_record_batch()
        for name in ("position", "look_target"):
            if f"EyeControls3D:{name}" in batch.schema.names:
                eye[name] = np.array(batch.column(f"EyeControls3D:{name}").to_pylist()[-1][0])
    return eye["position"], eye["look_target"]


def test_a_converted_arm_logs_map_shows_the_gripper_from_its_first_step(tmp_path: Path) -> None:
    """The robot sample's gripper hangs still 1 s at 0.62 m beyond the elbow, then nears the
    hand: the map alone (no ground truth) had it 43 degrees off its axis, beyond the 39 of
    its half width, for 1.5 s. The camera moves aside; the arm keeps its size."""
    from dresslog.io.writer import TrialWriter
    from dresslog.limb import build_limb, limb_points
    from dresslog.replay.pipeline import replay_file
    from dresslog.spec import TrialMetadata

    start = np.array([0.62, 0.0, 0.1])
    t_ns = np.arange(15, dtype=np.int64) * 10_000_000
    pose = np.tile([*start, 0.0, 0.0, 0.0, 1.0], (15, 1))
    pose[:, 0] -= np.linspace(0, 0.05, 15)
    log = tmp_path / "robot.mcap"
    with TrialWriter(log, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_wrench(t_ns, np.zeros((15, 6)))
        writer.write_twist(t_ns, np.zeros((15, 6)))
        writer.write_pose(t_ns, pose)
    rrd = tmp_path / "robot.rrd"
    replay_file(log, model=save_random_model(tmp_path), rrd=rrd)
    position, target = _camera(rrd)
    arm = limb_points(build_limb(Task.GOWN)).points

    def bearings(points: np.ndarray) -> np.ndarray:
        ahead = (target - position) / np.linalg.norm(target - position)
        right = np.cross(ahead, [0, 0, 1]) / np.linalg.norm(np.cross(ahead, [0, 0, 1]))
        rays = points - position
        return np.degrees(np.arctan2(rays @ right, rays @ ahead))

    half_width = np.degrees(np.arctan(np.tan(np.radians(27.5)) * 1.58))
    assert np.abs(bearings(np.vstack([arm, start]))).max() < half_width
    seen = bearings(arm)
    assert seen.max() - seen.min() > 44  # as wide as it was, 45 degrees


def test_a_trial_with_no_force_on_the_limb_gets_the_fixed_colour_scale(tmp_path: Path) -> None:
    """A trial cut short before the garment reaches the limb has no force to fit a scale
    to: it gets a converted log's 0.5 N, not color_scale's 1 N placeholder, which the
    note gave as though it were the trial's."""
    from dresslog.io.writer import TrialWriter
    from dresslog.limb import build_limb, limb_points
    from dresslog.replay.pipeline import replay_file
    from dresslog.spec import TrialMetadata

    limb = limb_points(build_limb(Task.GOWN))
    t_ns = np.arange(15, dtype=np.int64) * 10_000_000
    trial = tmp_path / "untouched.mcap"
    with TrialWriter(trial, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_limb_points(0, limb)
        for t in t_ns:
            writer.write_wrench(t, np.zeros(6))
            writer.write_twist(t, np.zeros(6))
            writer.write_force_map(t, np.zeros(len(limb), np.float32))
    rrd = tmp_path / "untouched.rrd"
    replay_file(trial, model=save_random_model(tmp_path), rrd=rrd)
    assert "dark to bright = 0 to 0.5 N and over (one scale" in spec_text(rrd)


def _on_the_wall_clock(trial: Path, out: Path, start_ns: int) -> Path:
    """`trial` as another tool writes one on the wall clock: its time 0 stamped `start_ns`
    and no time origin in its metadata (TrialWriter stamps time 0 as 2020-01-01)."""
    import json
    import struct

    from dresslog.io import well_known as wk
    from tests.conftest import mcap_records, write_mcap

    stamp = struct.Struct("<iI")  # a header stamp after the 4-byte encapsulation
    messages, metadata = mcap_records(trial)
    rows = []
    for schema, channel, message in messages:
        t = message.log_time - wk.TIME_ORIGIN_NS + start_ns
        data = bytearray(message.data)
        if channel.topic in wk.SCHEMAS:
            stamp.pack_into(data, 4, *divmod(t, 1_000_000_000))
        rows.append((channel.id, schema, channel.topic, t, bytes(data), t))
    records = dict(metadata)
    entry = json.loads(records[wk.METADATA_NAME]["trial"]) | {"time_origin_ns": 0}
    records[wk.METADATA_NAME] = {"task": entry["task"], "trial": json.dumps(entry)}
    return write_mcap(out, "another tool", rows, list(records.items()))


def test_a_trial_stamped_on_the_wall_clock_opens_at_zero_seconds_with_its_timestamps(
    tmp_path: Path,
) -> None:
    """`time` counts from the trial's first step whatever its stamps; stamps that are
    wall-clock times are kept on `timestamp`."""
    from dresslog.io.writer import TrialWriter
    from dresslog.replay.pipeline import replay_file
    from dresslog.spec import TrialMetadata

    steps = np.arange(15, dtype=np.int64) * 10_000_000
    ours = tmp_path / "ours.mcap"
    with TrialWriter(ours, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_wrench(steps, np.zeros((15, 6)))
        writer.write_twist(steps, np.zeros((15, 6)))
    t_ns = LOG_START_NS + steps
    log = _on_the_wall_clock(ours, tmp_path / "stamped.mcap", LOG_START_NS)
    rrd = tmp_path / "stamped.rrd"
    replay_file(log, model=save_random_model(tmp_path), rrd=rrd)
    force = temporal(rrd)[bp.EE_FORCE]
    seconds = [d.total_seconds() for d in column(force, bp.TIME)]
    assert seconds == pytest.approx([0.01 * i for i in range(15)])
    stamps = np.array(column(force, bp.TIMESTAMP), dtype="datetime64[ns]")
    assert stamps.astype(np.int64).tolist() == t_ns.tolist()


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_two_view_webs_serve_on_localhost_until_interrupted_or_terminated(inferred) -> None:
    """What the README advises without a display: `view --web` prints a URL that answers.

    A second one beside it takes other ports; Ctrl-C or a kill (a closed terminal) of
    dresslog alone stops its viewer too.
    """
    import contextlib
    import re
    import signal
    import time
    import urllib.request

    _, _, rrd = inferred
    command = [sys.executable, "-c", AS_FROM_A_TERMINAL]
    runs: list[subprocess.Popen] = []
    pages = []
    logs = [rrd.with_name(f"view{i}.log") for i in range(2)]
    env = {**os.environ, "PYTHONFAULTHANDLER": "1"}  # SIGABRT dumps where it is stuck
    try:
        for log in logs:  # the second once the first serves
            with log.open("w") as err:  # the child holds its own copy
                run = subprocess.Popen(
                    [*command, "view", str(rrd), "--web"],
                    stdout=subprocess.PIPE,
                    stderr=err,
                    text=True,
                    start_new_session=True,
                    env=env,
                )
            runs.append(run)
            assert run.stdout is not None
            line = run.stdout.readline()
            found = re.match(r"Web viewer: (http://127\.0\.0\.1:\d+/)\?url=rerun%2Bhttp", line)
            assert found, line
            pages.append(page := found.group(1))
            deadline, status = time.monotonic() + 30, None
            while status is None and time.monotonic() < deadline:
                try:
                    with urllib.request.urlopen(page, timeout=2) as reply:
                        status = reply.status
                except OSError:
                    time.sleep(0.5)
            assert status == 200, page
        assert pages[0] != pages[1]
    finally:
        stuck = []
        for run, sent, log in zip(runs, (signal.SIGINT, signal.SIGTERM), logs, strict=False):
            run.send_signal(sent)  # to dresslog alone: it must stop its viewer
            try:
                run.wait(timeout=30)
            except subprocess.TimeoutExpired:
                stuck.append(f"its {_signal_state(str(run.pid))}")
                os.kill(run.pid, signal.SIGABRT)
                run.wait(timeout=30)
                stuck.append(f"{sent.name} did not stop it:\n{log.read_text()[-4000:]}")
                stuck.append(f"pytest's {_signal_state('self')}")
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(run.pid, signal.SIGKILL)
            assert run.stdout is not None
            run.stdout.close()
        assert not stuck, "\n".join(stuck)
    assert [run.returncode for run in runs] == [1, 1]  # click's "Aborted!"
    time.sleep(1)
    for page in pages:
        with pytest.raises(OSError):  # the viewers are gone too
            urllib.request.urlopen(page, timeout=2)


@pytest.mark.skipif(sys.platform != "linux", reason="the parent-death signal is Linux's")
def test_view_web_killed_outright_takes_its_viewer_with_it(inferred) -> None:
    """A kill -9 (or the OOM killer) runs no handler of dresslog's: the kernel stops the viewer."""
    import re
    import signal
    import time
    import urllib.request

    _, _, rrd = inferred
    run = subprocess.Popen(
        [sys.executable, "-c", AS_FROM_A_TERMINAL, "view", str(rrd), "--web"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
    )
    try:
        assert run.stdout is not None
        found = re.match(r"Web viewer: (http://127\.0\.0\.1:\d+/)", run.stdout.readline())
        assert found
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            try:
                urllib.request.urlopen(found.group(1), timeout=2).close()
                break
            except OSError:
                time.sleep(0.5)
        else:
            pytest.fail("the web viewer never answered")
        run.kill()
        run.wait(timeout=10)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                urllib.request.urlopen(found.group(1), timeout=2).close()
                time.sleep(0.2)
            except OSError:
                break
        else:
            pytest.fail("the viewer went on serving after dresslog was killed")
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(run.pid, signal.SIGKILL)
        run.stdout.close()


def test_view_web_listens_on_the_ports_it_is_given(inferred) -> None:
    """Issue 50: the recording was served on a random port, which an SSH tunnel cannot
    forward. `--port` and `--grpc-port` are both listened on, and the page is pointed at the
    second (`ssh -L 9090:localhost:9090 -L 9876:localhost:9876 host`)."""
    import re
    import signal
    import time

    _, _, rrd = inferred
    web, grpc = _free_port(), _free_port()
    run = subprocess.Popen(
        [sys.executable, "-c", AS_FROM_A_TERMINAL, "view", str(rrd), "--web",
         "--web-port", str(web), "--grpc-port", str(grpc)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    try:
        assert run.stdout is not None
        line = run.stdout.readline()
        assert re.match(rf"Web viewer: http://127\.0\.0\.1:{web}/\?url=rerun%2Bhttp%3A%2F%2F"
                        rf"127\.0\.0\.1%3A{grpc}%2Fproxy ", line), line  # fmt: skip
        deadline, listening = time.monotonic() + 30, set()
        while listening != {web, grpc} and time.monotonic() < deadline:
            listening = {port for port in (web, grpc) if _answers(port)}
            time.sleep(0.3)
        assert listening == {web, grpc}
    finally:
        run.send_signal(signal.SIGINT)
        try:
            _, err = run.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(run.pid, signal.SIGKILL)
            _, err = run.communicate()
    assert "XDG_RUNTIME_DIR" not in err
    time.sleep(0.5)
    assert not _answers(web) and not _answers(grpc)  # closed with the viewer


def _answers(port: int) -> bool:
    import socket

    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
    except OSError:
        return False
    return True


def test_view_web_refuses_one_port_for_both(inferred) -> None:
    _, _, rrd = inferred
    port = str(_free_port())
    result = CliRunner().invoke(main, ["view", str(rrd), "--web", "--port", port,
                                       "--grpc-port", port])  # fmt: skip
    assert result.exit_code == 1
    assert result.output == f"Error: --port and --grpc-port are both {port}; give two ports\n"


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="XDG_RUNTIME_DIR is POSIX's")
def test_a_viewer_gets_a_private_runtime_dir_where_there_is_none(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a headless machine (no XDG_RUNTIME_DIR, or one of another user's or open to all)
    the viewer wrote `XDG_RUNTIME_DIR is invalid or not set` on the user's terminal."""
    import stat

    from dresslog.replay.viewer import viewer_env

    (private := tmp_path / "private").mkdir(mode=0o755)
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    env = viewer_env(private)
    assert env is not None and env["XDG_RUNTIME_DIR"] == str(private)
    assert stat.S_IMODE(private.stat().st_mode) == 0o700
    (open_to_all := tmp_path / "open").mkdir()
    open_to_all.chmod(0o777)
    for invalid in (tmp_path / "missing", open_to_all):
        monkeypatch.setenv("XDG_RUNTIME_DIR", str(invalid))
        env = viewer_env(private)
        assert env is not None and env["XDG_RUNTIME_DIR"] == str(private)
    (own := tmp_path / "own").mkdir(mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(own))
    assert viewer_env(private) is None  # a valid one is the viewer's as it is


def test_view_web_on_a_port_in_use_says_so_before_starting(inferred) -> None:
    import socket

    _, _, rrd = inferred
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = CliRunner().invoke(main, ["view", str(rrd), "--web", "--port", str(port)])
        assert result.exit_code == 1
        assert (
            result.output == f"Error: port {port} is in use; pass another --port or leave it out\n"
        )
        result = CliRunner().invoke(main, ["view", str(rrd), "--web", "--grpc-port", str(port)])
    assert result.exit_code == 1
    assert result.output == (
        f"Error: port {port} is in use; pass another --grpc-port or leave it out\n"
    )


@pytest.mark.skipif(not hasattr(os, "killpg"), reason="process groups are POSIX's")
@pytest.mark.parametrize("wrapped", [False, True], ids=["viewer", "viewer-under-a-wrapper"])
def test_a_viewer_that_ignores_sigterm_is_killed(
    monkeypatch: pytest.MonkeyPatch, wrapped: bool
) -> None:
    """Ctrl-C on `view` always ends its viewer, even one slow to or refusing to stop, and
    even when, as with `python -m rerun`, a wrapper that dies at once started it."""
    import signal
    import time

    from dresslog.replay import viewer

    monkeypatch.setattr(viewer, "VIEWER_STOP_S", 0.5)
    stubborn = "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); time.sleep(60)"
    wrapper = (
        "import subprocess, sys, time; "
        f"child = subprocess.Popen([sys.executable, '-c', {stubborn!r}]); "
        "print(child.pid, flush=True); child.wait()"
    )
    code = wrapper if wrapped else f"print(0, flush=True); {stubborn}"
    process = subprocess.Popen(
        [sys.executable, "-c", code], start_new_session=True, stdout=subprocess.PIPE, text=True
    )
    assert process.stdout is not None
    with process.stdout:
        child = int(process.stdout.readline())
    time.sleep(0.5)  # the handlers in place
    started = time.monotonic()
    viewer._stop(process, group=True)
    assert time.monotonic() - started < 5
    if wrapped:
        time.sleep(0.2)
        assert not Path(f"/proc/{child}").exists() or "Z" in _state(child), "viewer left running"
    else:
        assert process.returncode == -signal.SIGKILL


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "gone"


#: `dresslog` with SIGINT as a terminal's shell gives it: handled and unblocked, whatever
#: this test process's own handlers and threads have left for its children to inherit.
AS_FROM_A_TERMINAL = (
    "import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT}); "
    "from dresslog.cli.main import main; main()"
)

#: tgkill(2)'s number, to signal one thread of another process (no Python wrapper exists).
TGKILL = {"x86_64": 234, "aarch64": 131}.get(__import__("platform").machine())


@pytest.mark.skipif(TGKILL is None or not sys.platform.startswith("linux"), reason="tgkill")
def test_ctrl_c_stops_view_whichever_thread_the_kernel_hands_it_to(inferred) -> None:
    """A process-wide SIGINT goes to any thread; one that lands on numpy's BLAS thread must
    stop `view` as surely as one that lands on the main thread (it used to hang)."""
    import ctypes
    import signal
    import time

    _, _, rrd = inferred
    command = [sys.executable, "-c", AS_FROM_A_TERMINAL]
    # BLAS's threads are the ones a signal may land on: a shell's OMP_NUM_THREADS=1 would
    # leave only the main thread, and the test nothing to send to
    limits = {"OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"}
    env = {k: v for k, v in os.environ.items() if k not in limits} | {"OPENBLAS_NUM_THREADS": "2"}
    run = subprocess.Popen(
        [*command, "view", str(rrd), "--web"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
        env=env,
    )
    try:
        assert run.stdout is not None and "Web viewer" in run.stdout.readline()
        time.sleep(1)
        tasks = Path(f"/proc/{run.pid}/task").iterdir()
        others = [int(t.name) for t in tasks if int(t.name) != run.pid]
        assert others, "no thread but the main one"
        ctypes.CDLL(None, use_errno=True).syscall(TGKILL, run.pid, others[0], signal.SIGINT)
        state = _signal_state(str(run.pid))
        try:
            assert run.wait(timeout=20) == 1  # click's "Aborted!"
        except subprocess.TimeoutExpired:
            pytest.fail(f"not stopped; its {state}; pytest's {_signal_state('self')}")
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
        run.stdout.close()


def _signal_state(pid: str) -> str:
    """The signal masks of a process (Linux), for a test that finds a signal went unheard."""
    try:
        lines = Path(f"/proc/{pid}/status").read_text().splitlines()
    except OSError:
        return "signal state unknown"
    return ", ".join(line for line in lines if line.startswith(("SigBlk", "SigIgn", "SigCgt")))


def test_a_rerun_replaces_an_earlier_estimate_copy_without_reading_it(tmp_path: Path) -> None:
    """Whether the copy's name holds an earlier copy (or a recording not to replace) was
    asked of the copy read whole: a 30-minute log's re-run peaked at 734 MB where its first
    run took 272 MB. Over a copy 10 times its length, it takes the memory of a first run."""
    from dresslog.io.writer import TrialWriter
    from dresslog.spec import TrialMetadata

    model, log = save_random_model(tmp_path), _converted_log(tmp_path, 1000)
    earlier = tmp_path / "earlier.mcap"
    t_ns = np.arange(10_000, dtype=np.int64) * 10_000_000
    with TrialWriter(earlier, TrialMetadata(task=Task.GOWN)) as writer:
        writer.write_wrench(t_ns, np.zeros((len(t_ns), 6)))
        writer.write_twist(t_ns, np.zeros((len(t_ns), 6)))
        writer.write_force_map(
            t_ns, np.ones((len(t_ns), 300)), np.ones((len(t_ns), 300)), estimate=True
        )
    peaks = [
        _replay_peak(log, model=model, mcap=copy, overwrite=True)
        for copy in (tmp_path / "first.mcap", earlier)
    ]
    assert peaks[1] < 1.2 * peaks[0], [f"{p / 1e6:.1f} MB" for p in peaks]
    estimate = read_trial(earlier).estimate
    assert estimate is not None and len(estimate.t_ns) == 1000
