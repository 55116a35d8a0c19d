"""The replay engine: streaming equals whole-sequence inference, sinks agree, bad input stops."""

from __future__ import annotations

import io
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.errors import TrialFormatError, TrialWriteError
from dresslog.io import well_known as wk
from dresslog.io.reader import TrialReader, read_trial
from dresslog.model import load_model
from dresslog.model.bundled import MODELS_ENV
from dresslog.model.postprocess import sequence_rmse
from dresslog.replay.engine import Replay, run, trial_context, trial_steps
from dresslog.replay.live import SimulationSource
from dresslog.replay.mcap_sink import McapSink
from dresslog.replay.metrics import MetricsSink
from dresslog.replay.pipeline import replay_file
from dresslog.replay.rerun_sink import RerunSink
from dresslog.spec import Task
from tests.conftest import (
    SAMPLES,
    TWIST,
    csv_of,
    missing_twist,
    nan_wrench,
    prints_warnings,
    raw_mcap,
    vector_payloads,
)
from tests.replay.conftest import STEPS, save_random_model

N_POINTS = {Task.GOWN: 300, Task.SHORTS: 400}


@pytest.fixture
def gown(make_trial, tmp_path: Path) -> tuple[Path, Path]:
    trial, _ = make_trial(Task.GOWN, STEPS)
    return trial, save_random_model(tmp_path)


def test_step_by_step_replay_equals_whole_sequence_inference(gown) -> None:
    trial_path, model_path = gown
    trial = read_trial(trial_path)
    model = load_model(model_path)
    results = run(trial_context(trial), trial_steps(trial), model.estimator())
    streamed = np.stack([r.estimate for r in results])
    whole, contact = model.estimator().run(trial.measurements.phi)
    assert streamed.shape == (STEPS, 300)
    assert np.abs(streamed).max() > 0.01, "the test model should estimate some force"
    np.testing.assert_allclose(streamed, whole, atol=1e-5)
    np.testing.assert_allclose(np.stack([r.contact for r in results]), contact, atol=1e-5)


def test_metrics_match_the_papers_rmse(gown) -> None:
    trial_path, model_path = gown
    trial = read_trial(trial_path)
    metrics = MetricsSink()
    results = run(
        trial_context(trial), trial_steps(trial), load_model(model_path).estimator(), [metrics]
    )
    estimate = np.stack([r.estimate for r in results])
    truth = trial.force_map.forces
    assert metrics.metrics.rmse == pytest.approx(sequence_rmse(truth, estimate), rel=1e-6)
    assert metrics.metrics.zero_rmse == pytest.approx(sequence_rmse(truth, 0 * truth), rel=1e-6)
    assert metrics.metrics.per_step[3] == pytest.approx(sequence_rmse(truth[3], estimate[3]))


def test_mcap_copy_holds_the_trial_and_the_engines_estimate(gown, tmp_path: Path) -> None:
    trial_path, model_path = gown
    trial = read_trial(trial_path)
    out = tmp_path / "with_estimate.mcap"
    results = run(
        trial_context(trial, trial_path),
        trial_steps(trial),
        load_model(model_path).estimator(),
        [McapSink(out)],
    )
    with TrialReader(out) as reader:
        copy = reader.read()
    assert copy.metadata == trial.metadata
    np.testing.assert_array_equal(copy.wrench.values, trial.wrench.values)
    np.testing.assert_array_equal(copy.force_map.forces, trial.force_map.forces)
    assert len(copy.garment.t_ns) == len(trial.garment.t_ns)
    np.testing.assert_array_equal(copy.estimate.forces, np.stack([r.estimate for r in results]))
    np.testing.assert_array_equal(copy.estimate.contact, np.stack([r.contact for r in results]))


def test_a_live_simulation_goes_through_the_same_engine(gown) -> None:
    from dresslog.sim.simulate import SimStart, SimStep

    trial_path, model_path = gown
    trial = read_trial(trial_path)
    model = load_model(model_path)
    expected = run(trial_context(trial), trial_steps(trial), model.estimator())
    live = SimulationSource(model.estimator())
    with live:
        live.start(SimStart(trial.metadata.spec, trial.limb_points, trial.garment.triangles))
        for step in trial_steps(trial):
            i = step.index
            wrench, twist = trial.wrench.values[i], trial.twist.values[i]
            sim = SimStep(i, step.t_ns, wrench, twist, step.pose, step.contacts, step.truth, None)
            live.step(sim)
    assert live.metrics.steps == STEPS
    assert live.metrics.per_step == pytest.approx([r.rmse for r in expected])


def test_a_nan_measurement_stops_a_live_replay(gown) -> None:
    trial_path, model_path = gown
    trial = read_trial(trial_path)
    steps = list(trial_steps(trial))
    bad = steps[3].__class__(3, steps[3].t_ns, np.full(9, np.nan, np.float32))
    replay = Replay(load_model(model_path).estimator())
    replay.start(trial_context(trial))
    with pytest.raises(TrialFormatError, match="NaN or infinite measurement at step 3"):
        replay.push(bad)


def test_a_replay_failing_midway_leaves_no_output_behind(gown, tmp_path: Path) -> None:
    trial_path, model_path = gown
    trial = read_trial(trial_path)
    steps = list(trial_steps(trial))
    steps[10] = steps[10].__class__(10, steps[10].t_ns, np.full(9, np.nan, np.float32))
    (out := tmp_path / "out").mkdir()
    sinks = [McapSink(out / "e.mcap"), RerunSink(out / "e.rrd")]
    estimator = load_model(model_path).estimator()
    with pytest.raises(TrialFormatError, match="at step 10"):
        Replay(estimator, sinks).run(trial_context(trial, trial_path), steps)
    assert list(out.iterdir()) == []  # neither the outputs nor their temporaries


@pytest.mark.parametrize("failing", ["first", "second"])
def test_an_output_that_fails_to_write_leaves_every_earlier_output_as_it_was(
    gown, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failing: str
) -> None:
    """A full disk while writing one of infer's two outputs replaces neither earlier file."""
    from mcap.writer import Writer

    trial_path, model_path = gown
    mcap, rrd = tmp_path / "e.mcap", tmp_path / "e.rrd"
    args = ["infer", str(trial_path), "--model", str(model_path), "-o", str(rrd)]
    assert CliRunner().invoke(main, [*args, "--mcap-out", str(mcap)]).exit_code == 0
    before = {p.name: p.read_bytes() for p in (mcap, rrd)}

    def full_disk(self: Writer) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Writer, "finish", full_disk)
    sinks = [McapSink(mcap, overwrite=True), RerunSink(rrd, overwrite=True)]
    if failing == "second":
        sinks.reverse()
    trial = read_trial(trial_path)
    with pytest.raises(TrialWriteError, match=r"e\.mcap: cannot write it: No space left"):
        Replay(load_model(model_path).estimator(), sinks).run(
            trial_context(trial, trial_path), trial_steps(trial)
        )
    outputs = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name.startswith((".", "e."))}
    assert outputs == before  # both as they were, and no temporaries


def test_a_full_disk_under_the_estimate_copy_is_one_line_naming_it(
    gown, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its OSError names no file: `infer --mcap-out` printed `No space left on device` alone,
    as record and convert did before the trial writer named its output."""
    from mcap.writer import Writer

    def full_disk(self: Writer) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Writer, "finish", full_disk)
    trial_path, model_path = gown
    mcap, rrd = tmp_path / "e.mcap", tmp_path / "e.rrd"
    args = ["infer", str(trial_path), "--model", str(model_path), "-o", str(rrd)]
    result = CliRunner().invoke(main, [*args, "--mcap-out", str(mcap)])
    assert result.exit_code == 1
    assert result.output == f"Error: {mcap}: cannot write it: No space left on device\n"
    assert not mcap.exists() and not rrd.exists()


def test_infer_prints_rmse_and_writes_both_outputs(gown, tmp_path: Path) -> None:
    trial_path, model_path = gown
    rrd, mcap = tmp_path / "out.rrd", tmp_path / "out.mcap"
    args = ["infer", str(trial_path), "--model", str(model_path), "-o", str(rrd)]
    result = CliRunner().invoke(main, [*args, "--mcap-out", str(mcap)])
    assert result.exit_code == 0, result.output
    again = CliRunner().invoke(main, [*args, "--mcap-out", str(mcap)])
    assert again.exit_code == 1  # every command's rule: an output is replaced only when asked
    assert again.output == f"Error: {rrd}: file exists; pass --overwrite to replace it\n"
    again = CliRunner().invoke(main, [*args, "--mcap-out", str(mcap), "--overwrite"])
    assert again.exit_code == 0, again.output
    report = replay_file(trial_path, model=model_path)  # the same replay, no outputs
    assert "40 steps" in result.output
    rmse, zero = report.rmse, report.zero_rmse
    assert rmse is not None and zero is not None
    said = f"RMSE {rmse:.4g} N (all-zero estimate {zero:.4g} N, ratio {rmse / zero:.3f})"
    assert said in result.output
    # the estimate's total force, as the copy holds it: what a log without truth shows
    estimate = read_trial(mcap).estimate
    assert estimate is not None
    totals = estimate.forces.astype(np.float64).sum(axis=1)
    peak_s = (estimate.t_ns[totals.argmax()] - estimate.t_ns[0]) / 1e9
    said = (
        f"estimated force on the limb {totals.mean():.3g} N on average, at most "
        f"{totals.max():.3g} N ({peak_s:.2f} s), on {(totals > 0).mean():.0%} of steps"
    )
    assert said in result.output
    assert rrd.stat().st_size > 0 and mcap.stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_infer_finds_the_bundled_model_for_the_trials_task(gown, tmp_path, monkeypatch) -> None:
    trial_path, model_path = gown
    (tmp_path / "bundled").mkdir()
    model_path.rename(tmp_path / "bundled" / "gown")
    monkeypatch.setenv(MODELS_ENV, str(tmp_path / "bundled"))
    report = replay_file(trial_path, rrd=tmp_path / "x.rrd")
    assert report.model == tmp_path / "bundled" / "gown"
    assert report.rmse is not None


def test_a_bundled_model_of_the_other_task_is_not_blamed_on_an_option_never_given(
    gown, tmp_path, monkeypatch
) -> None:
    trial_path, _ = gown
    (tmp_path / "bundled").mkdir()
    save_random_model(tmp_path, Task.SHORTS).rename(tmp_path / "bundled" / "gown")
    monkeypatch.setenv(MODELS_ENV, str(tmp_path / "bundled"))
    result = CliRunner().invoke(main, ["infer", str(trial_path), "-o", str(tmp_path / "x.rrd")])
    assert result.exit_code == 1 and "shorts" in result.output, result.output
    assert "leave out --model" not in result.output and "pass --model" in result.output


@pytest.mark.parametrize("task", list(Task))
def test_bundled_model_beats_all_zero_on_the_bundled_trial(
    task: Task, tmp_path: Path, monkeypatch
) -> None:
    """What a new user runs first: `dresslog infer samples/T.mcap` with the shipped model."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    report = replay_file(SAMPLES / f"{task.value}.mcap", rrd=tmp_path / "x.rrd")
    assert report.model == SAMPLES / "models" / task.value
    assert report.steps == 700
    assert report.rmse is not None and report.zero_rmse is not None
    assert report.rmse < report.zero_rmse
    assert load_model(report.model).card.metrics["test_ratio"] < 0.85


def other_task_model(tmp: Path, trial: Path, model: Path) -> tuple[Path, Path]:
    return trial, save_random_model(tmp, Task.SHORTS)


def no_twist(tmp: Path, trial: Path, model: Path) -> tuple[Path, Path]:
    return missing_twist(tmp, trial), model


def no_wrench(tmp: Path, trial: Path, model: Path) -> tuple[Path, Path]:
    path = tmp / "no_wrench.mcap"
    raw_mcap(path, {wk.TWIST: (TWIST[0], vector_payloads(*TWIST, np.zeros((3, 6))))}, True)
    return path, model


def nan_measurement(tmp: Path, trial: Path, model: Path) -> tuple[Path, Path]:
    return nan_wrench(tmp, trial), model


def no_bundled_model(tmp: Path, trial: Path, model: Path) -> tuple[Path, None]:
    return trial, None


def folder_is_a_file(tmp: Path, trial: Path, model: Path) -> tuple[Path, Path]:
    (tmp / "blocker").write_text("")  # where the output's folder would be made
    return trial, model


BAD = [
    (other_task_model, "model is for shorts but the trial is gown", "out.rrd"),
    (no_twist, "missing channel /ee/twist", "out.rrd"),
    (no_wrench, "missing channel /ee/wrench", "out.rrd"),
    (nan_measurement, "channel /ee/wrench: NaN", "out.rrd"),
    (no_bundled_model, "no bundled gown model", "out.rrd"),
    (folder_is_a_file, "blocker is not a folder", "../blocker/out.rrd"),
]


@pytest.mark.parametrize(
    ("output", "mcap_out", "message"),
    [
        ("trial.mcap", None, "would overwrite trial.mcap, the file being read"),
        ("out.rrd", "trial.mcap", "would overwrite trial.mcap, the file being read"),
        ("out.rrd", "out.rrd", "a trial is an MCAP file; name it .mcap"),
        ("out.rrd", "estimate.rrd", "a trial is an MCAP file; name it .mcap"),
        (
            "out.rrd",
            "other.mcap",
            "exists and is not an earlier estimate copy (a recording?); "
            "give --mcap-out another name (or folder), or delete it first",
        ),
        ("out.txt", None, "a Rerun recording is named .rrd"),
    ],
)
def test_infer_never_writes_over_its_trial_or_one_output_over_the_other(
    gown, tmp_path: Path, output: str, mcap_out: str | None, message: str
) -> None:
    trial, model = gown
    (work := tmp_path / "work").mkdir()
    copy = work / "trial.mcap"
    copy.write_bytes(trial.read_bytes())
    (other := work / "other.mcap").write_bytes(trial.read_bytes())  # another recording
    args = ["infer", str(copy), "--model", str(model), "-o", str(work / output)]
    args += ["--mcap-out", str(work / mcap_out)] if mcap_out else []
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and message in result.output, result.output
    assert copy.read_bytes() == trial.read_bytes() == other.read_bytes()
    assert sorted(p.name for p in work.iterdir()) == ["other.mcap", "trial.mcap"]


def test_infer_makes_its_outputs_missing_folders(gown, tmp_path: Path) -> None:
    trial, model = gown
    rrd, copy = tmp_path / "a" / "b" / "t.rrd", tmp_path / "c" / "t.mcap"
    args = ["infer", str(trial), "-m", str(model), "-o", str(rrd), "--mcap-out", str(copy)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert [p.name for p in rrd.parent.iterdir()] == ["t.rrd"]
    assert [p.name for p in copy.parent.iterdir()] == ["t.mcap"]


def test_infer_names_a_rerun_recording_given_as_the_trial_or_as_an_mcap_output(
    gown, tmp_path: Path
) -> None:
    trial, model = gown
    rrd = tmp_path / "made.rrd"
    assert (
        CliRunner().invoke(main, ["infer", str(trial), "-m", str(model), "-o", str(rrd)]).exit_code
        == 0
    )
    again = CliRunner().invoke(main, ["infer", str(rrd), "-m", str(model)])
    assert again.exit_code == 1 and "is a Rerun recording, not a trial" in again.output
    wrong = tmp_path / "estimate.mcap"
    named = CliRunner().invoke(main, ["infer", str(trial), "-m", str(model), "-o", str(wrong)])
    assert named.exit_code == 1 and "is named .rrd" in named.output and not wrong.exists()


def test_a_model_for_the_other_task_points_to_the_bundled_one(gown, tmp_path: Path) -> None:
    trial, model = other_task_model(tmp_path, *gown)
    result = CliRunner().invoke(main, ["infer", str(trial), "--model", str(model)])
    assert result.exit_code == 1
    assert "leave out --model to use the bundled one" in result.output, result.output
    assert f"{Path('samples', 'models', 'gown')})" in result.output


@pytest.mark.parametrize(("make", "message", "output"), BAD, ids=[b[0].__name__ for b in BAD])
def test_bad_input_is_one_line_and_writes_nothing(
    gown, tmp_path: Path, monkeypatch, make, message: str, output: str
) -> None:
    monkeypatch.setattr("dresslog.model.bundled.bundled_model", lambda task: None)
    trial, model = make(tmp_path, *gown)
    out = tmp_path / "results"
    out.mkdir()
    args = ["infer", str(trial), "-o", str(out / output), "--mcap-out", str(out / "copy.mcap")]
    result = CliRunner().invoke(main, [*args, *(["--model", str(model)] if model else [])])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    assert message in lines[0]
    assert list(out.iterdir()) == []


def test_the_engine_refuses_a_model_of_another_limb_at_the_start(make_trial, tmp_path) -> None:
    """A shorts trial through a gown model was numpy's broadcast error at the first step."""
    from dresslog.errors import ModelError

    shorts = read_trial(make_trial(Task.SHORTS, STEPS)[0])
    estimator = load_model(save_random_model(tmp_path)).estimator()
    with pytest.raises(ModelError, match="model estimates 300 limb points but the trial has 400"):
        run(trial_context(shorts), trial_steps(shorts), estimator, [MetricsSink()])


def test_a_rerun_sink_used_again_scales_its_colours_by_the_new_trial(gown, tmp_path) -> None:
    """It kept the first trial's scale, in the heat colours and the text that states it."""
    trial_path, model_path = gown
    trial = read_trial(trial_path)
    scaled = read_trial(trial_path)
    assert trial.force_map is not None and scaled.force_map is not None
    scaled.force_map.forces[:] *= 5  # the same trial, pressing five times as hard
    sink = RerunSink(tmp_path / "out.rrd", overwrite=True)
    scales = []
    for one in (trial, scaled, trial):
        run(trial_context(one), trial_steps(one), load_model(model_path).estimator(), [sink])
        scales.append(sink.vmax)
    assert scales[0] == scales[2] and scales[1] == pytest.approx(5 * scales[0], rel=1e-5)


def test_an_estimate_copy_needs_a_model_that_runs(tmp_path: Path) -> None:
    """With none it was a copy with no estimate, which the same call then refused."""
    from dresslog.sim.record import record_trial
    from dresslog.spec import TrialSpec

    spec = {"task": "gown", "seed": 1, "duration": 0.3, "sim": {"record_hz": 50}}
    record_trial(TrialSpec.model_validate(spec), trial := tmp_path / "hz50.mcap")
    with pytest.raises(TrialFormatError, match="is at 50 Hz"):
        replay_file(trial, require_model=False, mcap=tmp_path / "copy.mcap")
    assert not (tmp_path / "copy.mcap").exists()


@prints_warnings
def test_a_signal_far_from_the_training_data_is_warned_about_with_its_likely_cause(
    tmp_path: Path, monkeypatch
) -> None:
    """A robot's log whose sensor still reads the gripper's weight (1.5 kg) in fz: the
    bundled model extrapolates on every step, and says so; tared, the same log does not."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    runner = CliRunner()
    said = {}
    for name, offset in (("tared", 0.0), ("untared", -1.5 * 9.81)):
        csv = csv_of(SAMPLES / "gown.mcap", tmp_path / f"{name}.csv", offset)
        mcap = tmp_path / f"{name}.mcap"
        converted = runner.invoke(main, ["convert", str(csv), "-o", str(mcap), "--task", "gown"])
        assert converted.exit_code == 0, converted.output
        result = runner.invoke(main, ["infer", str(mcap), "-o", str(tmp_path / f"{name}.rrd")])
        assert result.exit_code == 0 and (tmp_path / f"{name}.rrd").exists(), result.output
        said[name] = result.stderr
    assert "Warning" not in said["tared"]
    warning = said["untared"]
    assert warning.startswith(f"Warning: {tmp_path / 'untared.mcap'}: fz lies beyond 10 ")
    share = re.search(r"on (\d+)% of steps \(median there (\S+) N", warning)
    # v9's gown pulls with up to 10 N, so a 15 N offset lies 10 SD away on a fifth of steps
    assert share and int(share[1]) >= 15 and float(share[2]) < -10, warning
    assert "convert --tare" in warning
    assert len(warning.strip().splitlines()) == 1


@prints_warnings
def test_a_simulated_trial_far_from_a_models_training_names_the_training(tmp_path: Path) -> None:
    """A model trained on trials unlike the sample (a signal 100 times narrower, as of trials
    too short to reach the arm): the simulator's own signal is tared and in its axes, where
    the warning had asked whether the sensor was tared (`convert --tare`)."""
    model = save_random_model(tmp_path, std=0.02)
    trial, rrd = SAMPLES / "gown.mcap", tmp_path / "g.rrd"
    result = CliRunner().invoke(main, ["infer", str(trial), "-m", str(model), "-o", str(rrd)])
    assert result.exit_code == 0 and rrd.exists(), result.output
    warning = result.stderr.strip()
    assert warning.startswith(f"Warning: {trial}: ") and " standard deviations " in warning
    assert warning.endswith(
        "so the estimate there is a guess; the trial is simulated, so the model was trained "
        "on trials unlike it (`dresslog info` on the model and its dataset says how)"
    ), warning
    assert "convert" not in warning and len(warning.splitlines()) == 1


@prints_warnings
def test_a_simulated_trial_at_a_speed_or_pose_the_model_never_saw_is_warned_about(
    tmp_path: Path, monkeypatch
) -> None:
    """`record --speed 0.2`, `--rotation z -15` or `--offset 0 0.35 0`, then `infer` with
    the bundled model: the signal lies in range, so nothing said that the estimate is a
    generalisation; the sample trial, drawn as the model's own training trials, gets no
    warning."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    runner = CliRunner()
    trained = "speeds 0.1-0.15 m/s, the limb never turned"
    for name, option, outside in (
        ("fast", ["--speed", "0.2"], "speed 0.2 m/s"),
        ("turned", ["--rotation", "z", "-15"], "rotation about z -15 deg"),
        (
            "aside",
            ["--offset", "0", "0.35", "0"],
            "limb offset y +0.35 m (trained on y -0.1...+0.1)",
        ),
        ("older", ["--simulator", "v8"], "simulator v8 (trained on v9)"),
        ("newer", ["--simulator", "v10"], "simulator v10 (trained on v9)"),
    ):
        trial = tmp_path / f"{name}.mcap"
        args = ["record", "--task", "gown", "--seed", "4", "--duration", "1", *option]
        recorded = runner.invoke(main, [*args, "-o", str(trial)])
        assert recorded.exit_code == 0, recorded.output
        result = runner.invoke(main, ["infer", str(trial), "-o", str(tmp_path / f"{name}.rrd")])
        assert result.exit_code == 0, result.output
        assert result.stderr == (
            f"Warning: {trial}: outside the model's training ({trained}): {outside}, so the "
            "estimate measures how it generalises\n"
        ), result.stderr
    sample = ["infer", str(SAMPLES / "gown.mcap"), "-o", str(tmp_path / "s.rrd")]
    result = runner.invoke(main, sample)
    assert result.exit_code == 0 and result.stderr == "", result.output


def test_a_knock_or_a_channel_constant_in_training_is_not_called_far() -> None:
    """A 30 N knock over 8 steps, 10% of a short trial, is not a recording far from the
    training data; nor is any value of a channel that never varied in training."""
    from dresslog.model.inputs import unfamiliar

    mean, std = np.zeros(9), np.ones(9)
    phi = np.zeros((80, 9))
    phi[10:18, 0] = 30.0
    assert unfamiliar(phi, mean, std) is None
    phi[:, 0] = 30.0  # the whole trial: far
    assert (said := unfamiliar(phi, mean, std)) and said.startswith("fx lies beyond 10 ")
    std[0] = 0.0
    assert unfamiliar(phi, mean, std) is None


@prints_warnings
def test_a_log_in_another_robots_axes_is_warned_about_and_rotate_puts_it_right(
    tmp_path: Path, monkeypatch
) -> None:
    """The same trial logged in axes turned 90 degrees about z: every value in range, but
    the gripper heads along y, not -x; `convert --rotate` back makes the warning go."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    csv = csv_of(SAMPLES / "gown.mcap", tmp_path / "turned.csv", turn=turn)
    runner = CliRunner()
    said = {}
    back = ["--rotate", "0", "0", str(-np.sqrt(0.5)), str(np.sqrt(0.5))]  # -90 deg about z
    for name, extra in (("turned", []), ("rotated", back)):
        mcap = tmp_path / f"{name}.mcap"
        args = ["convert", str(csv), "-o", str(mcap), "--task", "gown", *extra]
        assert (converted := runner.invoke(main, args)).exit_code == 0, converted.output
        result = runner.invoke(main, ["infer", str(mcap), "-o", str(tmp_path / f"{name}.rrd")])
        assert result.exit_code == 0, result.output
        said[name] = result.stderr
    assert "Warning" not in said["rotated"], said["rotated"]
    # its forearm stroke turned aside, its rise still up: most of it one way, far off
    assert re.match(rf"Warning: {re.escape(str(tmp_path / 'turned.mcap'))}: \d+% of the "
                    "gripper's moving steps head within 60 degrees", said["turned"])  # fmt: skip
    assert "training trials' way (-0.8" in said["turned"]
    mostly = re.search(r"mostly along \((\S+), (\S+), (\S+)\)", said["turned"])
    # the turned log's -y (the trials' -x, turned) with the rise up the arm
    assert mostly and float(mostly[2]) < -0.7 and abs(float(mostly[1])) < 0.1


def test_a_log_that_returns_the_way_it_came_is_not_taken_for_one_in_other_axes() -> None:
    """The sample trial with a retract stroke appended (back at 0.8 of the speed, a quarter
    longer): its median velocity points backwards, which had been read as other axes."""
    from dresslog.model.inputs import unfamiliar

    stats = load_model(SAMPLES / "models" / "gown").card.normalisation
    assert stats is not None
    phi = read_trial(SAMPLES / "gown.mcap").measurements.phi.astype(np.float64)
    back = np.zeros((len(phi) * 5 // 4, 9))
    back[:, 6:9] = -0.8 * phi[np.arange(len(back)) % len(phi), 6:9]
    assert (
        unfamiliar(np.concatenate([phi, back]), np.array(stats.mean), np.array(stats.std)) is None
    )


def test_a_force_map_that_fits_neither_its_limb_nor_the_tasks_is_one_line(tmp_path: Path) -> None:
    """Ground truth without /limb/points is drawn on the task's limb; 100 values per step
    cannot be, which had surfaced as numpy's broadcast error mid-replay."""
    from dresslog.io.writer import TrialWriter
    from dresslog.spec import TrialMetadata, TrialSpec

    path = tmp_path / "narrow.mcap"
    spec = TrialSpec(task=Task.GOWN, seed=1)
    with TrialWriter(path, TrialMetadata(task=Task.GOWN, spec=spec)) as writer:
        for i in range(20):
            t = 1_000_000_000 + i * 10_000_000
            writer.write_wrench(t, np.zeros(6))
            writer.write_twist(t, np.zeros(6))
            writer.write_force_map(t, np.zeros(100, np.float32))
    result = CliRunner().invoke(main, ["infer", str(path), "-o", str(tmp_path / "n.rrd")])
    assert result.exit_code == 1 and not (tmp_path / "n.rrd").exists()
    assert result.output == (
        f"Error: {path}: channel {wk.FORCE_MAP}: force maps have 100 values but the trial has "
        f"no {wk.LIMB_POINTS} and the gown's limb has 300 points; write its limb points with "
        "the maps\n"
    )


def test_the_estimated_force_summary_counts_time_and_steps_from_the_trials_start() -> None:
    """A replay whose estimate begins at its sixth step: the peak's time and the share of
    steps with force are the trial's, as the Rerun timeline counts them."""
    from dresslog.replay.engine import Step, StepResult

    sink = MetricsSink()
    sink.open(None)  # type: ignore[arg-type]  # the context is not read
    for i in range(10):
        estimate = None if i < 5 else np.where(i == 7, np.full(3, 2.0), np.zeros(3))
        sink.write(StepResult(Step(i, 5_000_000_000 + i * 10_000_000, np.zeros(9)), None, estimate))
    sink.close()
    m = sink.metrics
    assert m.steps == 10 and m.peak_total == 6.0 and m.peak_s == pytest.approx(0.07)
    assert m.touching == pytest.approx(0.1) and m.mean_total == pytest.approx(1.2)


@pytest.fixture
def day(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder of trials as a researcher's day holds them: the two samples, copied."""
    monkeypatch.delenv(MODELS_ENV, raising=False)
    (folder := tmp_path / "day1").mkdir()
    for task in Task:
        (folder / f"{task.value}.mcap").write_bytes((SAMPLES / f"{task.value}.mcap").read_bytes())
    return folder


def test_infer_on_several_trials_writes_each_recording_and_prints_the_mean(day: Path) -> None:
    gown, shorts = day / "gown.mcap", day / "shorts.mcap"
    result = CliRunner().invoke(main, ["infer", str(gown), str(shorts)])
    assert result.exit_code == 0, result.output
    each = [replay_file(t) for t in (gown, shorts)]  # the same replays, no outputs
    lines = result.output.splitlines()
    assert [line.split(": ", 1)[0] for line in lines[:2]] == [str(gown), str(shorts)]
    assert f"-> {day / 'gown.rrd'}; RMSE {each[0].rmse:.4g} N" in lines[0]
    assert f"-> {day / 'shorts.rrd'}; RMSE {each[1].rmse:.4g} N" in lines[1]
    assert lines[2:] == [  # a line per task: each task's all-zero RMSE is its own scale
        f"{r.task.value}: mean over 1 trial: RMSE {r.rmse:.4g} N, ratio to the all-zero "
        f"estimate's {r.rmse / r.zero_rmse:.3f}"
        for r in each
    ]
    assert sorted(p.name for p in day.iterdir()) == [
        "gown.mcap", "gown.rrd", "shorts.mcap", "shorts.rrd"
    ]  # fmt: skip


def test_a_folder_of_trials_given_to_infer_is_told_to_give_its_trials(day: Path) -> None:
    result = CliRunner().invoke(main, ["infer", str(day)])
    assert result.exit_code == 1
    assert (
        result.stderr
        == f"Error: {day}: is a folder, not an MCAP file; give its trials, {day}/*.mcap\n"
    )
    (day / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")  # a ROS 2 bag's
    assert "run `dresslog convert` first" in CliRunner().invoke(main, ["infer", str(day)]).stderr


def test_a_folder_whose_trials_lie_in_subfolders_is_told_to_give_theirs(day: Path) -> None:
    """A dataset (train/, test/) or a sweep's folder, where it had been told to convert."""
    data = day.parent / "data"
    for split, trial in (("train", "gown.mcap"), ("test", "shorts.mcap")):
        (data / split).mkdir(parents=True)
        (day / trial).rename(data / split / "000000.mcap")
    result = CliRunner().invoke(main, ["infer", str(data)])
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: {data}: is a folder, not an MCAP file; give its trials, {data}/test/*.mcap "
        f"{data}/train/*.mcap\n"
    )


def test_a_model_folder_given_as_the_trial_is_told_to_go_with_model() -> None:
    """`dresslog infer samples/models/gown`, where it had been told to convert a ROS bag or
    CSV first."""
    folder = SAMPLES / "models" / "gown"
    result = CliRunner().invoke(main, ["infer", str(folder)])
    assert result.exit_code == 1
    assert result.stderr == (
        f"Error: {folder}: is a folder, not an MCAP file; a model's (it holds weights): give "
        "it with --model, after a trial\n"
    )


def test_a_bad_trial_among_good_ones_is_said_and_the_others_are_done(day: Path) -> None:
    """Not MCAP, cut short, a channel missing: each its error, no recording of it, exit 1."""
    gown, shorts = day / "gown.mcap", day / "shorts.mcap"
    (junk := day / "notes.mcap").write_text("not a recording\n")
    (cut := day / "cut.mcap").write_bytes(gown.read_bytes()[:100_000])
    no_twist = missing_twist(day, gown)
    trials = [junk, gown, cut, no_twist, shorts]
    result = CliRunner().invoke(main, ["infer", *map(str, trials)])
    assert result.exit_code == 1, result.output
    errors = result.stderr.splitlines()
    assert [e.split(": ", 2)[1] for e in errors[:3]] == [str(junk), str(cut), str(no_twist)]
    assert "not an MCAP file" in errors[0] and "truncated" in errors[1]
    assert "missing channel /ee/twist" in errors[2]
    assert errors[3:] == ["Error: 3 of 5 trials failed"]  # the last line
    assert result.stdout.splitlines()[-1].startswith("shorts: mean over 1 trial: RMSE ")
    assert sorted(p.name for p in day.iterdir() if p.suffix == ".rrd") == ["gown.rrd", "shorts.rrd"]
    assert not [p for p in day.iterdir() if p.name.startswith(".")]  # no temporaries


def test_a_model_for_the_other_task_fails_those_trials_alone(day: Path) -> None:
    """Each failure's line begins with its trial: the model's error named only the model."""
    gown, shorts = day / "gown.mcap", day / "shorts.mcap"
    model = SAMPLES / "models" / "gown"
    result = CliRunner().invoke(main, ["infer", str(shorts), str(gown), "--model", str(model)])
    assert result.exit_code == 1, result.output
    assert result.stderr.splitlines() == [
        f"Error: {shorts}: {model}: model is for gown but the trial is shorts; leave out "
        "--model to use "
        f"the bundled one ({SAMPLES / 'models' / 'shorts'})",
        "Error: 1 of 2 trials failed",
    ]
    assert result.stdout.startswith(f"{gown}: 700 steps, gown, model {model}")
    assert sorted(p.name for p in day.iterdir() if p.suffix == ".rrd") == ["gown.rrd"]


def test_infer_on_several_trials_writes_each_into_the_folders_given(day: Path) -> None:
    """A day's estimate copies in one command: each trial's recording and copy in the folders
    given (made if missing), named after it; a re-run replaces them with --overwrite only."""
    gown, shorts = day / "gown.mcap", day / "shorts.mcap"
    rec, est = day.parent / "out" / "rec", day.parent / "out" / "est"
    args = ["infer", str(gown), str(shorts), "-o", str(rec), "--mcap-out", str(est)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert f"{gown}: 700 steps, gown" in lines[0]
    assert f" -> {rec / 'gown.rrd'}, {est / 'gown.mcap'}; RMSE " in lines[0]
    assert f" -> {rec / 'shorts.rrd'}, {est / 'shorts.mcap'}; RMSE " in lines[1]
    assert sorted(p.name for p in rec.iterdir()) == ["gown.rrd", "shorts.rrd"]
    assert sorted(p.name for p in est.iterdir()) == ["gown.mcap", "shorts.mcap"]
    assert sorted(p.name for p in day.iterdir()) == ["gown.mcap", "shorts.mcap"]
    one = replay_file(gown, mcap=day.parent / "one.mcap")  # the same replay, alone
    assert one.steps == 700
    with TrialReader(est / "gown.mcap") as copy, TrialReader(day.parent / "one.mcap") as alone:
        assert copy.has(wk.ESTIMATE) and copy.metadata.task is Task.GOWN
        assert copy.estimate is not None and alone.estimate is not None
        np.testing.assert_array_equal(copy.estimate.forces, alone.estimate.forces)
    again = CliRunner().invoke(main, args)  # each trial fails alone, its outputs kept
    assert again.exit_code == 1
    assert again.output.splitlines()[-1] == "Error: 2 of 2 trials failed"
    assert f"Error: {gown}: {rec / 'gown.rrd'}: file exists; pass --overwrite" in again.output
    assert CliRunner().invoke(main, [*args, "--overwrite"]).exit_code == 0


def test_one_trial_goes_into_an_existing_folder_as_cp_takes_one(day: Path) -> None:
    """`infer day1/*.mcap -o out` matching one trial, or `infer t.mcap -o out/`: an existing
    folder holds TRIAL.rrd (and its copy), where it was refused as 'is a folder'; the trial's
    own folder for its copy is still refused, as it would overwrite the trial."""
    gown, out = day / "gown.mcap", day.parent / "out"
    out.mkdir()
    result = CliRunner().invoke(main, ["infer", str(gown), "-o", str(out), "--mcap-out", str(out)])
    assert result.exit_code == 0, result.output
    assert f" -> {out / 'gown.rrd'}, {out / 'gown.mcap'}; RMSE " in result.stdout
    assert sorted(p.name for p in out.iterdir()) == ["gown.mcap", "gown.rrd"]
    result = CliRunner().invoke(main, ["infer", str(gown), "--mcap-out", str(day)])
    assert result.exit_code == 2
    assert result.stderr.splitlines()[-1] == (
        f"Error: {gown}: would overwrite gown.mcap, the file being read; give another folder"
    )
    assert sorted(p.name for p in day.iterdir()) == ["gown.mcap", "shorts.mcap"]


def test_one_trial_goes_into_a_folder_to_make_named_with_a_trailing_slash(day: Path) -> None:
    """`infer t.mcap -o out/` with no `out` yet: the / says a folder, as for rsync; it was
    refused as a recording not named .rrd. A .rrd name with a / is still refused."""
    gown, out = day / "gown.mcap", day.parent / "out"
    args = ["infer", str(gown), "-o", f"{out}/", "--mcap-out", f"{out / 'est'}/"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["est", "gown.rrd"]
    assert [p.name for p in (out / "est").iterdir()] == ["gown.mcap"]
    result = CliRunner().invoke(main, ["infer", str(gown), "-o", f"{day.parent / 'x.rrd'}/"])
    assert result.exit_code == 2
    assert "an output ending in / is a folder, not a .rrd recording" in result.stderr
    assert not (day.parent / "x.rrd").exists()


def test_a_bad_trial_among_good_ones_leaves_nothing_of_it_in_the_folders(day: Path) -> None:
    (junk := day / "notes.mcap").write_text("not a recording\n")
    out = day.parent / "out"
    trials = [str(junk), str(day / "gown.mcap")]
    result = CliRunner().invoke(main, ["infer", *trials, "-o", str(out), "--mcap-out", str(out)])
    assert result.exit_code == 1, result.output
    assert result.stderr.splitlines()[-1] == "Error: 1 of 2 trials failed"
    assert sorted(p.name for p in out.iterdir()) == ["gown.mcap", "gown.rrd"]  # no temporaries


def twice_named(day: Path) -> list[str]:
    (other := day.parent / "day2").mkdir()
    (other / "gown.mcap").write_bytes((day / "gown.mcap").read_bytes())
    return [str(day / "gown.mcap"), str(other / "gown.mcap")]


def both_tasks(day: Path) -> list[str]:
    return [str(day / "gown.mcap"), str(day / "shorts.mcap")]


FOLDERS = [  # (trials, option, folder, the error line)
    (twice_named, "-o", "out", "{day}/gown.mcap and {day2}/gown.mcap would both be written to "
     "{tmp}/out/gown.rrd; infer them into separate folders"),
    (twice_named, "--mcap-out", "out", "{day}/gown.mcap and {day2}/gown.mcap would both be "
     "written to {tmp}/out/gown.mcap; infer them into separate folders"),
    (both_tasks, "-o", "file", "{tmp}/file: is a file; give a folder for the trials' outputs"),
    (both_tasks, "--mcap-out", "file/est", "{tmp}/file/est: {tmp}/file is not a folder"),
    (both_tasks, "--mcap-out", "day1", "{day}/gown.mcap: would overwrite gown.mcap, the file "
     "being read; give another folder"),
    (both_tasks, "-o", "out.rrd", "{tmp}/out.rrd: with several trials, the output is a folder, "
     "not a .rrd recording; name it without .rrd (e.g. {tmp}/out)"),
    (both_tasks, "--mcap-out", "out.mcap", "{tmp}/out.mcap: with several trials, the output "
     "is a folder, not a .mcap recording; name it without .mcap (e.g. {tmp}/out)"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("trials", "option", "folder", "line"),
    FOLDERS,
    ids=["collision-o", "collision-mcap", "file", "under-a-file", "own-folder", "rrd", "mcap"],
)
def test_output_folders_that_cannot_hold_every_trial_are_a_usage_error(
    day: Path, trials, option: str, folder: str, line: str
) -> None:
    """Refused before any trial, where two trials of one name would have left the second's."""
    tmp = day.parent
    (tmp / "file").write_text("")
    args = ["infer", *trials(day), option, str(tmp / folder)]
    before = sorted(tmp.rglob("*"))
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    said = line.format(tmp=tmp, day=day, day2=tmp / "day2")
    assert result.stderr.splitlines()[-1] == f"Error: {said}"
    assert sorted(tmp.rglob("*")) == before


@pytest.mark.parametrize("output", [[], ["-o", "out"]], ids=["beside", "folder"])
def test_a_trial_given_twice_is_a_usage_error(day: Path, output: list[str]) -> None:
    """Beside the trial it was replayed twice and counted twice in the mean; into a folder
    it was told it and itself "would both be written" there, "into separate folders"."""
    gown, shorts = day / "gown.mcap", day / "shorts.mcap"
    out = [output[0], str(day.parent / output[1])] if output else []
    for again, said in (
        (gown, "given twice"),
        (day / ".." / "day1" / "gown.mcap", f"is {gown}, given already"),
    ):
        result = CliRunner().invoke(main, ["infer", str(gown), str(shorts), str(again), *out])
        assert result.exit_code == 2, result.output
        assert result.stderr.splitlines()[-1] == f"Error: {again}: {said}; give each trial once"
    assert sorted(p.name for p in day.parent.rglob("*")) == ["day1", "gown.mcap", "shorts.mcap"]


def test_replay_files_takes_the_folders_from_python(gown, tmp_path: Path) -> None:
    from dresslog.errors import TrialWriteError
    from dresslog.replay.batch import replay_files

    trial, model = gown
    a, b, out = tmp_path / "a" / "t.mcap", tmp_path / "b" / "t.mcap", tmp_path / "out"
    for path in (a, b):
        path.parent.mkdir()
        path.write_bytes(trial.read_bytes())
    with pytest.raises(TrialWriteError, match=f"{a} and {b} would both be written to"):
        replay_files([a, b], model=model, rrd=out)
    assert not out.exists()
    batch = replay_files([a, trial], model=model, mcap=out)
    assert [r.outputs for r in batch.reports] == [
        [a.with_suffix(".rrd"), out / "t.mcap"],
        [trial.with_suffix(".rrd"), out / "trial.mcap"],
    ]


def test_a_batch_loads_each_model_once(gown, tmp_path: Path, monkeypatch) -> None:
    """The bundled model is read and verified before the first trial only: replaced on disk
    after it, the rest of the batch still runs on the model it began with."""
    from dresslog.replay.batch import replay_files

    trial, model = gown
    (tmp_path / "bundled").mkdir()
    model.rename(tmp_path / "bundled" / "gown")
    monkeypatch.setenv(MODELS_ENV, str(tmp_path / "bundled"))
    trials = [tmp_path / f"t{i}.mcap" for i in range(3)]
    for path in trials:
        path.write_bytes(trial.read_bytes())

    def tamper(outcome: object) -> None:
        (tmp_path / "bundled" / "gown" / "model.safetensors").write_bytes(b"replaced")

    batch = replay_files(trials, on_trial=tamper)
    assert not batch.failures, batch.failures
    assert len({r.rmse for r in batch.reports}) == 1 and batch.reports[0].rmse is not None


def test_the_batch_mean_leaves_out_trials_without_ground_truth_and_says_so() -> None:
    from dresslog.replay.batch import BatchReport
    from dresslog.replay.metrics import TrialMetrics
    from dresslog.replay.pipeline import InferenceReport

    def report(name: str, metrics: TrialMetrics) -> InferenceReport:
        return InferenceReport(Path(name), Task.GOWN, 700, metrics=metrics)

    log = report("log.mcap", TrialMetrics(mean_total=0.5, peak_total=2.0))  # a robot's log
    trials = [
        report("a.mcap", TrialMetrics(rmse=0.01, zero_rmse=0.02)),
        log,
        report("b.mcap", TrialMetrics(rmse=0.03, zero_rmse=0.04)),
        report("still.mcap", TrialMetrics(rmse=0.0, zero_rmse=0.0)),  # no force on the limb
    ]
    assert BatchReport(trials).summary() == (
        "mean over 3 trials (1 without ground truth left out): RMSE 0.01333 N, "
        "ratio to the all-zero estimate's 0.667"  # 0.01333 / 0.02, the pooled means
    )
    assert BatchReport([log, log]).summary() == (
        "2 trials replayed, none with ground truth: no RMSE to average"
    )


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_infer_shows_the_steps_replayed_on_a_terminal(make_trial, tmp_path, monkeypatch) -> None:
    """A 30-minute log takes a minute to replay: a progress bar says how far it is."""
    from dresslog.replay.batch import replay_files

    trial, _ = make_trial(Task.GOWN, STEPS)
    model = save_random_model(tmp_path)
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    batch = replay_files([trial], model=model, rrd=tmp_path / "t.rrd", progress=True)
    assert batch.reports and f"{trial.name}:   0%|          | 0/{STEPS} [" in terminal.getvalue()
