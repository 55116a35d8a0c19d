"""`dresslog train`, `eval` and `sweep` on a small real dataset, and their bad input."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import matplotlib.colors
import matplotlib.image
import matplotlib.pyplot
import numpy as np
import pytest
from click.testing import CliRunner, Result

from dresslog.cli.main import main
from dresslog.dataset import Execution, Manifest, generate, load_dataset, load_manifest
from dresslog.errors import DatasetError, DresslogWarning, ModelError
from dresslog.experiments import (
    Scores,
    SweepReport,
    TrainOptions,
    dataset_bounds,
    sweep,
    sweep_settings,
    train_dataset,
)
from dresslog.experiments.evaluation import data_conditions
from dresslog.experiments.plots import (
    eval_figure,
    plot_sweep,
    sweep_figure,
    sweep_lines,
    training_figure,
)
from dresslog.folders import CARD_FILE
from dresslog.io.files import exclusive
from dresslog.model.bounds import describe_oracle
from dresslog.model.conditions import Conditions, combined, spec_conditions, trained_conditions
from dresslog.model.evaluate import ErrorProfile, score_sequences
from dresslog.model.files import (
    EpochRecord,
    Hyperparameters,
    InitialModel,
    ModelCard,
    TrainingFolder,
    load_model,
    save_model,
)
from dresslog.model.numpy_lstm import expected_shapes
from dresslog.sim.specs import random_spec
from dresslog.spec import RotationRange, Task, TrialSpec
from tests.conftest import SAMPLES, prints_warnings
from tests.test_dataset import fake_record


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """4 gown trials (3 train, 1 test) with the arm moved to the gripper, so force is on it."""
    out = tmp_path_factory.mktemp("exp") / "gown"
    near = {"duration": 1.5, "limb_offset": (0.30, 0.0, 0.05)}
    generate("gown", 4, out, execution=Execution(workers=2), test_fraction=0.25, overrides=near)
    return out


@pytest.fixture(scope="module")
def turned(data: Path) -> Path:
    """3 more such trials (2 train, 1 test) of seed 1, at 0.2 m/s and the limb turned within
    z +-15 deg: a second folder to train on, of other conditions."""
    out = data.parent / "turned"
    near = {"duration": 1.5, "limb_offset": [0.30, 0.0, 0.05]}
    generate("gown", 3, out, execution=Execution(workers=2), seed=1, test_fraction=1 / 3,
             overrides={**near, "speed": 0.2}, rotation_range=TURNED)  # fmt: skip
    return out


#: The `turned` fixture's span of rotations.
TURNED = RotationRange(axis="z", low=-15, high=15)


@pytest.fixture(scope="module")
def model(data: Path) -> Path:
    out = data.parent / "model"
    args = ["train", str(data), "-o", str(out), "--epochs", "2", "--hidden", "4", "--layers", "1"]
    result = CliRunner().invoke(main, [*args, "--quiet"])
    assert result.exit_code == 0, result.output
    assert "epoch 2: train loss" in result.output and "test_rmse" in result.output
    return out


def invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.output


#: For a sweep of sequences too short to reach the arm, kept short for speed: the warning
#: that no sequence carries force is beside the point of the test.
short_sequences = pytest.mark.filterwarnings(
    "ignore:.*carries force on the limb:dresslog.errors.DresslogWarning"
)


def lines(output: str) -> list[str]:
    """`output`'s lines but the warning that no sequence carries force, which a sweep of
    0.3 s sequences (ended before the garment reaches the arm) gives."""
    return [line for line in output.splitlines() if "carries force on the limb" not in line]


@pytest.fixture(scope="module")
def swept(model: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, str]:
    """`dresslog sweep` of the `model` fixture without -o (into MODEL-sweep in the current
    folder), of in-range, speed:0.2 and rot:z:10, 2 sequences of 0.3 s each: its folder,
    exit code and output. Simulated once for the tests that read it; one that sweeps on
    copies it."""
    here = tmp_path_factory.mktemp("swept")
    with pytest.MonkeyPatch.context() as patch, warnings.catch_warnings():
        patch.chdir(here)
        warnings.filterwarnings("ignore", ".*carries force on the limb", DresslogWarning)
        code, output = invoke(
            "sweep", model, "--speeds", "0.2", "--rotations", "z:10", "-n", "2",
            "--duration", "0.3", "--workers", "2", "-q",
        )  # fmt: skip
    return here / f"{model.name}-sweep", code, output


@pytest.fixture(scope="module")
def sample_swept(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Result]:
    """The bundled gown model swept over in-range, speed:0.2 and rot:z:10, 1 sequence of
    0.3 s each (too short to reach the arm): its folder and `dresslog sweep`'s result, the
    warning of no force printed. Simulated once; a test that sweeps on copies the folder."""
    out = tmp_path_factory.mktemp("sample-swept") / "sweep"
    args = ["sweep", str(SAMPLES / "models" / "gown"), "--speeds", "0.2", "--rotations", "z:10"]
    with warnings.catch_warnings():
        warnings.simplefilter("default", DresslogWarning)  # printed, as in a user's shell
        result = CliRunner().invoke(
            main, [*args, "-n", "1", "--duration", "0.3", "--workers", "1", "-q", "-o", str(out)]
        )
    return out, result


@pytest.mark.slow
def test_trained_model_card_names_its_data_and_test_scores(model: Path, data: Path) -> None:
    card = json.loads((model / "card.json").read_text())
    assert card["data"]["manifest_sha256"] == load_manifest(data).content_hash()
    assert card["hidden"] == 4 and card["layers"] == 1 and card["hyperparameters"]["epochs"] == 2
    assert card["metrics"]["test_n_sequences"] == 1.0
    assert not list(data.parent.glob(".model.checkpoint.safetensors"))


@pytest.mark.slow
def test_trained_model_keeps_its_learning_curve_and_its_plot(model: Path) -> None:
    import matplotlib.image

    card = load_model(model).card
    assert [e.epoch for e in card.history] == [1, 2]
    assert all(e.train_loss > 0 and e.seconds > 0 for e in card.history)
    assert card.data.n_val == 0 and all(e.val_loss is None for e in card.history)  # 3 trials
    assert card.metrics["train_loss"] == card.history[-1].train_loss  # the last epoch kept
    image = matplotlib.image.imread(model / "training.png")
    assert image.shape[0] > 200 and image.shape[1] > 300
    assert not list(model.glob(".*partial"))


@pytest.mark.slow
def test_overwrite_replaces_an_interrupted_run_of_other_settings(data: Path) -> None:
    out = data.parent / "interrupted"

    def stop(epoch) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        options = TrainOptions(epochs=3, hidden=4, layers=1)
        train_dataset(data, out, options, progress=False, on_epoch=stop)
    checkpoint = data.parent / ".interrupted.checkpoint.safetensors"
    assert checkpoint.exists() and not out.exists()
    args = ["train", data, "-o", out, "--epochs", "2", "--hidden", "4", "--layers", "1", "-q"]
    code, output = invoke(*args)
    assert code != 0 and "other settings" in output and "--overwrite" in output
    assert "Traceback" not in output and not out.exists()
    code, output = invoke(*args, "--overwrite")
    assert code == 0, output
    assert [e.epoch for e in load_model(out).card.history] == [1, 2]  # afresh, not resumed
    assert not checkpoint.exists()


@pytest.mark.slow
def test_an_interrupted_overwrite_resumes_when_its_command_is_repeated(data: Path) -> None:
    """Retraining over a model: the repeated command picks up the epochs done."""
    out = data.parent / "retrained"
    options = TrainOptions(epochs=3, hidden=4, layers=1)
    train_dataset(data, out, options, progress=False)
    before = (out / "model.safetensors").read_bytes()
    seen: list[int] = []

    def stop_after_two(epoch) -> None:
        seen.append(epoch.epoch)
        if epoch.epoch == 2:
            raise KeyboardInterrupt

    def seen_epoch(epoch) -> None:
        seen.append(epoch.epoch)

    with pytest.raises(KeyboardInterrupt):
        train_dataset(data, out, options, overwrite=True, progress=False, on_epoch=stop_after_two)
    assert (out / "model.safetensors").read_bytes() == before  # kept until the run ends
    train_dataset(data, out, options, overwrite=True, progress=False, on_epoch=seen_epoch)
    assert seen == [1, 2, 3]  # epoch 3 only: resumed, not afresh
    assert (out / "model.safetensors").read_bytes() == before  # what one run computes


@pytest.mark.slow
def test_eval_reports_rmse_baseline_and_per_outcome(model: Path, data: Path) -> None:
    code, output = invoke("eval", model, data, "--json")
    assert code == 0, output
    report = json.loads(output)
    overall = report["overall"]
    assert report["split"] == "test" and overall["n"] == 1
    assert report["bounds"] is None  # not asked for
    assert overall["zero_rmse"] > 0  # the test trial carries force
    assert overall["ratio"] == pytest.approx(overall["rmse"] / overall["zero_rmse"])
    assert 0 <= overall["contact_precision"] <= 1 and 0 <= overall["contact_recall"] <= 1
    code, output = invoke("eval", model, data, "--split", "train", "--json")
    assert code == 0, output
    train = json.loads(output)
    assert train["split"] == "train" and train["overall"]["n"] == 3
    entries = load_manifest(data).split("train")
    expected = {
        o: sum(e.outcome.value == o for e in entries) for o in {e.outcome.value for e in entries}
    }
    # every outcome listed, those absent from the split with n 0 and nulls
    assert {o: s["n"] for o, s in train["per_outcome"].items()} == {
        "dressed": 0, "missed": 0, "caught": 0, **expected,
    }  # fmt: skip
    absent = [s for s in train["per_outcome"].values() if s["n"] == 0]
    assert all(s["rmse"] is None and s["ratio"] is None for s in absent)
    code, output = invoke("eval", model, data, "-q")
    assert code == 0 and f"{overall['rmse']:.5f}" in output
    said = "trials    speeds 0.1-0.15 m/s, the limb never turned, as the model was trained on"
    assert said in output and "outside" not in output  # trained on this very folder
    code, output = invoke("eval", model, data, "--bounds", "--json")
    assert code == 0, output
    bounds = json.loads(output)["bounds"]
    assert dataset_bounds(data) == pytest.approx(bounds)  # the same oracles without a model
    assert 0 <= bounds["blur 0.5 cm"] <= bounds["blur 8 cm"] <= 1.0
    assert all(describe_oracle(name) for name in bounds)  # each row says what it is handed
    # as eval says it: an unknown split was a ValueError after decoding, an empty one {}
    with pytest.raises(DatasetError, match="split 'val' is not one of train, test, sweep"):
        dataset_bounds(data, split="val")
    with pytest.raises(DatasetError, match="has no sweep trials; it holds train, test trials"):
        dataset_bounds(data, split="sweep")


@pytest.mark.slow
def test_eval_plots_where_along_the_limb_and_at_what_total_force_the_model_errs(
    model: Path, data: Path, tmp_path: Path
) -> None:
    """The table gives one ratio per group; the plot shows where on the limb the error
    lies and whether high totals are estimated too low, from every step's truth and
    estimate after Eq. 2, as the model's own `run` gives them."""
    plot = tmp_path / "figures" / "eval.png"
    code, output = invoke("eval", model, data, "-q", "--plot", plot)
    assert code == 0 and output.endswith(f"wrote {plot}\n"), output
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    arrays = load_dataset(data, progress=False)
    rows = arrays.rows("test")
    profile = ErrorProfile(arrays.n_points)
    score_sequences(
        load_model(model), arrays.sequences(rows), arrays.force_maps(rows), profile=profile
    )
    estimator = load_model(model).estimator()
    truths, estimates = [], []
    for phi, truth in zip(arrays.sequences(rows), arrays.force_maps(rows), strict=True):
        estimator.reset()
        estimates.append(estimator.run(phi)[0])
        truths.append(truth)
    truth, estimate = (np.concatenate(maps).astype(np.float64) for maps in (truths, estimates))
    assert profile.steps == len(truth) and truth.any()
    np.testing.assert_allclose(profile.mean_true, truth.mean(axis=0), atol=1e-12)
    np.testing.assert_allclose(profile.mean_estimate, estimate.mean(axis=0), atol=1e-6)
    np.testing.assert_allclose(profile.rmse, np.sqrt(((estimate - truth) ** 2).mean(0)), atol=1e-6)
    np.testing.assert_allclose(profile.totals[:, 0], truth.sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(profile.totals[:, 1], estimate.sum(axis=1), rtol=1e-5, atol=1e-6)
    fig = eval_figure(profile, "gown", "title")
    where, how_much = fig.axes[:2]
    labels = [line.get_label() for line in where.get_lines()[:3]]
    assert labels == ["true force", "estimate", "RMSE"]
    r = np.corrcoef(truth.sum(axis=1), estimate.sum(axis=1))[0, 1]
    assert how_much.get_title() == f"How much: total force per step (r = {r:.2f})"
    matplotlib.pyplot.close(fig)
    code, output = invoke("eval", model, data, "-q", "--plot", tmp_path / "eval.jpg")
    assert (code, output) == (
        1, f"Error: {tmp_path / 'eval.jpg'}: a plot is a PNG image; name it .png\n"
    ), output  # fmt: skip


@pytest.mark.slow
def test_eval_writes_each_sequences_spec_outcome_and_scores(
    model: Path, data: Path, tmp_path: Path
) -> None:
    """Which trials the model gets wrong, and what their specs share: one row per
    sequence of the split, whose RMSEs average to the report's."""
    import csv

    table = tmp_path / "per-sequence.csv"
    for split in ("train", "test"):
        code, output = invoke("eval", model, data, "--split", split, "--per-sequence", table,
                              "--json", "--overwrite")  # fmt: skip
        assert code == 0, output
        overall = json.loads(output)["overall"]
        rows = list(csv.DictReader(table.open()))
        entries = load_manifest(data).split(split)
        assert [r["file"] for r in rows] == [e.file for e in entries]
        assert [(r["outcome"], int(r["steps"]), int(r["seed"])) for r in rows] == [
            (e.outcome.value, e.steps, e.spec.seed) for e in entries
        ]
        speeds = [e.spec.speed for e in entries]
        assert [float(r["speed"]) for r in rows] == pytest.approx(speeds, rel=1e-5)
        assert float(rows[0]["limb_offset_x"]) == pytest.approx(0.30)  # the fixture's
        assert np.mean([float(r["rmse"]) for r in rows]) == pytest.approx(overall["rmse"], 1e-5)
        zero = np.mean([float(r["zero_rmse"]) for r in rows])
        assert zero == pytest.approx(overall["zero_rmse"], 1e-5)
    code, output = invoke("eval", model, data, "-q", "--per-sequence", table)  # no --overwrite
    assert (code, output) == (
        1, f"Error: {table}: file exists; pass --overwrite to replace it\n"
    ), output  # fmt: skip
    code, output = invoke("eval", model, data, "-q", "--per-sequence", tmp_path / "s.txt")
    assert (code, output) == (
        1, f"Error: {tmp_path / 's.txt'}: a table is a CSV file; name it .csv\n"
    ), output  # fmt: skip
    assert not (tmp_path / "s.txt").exists()


@pytest.mark.slow
@prints_warnings
def test_training_on_trials_that_never_touch_the_limb_is_warned_about(
    data: Path, tmp_path: Path
) -> None:
    """Short trials, the natural first try, end before the garment reaches the arm: the
    model learnt to estimate nothing, and only `eval --bounds` said why."""
    away = tmp_path / "away"
    far = {"duration": 0.3, "limb_offset": (0, 5, 0)}
    generate(
        "gown", 2, away, execution=Execution(workers=1), test_fraction=0, overrides=far
    )  # all to train on
    tiny = ["--epochs", "1", "--hidden", "4", "--layers", "1", "-q"]
    for folder, warned in ((away, True), (data, False)):
        args = ["train", str(folder), "-o", str(tmp_path / f"m-{folder.name}"), *tiny]
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 0, result.output
        said = f"Warning: {folder}: no training sequence (outcomes: " in result.stderr
        assert said is warned, result.stderr
        assert ("generate longer trials (--duration)" in result.stderr) is warned


@pytest.mark.slow
@prints_warnings
def test_an_incomplete_dataset_is_used_with_a_warning(
    model: Path, data: Path, tmp_path: Path
) -> None:
    """What an interrupted `generate` leaves: usable, but the user is told."""

    part = tmp_path / "part"
    shutil.copytree(data, part)
    raw = json.loads((part / "manifest.json").read_text())
    raw["trials"] = [e for e in raw["trials"] if e["file"] != "train/000002.mcap"]
    (part / "manifest.json").write_text(json.dumps(raw))
    (part / "train" / "000002.mcap").unlink()
    result = CliRunner().invoke(main, ["eval", str(model), str(part), "-q"])
    assert result.exit_code == 0, result.output
    warning = "Warning: " + str(part) + ": the dataset is incomplete (2/3 train, 1/1 test)"
    assert warning in result.output and "Traceback" not in result.output
    code, output = invoke("info", part)
    assert code == 0 and warning in output, output
    code, output = invoke("eval", model, data, "-q")
    assert code == 0 and "Warning" not in output


@pytest.mark.slow
def test_a_file_inside_a_model_or_dataset_folder_points_to_the_folder(
    model: Path, data: Path
) -> None:
    code, output = invoke("eval", model / "card.json", data)
    assert code == 1 and f"give {model}" in output, output
    code, output = invoke("eval", model, data / "manifest.json")
    assert code == 1 and f"give its folder, {data}" in output, output
    for inside, kind in ((model / "card.json", "dresslog model"), (data / "manifest.json", "")):
        code, output = invoke("info", inside)
        assert code == 0 and kind in output and "Traceback" not in output, output


@pytest.mark.skipif(sys.platform == "win32", reason="symbolic links need privileges there")
def test_train_over_a_model_behind_a_symbolic_link_keeps_the_link(
    data: Path, tmp_path: Path
) -> None:
    """`models/current -> v1`: the swap replaced the link with a folder and left the old
    link behind, hidden; a link to nothing failed after the training, naming a temporary."""
    tiny = ["--epochs", "1", "--hidden", "4", "--layers", "1", "-q"]
    shm = Path("/dev/shm")  # the folder on another file system, if there is one
    apart = shm.is_dir() and os.access(shm, os.W_OK)
    apart = apart and shm.stat().st_dev != tmp_path.stat().st_dev
    with tempfile.TemporaryDirectory(dir=shm if apart else tmp_path) as elsewhere:
        v1 = Path(elsewhere) / "v1"
        v1.mkdir()
        (current := tmp_path / "current").symlink_to(v1)
        code, output = invoke("train", data, "-o", current, *tiny)
        assert code == 0, output
        code, output = invoke("train", data, "-o", current, *tiny, "--epochs", "2", "--overwrite")
        assert code == 0, output
        assert current.is_symlink() and len(load_model(v1).card.history) == 2
        files = ["card.json", "model.safetensors", "training.png"]
        assert sorted(p.name for p in v1.iterdir()) == files
    (dangling := tmp_path / "gone").symlink_to("nowhere")
    code, output = invoke("train", data, "-o", dangling, *tiny)
    assert code == 1 and "is a symbolic link to nothing" in output, output


@pytest.mark.slow
def test_train_into_the_current_folder(
    data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (here := tmp_path / "here").mkdir()
    monkeypatch.chdir(here)
    code, output = invoke("train", data, "-o", ".", "--epochs", "1", "--hidden", "4", "-q")
    assert code == 0, output
    assert load_model(here).card.task == Task.GOWN
    inode = Path().stat().st_ino  # over the model here: its files replaced, not the folder
    code, output = invoke("train", data, "-o", ".", "--epochs", "2", "--hidden", "4", "-q",
                          "--overwrite")  # fmt: skip
    assert code == 0 and Path().stat().st_ino == inode == here.stat().st_ino, output
    assert len(load_model(here).card.history) == 2
    # the README's `-o models/gown` on a fresh checkout: the folders are made
    code, output = invoke("train", data, "-o", "models/g", "--epochs", "1", "--hidden", "4", "-q")
    assert code == 0, output
    assert sorted(p.name for p in (here / "models").iterdir()) == ["g"]
    (here / "file").write_text("")
    code, output = invoke("train", data, "-o", "file/g", "--epochs", "1", "--hidden", "4")
    assert code == 1 and "file is a file, not a folder" in output
    long = "m" * 220  # fits, but its checkpoint's temporary name beside it would not
    code, output = invoke("train", data, "-o", long, "--epochs", "1", "--hidden", "4")
    assert code == 1 and output.startswith(f"Error: {long}: file name is too long"), output


def test_a_test_set_of_fresh_seeds_alone_scores_a_model(model: Path, data: Path) -> None:
    """`--test-fraction 1` makes a folder to score models on, the README's fresh trials:
    its test slots are drawn as any folder's of that seed, so the same trial scores alike."""
    fresh = data.parent / "fresh"
    near = {"duration": 1.5, "limb_offset": (0.30, 0.0, 0.05)}  # the `data` fixture's
    with warnings.catch_warnings():  # no training trials asked for: nothing to warn of
        warnings.simplefilter("error")
        manifest = generate(
            "gown", 1, fresh, execution=Execution(workers=1), test_fraction=1, overrides=near
        )
    assert (manifest.n_train, manifest.n_test) == (0, 1)
    own, other = (json.loads(invoke("eval", model, d, "--json")[1]) for d in (data, fresh))
    assert other["overall"]["n"] == 1 and other["overall"] == own["overall"]
    code, output = invoke("train", fresh, "-o", data.parent / "none", "--epochs", "1")
    assert code == 1 and "needs at least 2 training trials, has 0" in output


@prints_warnings
def test_eval_says_why_its_ratios_are_nan_when_the_split_has_no_force(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The all-zero RMSE is 0, so every ratio divides by 0: eval printed nan unexplained,
    where train warns of the same data; and the bounds say there is nothing to place."""
    monkeypatch.chdir(tmp_path)
    data = "early"  # the first 0.3 s: the gown hangs clear of the hand (seed 2's trial)
    args = ["--task", "gown", "--trials", "1", "--test-fraction", "1", "--duration", "0.3",
            "--seed", "2"]  # fmt: skip
    code, output = invoke("generate", *args, "--out", data, "--workers", "1", "-q")
    assert code == 0, output
    model = SAMPLES / "models" / "gown"
    result = CliRunner().invoke(main, ["eval", str(model), data, "--bounds", "-q"])
    assert result.exit_code == 0, result.output
    assert "oracle ratios: none, no force on the limb" in result.stdout
    assert "    nan" in result.stdout  # the ratio column
    assert result.stderr == (
        "Warning: early: no test sequence (outcomes: missed) carries force on the limb, so "
        "the all-zero RMSE is 0 and the ratios to it, as contact recall, are not numbers "
        "(nan); score the model on longer trials (generate --duration)\n"
    )
    result = CliRunner().invoke(main, ["eval", str(model), data, "--bounds", "--json"])
    assert result.exit_code == 0 and json.loads(result.stdout)["bounds"] == {}
    assert json.loads(result.stdout)["overall"]["ratio"] is None
    assert result.stderr.startswith("Warning: early: no test sequence")


#: The fields a folder of the current simulator saves beside what its request fixed.
V9 = {"sim": {"simulator": 9}}


#: A recorder for `generate` that simulates its second trial with the arm a metre away.
def record_one_away(spec: TrialSpec, path: Path, *, overwrite: bool = False) -> object:
    """Real simulations: slot 0 records the README's dressed gown (seed 42), slot 1 its
    own spec with the limb moved out of the garment's reach (missed, with no force)."""
    from dresslog.sim import random_spec, record_trial

    if Path(path).stem.endswith("1"):
        spec = spec.model_copy(update={"limb_offset": (0.0, 1.0, 0.0)})
    else:
        spec = random_spec(spec.task, 42)
    return record_trial(spec, path, overwrite=overwrite)


ONE_AWAY = record_one_away


@pytest.mark.slow
def test_eval_says_why_an_outcomes_ratio_is_nan_when_that_outcome_has_no_force(
    tmp_path: Path,
) -> None:
    """The split has force, so nothing is warned of, but its missed trial none: that row's
    ratio printed nan unexplained, beside a dressed row and an overall ratio of numbers."""
    data = tmp_path / "edge"  # one trial the arm takes force in, one whose arm is away
    generate("gown", 2, data, execution=Execution(workers=2, recorder=ONE_AWAY), test_fraction=1,
             overrides={"duration": 1.0}, progress=False)  # fmt: skip
    model = SAMPLES / "models" / "gown"
    result = CliRunner().invoke(main, ["eval", str(model), str(data), "-q"])
    assert result.exit_code == 0 and result.stderr == "", result.output
    groups = ("all", "dressed", "missed", "caught")
    rows = {
        words[0]: words[1:]
        for words in map(str.split, result.stdout.splitlines())
        if words and words[0] in groups
    }
    assert rows["all"][3] != "nan" and rows["dressed"][3] != "nan"  # n, RMSE, zero, ratio
    assert rows["missed"][2:4] == ["0.00000", "nan"]
    assert (
        "nan: no missed sequence carries force on the limb, so their all-zero RMSE is 0 and "
        "the ratios to it, as contact recall, are not numbers"
    ) in result.stdout.splitlines()
    result = CliRunner().invoke(main, ["eval", str(model), str(data), "--json"])
    assert result.exit_code == 0 and result.stderr == "", result.output
    missed = json.loads(result.stdout)["per_outcome"]["missed"]
    assert missed["n"] == 1 and missed["zero_rmse"] == 0 and missed["ratio"] is None


def test_sweep_says_why_its_ratios_are_nan_when_no_sequence_has_force(
    sample_swept: tuple[Path, Result],
) -> None:
    """As eval: sweep's table printed nan in both ratio columns, unexplained."""
    out, result = sample_swept
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines()[1].split()[-2:] == ["nan", "nan"]  # in-range
    assert result.stderr == (
        f"Warning: {out}: no sweep sequence of in-range, speed:0.2, rot:z:10 carries force on the "
        "limb, so the all-zero RMSE is 0 and the ratio to it is not a number (nan), as is "
        "x in-range, the in-range RMSE being 0 too; sweep longer sequences (--duration)\n"
    )


@pytest.mark.slow
@short_sequences
def test_sweep_writes_a_table_and_a_plot(
    model: Path, swept: tuple[Path, int, str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out, code, output = swept  # without -o: MODEL-sweep in the current folder
    monkeypatch.chdir(out.parent)
    assert code == 0, output
    assert "trained at speeds 0.1-0.15 m/s, the limb never turned\n" in output  # the card's
    assert f"wrote {model.name}-sweep: sweep.csv, sweep.json and sweep.png" in output
    assert not model.with_name(f"{model.name}-sweep").exists()
    assert "in-range" in output and "speed:0.2" in output and "rot:z:10" in output
    rows = (out / "sweep.csv").read_text().splitlines()
    assert len(rows) == 4 and rows[1].startswith("in-range,baseline")
    assert (out / "sweep.png").read_bytes()[:4] == b"\x89PNG"

    def strict(constant: str) -> None:
        raise AssertionError(f"{constant} is not JSON")

    saved = json.loads((out / "sweep.json").read_text(), parse_constant=strict)
    assert saved["settings"][0]["value"] is None  # the in-range setting has no swept value
    # the JSON carries the table's ratio to in-range, as the CSV does
    ratios = [float(row.split(",")[-1]) for row in rows[1:]]
    assert [s["ratio_to_in_range"] for s in saved["settings"]] == pytest.approx(ratios, 1e-3)
    # what the model was trained on, from its card: the `data` fixture drew its speeds
    assert (saved["trained_speeds"], saved["trained_rotations"]) == ([[0.10, 0.15]], [])
    assert saved["trained_unturned"] is True
    speeds = {e.spec.speed for e in load_manifest(out / "speed_0.2").trials}
    assert speeds == {0.2}
    # every setting re-simulates the same sequences: same seeds, same paths
    paths = [
        sorted((e.spec.seed, tuple(e.spec.control_points)) for e in load_manifest(out / f).trials)
        for f in ("in-range", "speed_0.2", "rot_z_10")
    ]
    assert paths[0] == paths[1] == paths[2] and len(paths[0]) == 2
    code, output = invoke("sweep", model, "--speeds", "0.2", "-n", "1", "--duration", "0.3")
    assert code == 1 and "has 2 sweep trials, more than the 1 asked for (-n sets it)" in output
    before = (out / "in-range" / "manifest.json").read_bytes()
    code, output = invoke(
        "generate", "--task", "gown", "--trials", "2", "-o", out / "in-range", "--duration", "0.3"
    )
    assert code == 1 and "holds 2 sweep trials, made by `dresslog sweep`" in output
    assert (out / "in-range" / "manifest.json").read_bytes() == before
    for command in (("eval", model, out), ("train", out, "-o", tmp_path / "m")):
        code, output = invoke(*command)  # the sweep's own folder, not one of its settings'
        assert code == 1 and "a sweep's folder: `dresslog sweep` scores its settings" in output


@pytest.mark.slow
@prints_warnings
def test_a_sweep_of_longer_sequences_than_the_training_says_so(model: Path, tmp_path: Path) -> None:
    """Sequences longer than the training's passed silently, as if the model's error on
    them were its fit: the sweep now warns before simulating and its line and plot say it."""
    out = tmp_path / "sweep"
    args = ["sweep", str(model), "--speeds", "0.2", "-n", "1", "--duration", "2"]
    result = CliRunner().invoke(main, [*args, "--workers", "1", "-q", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith(
        "Warning: sweep sequences of 2 s run longer than the model's training trials "
        "(1.5 s), so every setting's error"
    )
    trained = "trained at speeds 0.1-0.15 m/s, the limb never turned, on 1.5 s trials (these 2 s)"
    assert f"{trained}\n" in result.stdout
    saved = json.loads((out / "sweep.json").read_text())
    assert (saved["duration"], saved["trained_duration"]) == (2, 1.5)
    result = CliRunner().invoke(
        main,
        [
            "sweep",
            str(model),
            "--speeds",
            "0.2",
            "-n",
            "1",
            "--duration",
            "1",
            "-q",
            "-o",
            str(tmp_path / "short"),
        ],
    )
    assert result.exit_code == 0 and "trials (these" not in result.output  # a prefix
    # no --duration: the spec's 7 s, longer than this model's 1.5 s, is warned of too
    args = ["sweep", str(model), "--speeds", "0.2", "-n", "1", "--workers", "2", "-q"]
    result = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "default")])
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith("Warning: sweep sequences of 7 s run longer than the model's")
    assert "on 1.5 s trials (these 7 s)\n" in result.stdout


@pytest.mark.slow
@prints_warnings
def test_a_sweep_run_again_with_other_values_tables_every_complete_setting(
    model: Path, swept: tuple[Path, int, str], tmp_path: Path
) -> None:
    """The table, JSON and plot held only the settings of the last run, the others'
    folders left on disk unsaid."""
    out = tmp_path / "sweep"
    shutil.copytree(swept[0], out)  # a first run: speed 0.2, rotation z:10, 2 of 0.3 s
    assert swept[1] == 0, swept[2]
    common = ["--duration", "0.3", "--workers", "2", "-q", "-o", out]
    code, output = invoke("sweep", model, "--speeds", "0.15", "-n", "2", *common)
    assert code == 0 and "Warning" not in "".join(lines(output)), output
    names = ["in-range", "speed:0.15", "speed:0.2", "rot:z:10"]
    assert [row.split()[0] for row in lines(output)[1:5]] == names
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == names
    saved = json.loads((out / "sweep.json").read_text())
    assert [s["name"] for s in saved["settings"]] == names
    # of other sequences (-n 3 extends in-range): not comparable, left out and named
    code, output = invoke("sweep", model, "--speeds", "0.25", "-n", "3", *common)
    assert code == 0, output
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == ["in-range", "speed:0.25"]
    warning = [line for line in lines(output) if line.startswith("Warning: ")]
    assert len(warning) == 1, output
    assert "speed:0.15 (2/2 sweep), speed:0.2 (2/2 sweep), rot:z:10 (2/2 sweep);" in warning[0]


@pytest.mark.slow
@prints_warnings
def test_a_damaged_earlier_sweep_setting_is_left_out_and_named_not_fatal(
    sample_swept: tuple[Path, Result], tmp_path: Path
) -> None:
    """A corrupt trial in an earlier run's setting stopped the new sweep with "run `dresslog
    generate` on the folder again" (which refuses a sweep's folder), and a missing one was
    called "not 1 complete sequences" beside "(1/1 sweep)"."""
    model, out = SAMPLES / "models" / "gown", tmp_path / "sweep"
    shutil.copytree(sample_swept[0], out)  # a first run: speed 0.2, rotation z:10
    common = ["-n", "1", "--duration", "0.3", "--workers", "1", "-q", "-o", out]
    code, output = invoke("sweep", model, "--speeds", "0.25", *common)  # an intact one
    assert code == 0, output
    trial = out / "speed_0.2" / "sweep" / "000000.mcap"
    data = bytearray(trial.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 400] = bytes(400)  # the same size: only its checksum tells
    trial.write_bytes(bytes(data))
    (out / "rot_z_10" / "sweep" / "000000.mcap").unlink()
    for folder in ("speed_0.2", "rot_z_10"):
        shutil.rmtree(out / folder / ".cache", ignore_errors=True)
    code, output = invoke("sweep", model, "--speeds", "0.15", *common)
    assert code == 0, output
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == ["in-range", "speed:0.15", "speed:0.25"]
    warning = [line for line in lines(output) if line.startswith("Warning: ")]
    assert warning == [
        f"Warning: {out}: left out of the table, as damaged: "
        "speed:0.2 (a trial is damaged or missing; sweep it again with --speeds 0.2), "
        "rot:z:10 (a trial is damaged or missing; sweep it again with --rotations z:10)"
    ], output
    code, output = invoke("sweep", model, "--speeds", "0.2", "--rotations", "z:10", *common)
    assert code == 0 and "Warning" not in "".join(lines(output)), output  # the cure it names works
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert len(rows) == 5, rows


@pytest.mark.slow
@short_sequences
def test_the_sweep_table_lists_settings_by_kind_axis_and_value_as_the_plot_does(
    sample_swept: tuple[Path, Result], tmp_path: Path
) -> None:
    """Rows came in the order asked, this run's before earlier runs': 0.25, 0.15, 0.2."""
    model, out = SAMPLES / "models" / "gown", tmp_path / "sweep"
    shutil.copytree(sample_swept[0], out)  # a first run: speed 0.2, rotation z:10
    common = ["-n", "1", "--duration", "0.3", "--workers", "1", "-q", "-o", out]
    code, output = invoke("sweep", model, "--speeds", "0.25,0.15", "--rotations", "y:-5", *common)
    assert code == 0, output
    names = ["in-range", "speed:0.15", "speed:0.2", "speed:0.25", "rot:y:-5", "rot:z:10"]
    assert [row.split()[0] for row in lines(output)[1:7]] == names, output
    rows = (out / "sweep.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == names
    saved = json.loads((out / "sweep.json").read_text())
    assert [s["name"] for s in saved["settings"]] == names


@short_sequences
def test_sweep_never_writes_into_a_dataset_or_a_model_folder(
    model: Path, data: Path, tmp_path: Path
) -> None:
    for folder, out in ((data, data), (model, model), (data, data / "train" / "sweep")):
        before = sorted(folder.rglob("*"))
        code, output = invoke("sweep", model, "--speeds", "0.2", "-n", "1", "-o", out)
        assert code == 1 and "give the sweep a folder of its own" in output
        assert sorted(folder.rglob("*")) == before
    (web := tmp_path / "webapp").mkdir()  # another tool's manifest.json is no dataset
    (web / "manifest.json").write_text('{"name": "webapp", "version": "1.0"}')
    args = ["-n", "1", "--duration", "0.2", "--workers", "1", "-q", "-o", web / "sweep"]
    code, output = invoke("sweep", model, "--speeds", "0.2", *args)
    assert code == 0, output


def test_a_sweep_value_given_twice_is_one_setting() -> None:
    settings = sweep_settings(Task.GOWN, ["0.2", "0.20", "0.25"], ["z:-0", "z:0", "z:0.0"])
    assert [s.name for s in settings] == ["in-range", "speed:0.2", "speed:0.25", "rot:z:0"]
    # two values %g would print alike are two settings (the second was dropped)
    close = sweep_settings(Task.GOWN, ["0.1234567", "0.1234568"], [])
    assert [s.name for s in close[1:]] == ["speed:0.1234567", "speed:0.1234568"]
    # a script's float32 speeds name the folders a command-line sweep made
    single = sweep_settings(Task.GOWN, list(np.array([0.2, 0.25], np.float32)), [])
    assert [s.name for s in single[1:]] == ["speed:0.2", "speed:0.25"]


def test_a_sweep_called_from_a_script_says_what_is_wrong_with_its_arguments(
    model: Path, tmp_path: Path
) -> None:
    """A zero duration was dropped (every trial ran 7 s), a str swept letter by letter,
    and an output that is a file was a FileExistsError traceback."""

    wrong = [
        ({"speeds": [0.2], "duration": 0}, "in-range: invalid duration"),
        ({"speeds": "0.2"}, "speeds must be a list of values, not the one '0.2'"),
        ({"speeds": 0.2}, "speeds must be a list of values"),
        ({"rotations": "z:15"}, "rotations must be a list of values"),
    ]
    for arguments, message in wrong:
        with pytest.raises(DatasetError, match=re.escape(message)):
            sweep(model, tmp_path / "s", n=1, **arguments)
        assert not (tmp_path / "s").exists()
    (taken := tmp_path / "taken").write_text("mine")
    with pytest.raises(DatasetError, match="is a file; give the sweep a folder of its own"):
        sweep(model, taken, speeds=[0.2], n=1)
    assert taken.read_text() == "mine"
    (dangling := tmp_path / "gone").symlink_to("nowhere")
    with pytest.raises(DatasetError, match="is a symbolic link to nothing"):
        sweep(model, dangling, speeds=[0.2], n=1)


@pytest.mark.parametrize(
    ("option", "value", "message", "usage"),
    [
        ("rotations", "z:10,z:999", "rot:z:999: invalid limb_rotation.degrees", True),
        ("speeds", "0.2,-1", "speed:-1: invalid speed", True),
        ("rotations", "z:10,y:88", "rot:y:88: the fist lies inside the rest of the arm", False),
    ],
)
def test_sweep_rejects_a_bad_setting_before_making_its_folder(
    model: Path, tmp_path: Path, option: str, value: str, message: str, usage: bool
) -> None:
    """The library refuses for its callers; `dresslog sweep` refuses a value out of the spec's
    range first, as a usage error, and reports the library's refusal of what only it knows
    (the limb's geometry)."""

    out = tmp_path / "sweep"
    with pytest.raises(DatasetError, match=re.escape(message)):
        sweep(model, out, n=1, **{option: value.split(",")})
    assert not out.exists()
    code, output = invoke("sweep", model, f"--{option}", value, "-o", out)
    if usage:
        assert code == 2 and f"Invalid value for '--{option}'" in output, output
    else:
        assert code == 1 and message in output, output
    assert not out.exists()


def _fake_model(path: Path, task: str) -> Path:
    rng = np.random.default_rng(0)
    n = 300 if task == "gown" else 400
    weights = {
        k: rng.normal(size=s).astype(np.float32) for k, s in expected_shapes(n, 4, 1, 9).items()
    }
    weights["input_mean"], weights["input_std"] = np.zeros(9, np.float32), np.ones(9, np.float32)
    save_model(path, weights, ModelCard(task=task, n_points=n, hidden=4, layers=1))
    return path


def test_eval_refuses_a_model_for_the_other_task(data: Path, tmp_path: Path) -> None:
    code, output = invoke("eval", _fake_model(tmp_path / "shorts", "shorts"), data)
    assert code == 1 and output.count("\n") == 1
    assert "model is for shorts but the data is gown" in output
    assert "--model" not in output  # eval takes the model as its MODEL argument


def test_eval_refuses_a_tampered_model(data: Path, tmp_path: Path) -> None:
    path = _fake_model(tmp_path / "gown", "gown")
    weights = path / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:-4] + b"\0\0\0\0")
    code, output = invoke("eval", path, data)
    assert code == 1 and "does not match the sha256" in output


def test_info_counts_one_epoch_in_the_singular(tmp_path: Path) -> None:
    """A model trained for one epoch (a smoke test's) read `1 epochs` twice."""
    path = _fake_model(tmp_path / "gown", "gown")
    card = load_model(path).card.model_copy(
        update={
            "hyperparameters": Hyperparameters(epochs=1),
            "history": [EpochRecord(epoch=1, train_loss=0.5, seconds=2.0)],
        }
    )
    weights = load_model(path).weights
    save_model(path, weights, card, overwrite=True)
    code, output = invoke("info", path)
    assert code == 0, output
    assert "training  1 epoch, batch 16" in output and "history   1 epoch in 2 s" in output


@pytest.mark.slow
def test_info_summarises_a_model_folder_and_a_dataset_folder(
    model: Path, data: Path, tmp_path: Path
) -> None:
    code, output = invoke("info", model)
    assert code == 0, output
    assert "gown, 300 limb points" in output and "1x4 LSTM" in output
    assert "2 epochs in" in output and "weights   sha256" in output
    assert "  trained   speeds 0.1-0.15 m/s, the limb never turned\n" in output  # as eval's
    older = tmp_path / "format3"
    bundled = load_model(SAMPLES / "models" / "gown")
    save_model(older, bundled.weights, bundled.card)
    card = json.loads((older / CARD_FILE).read_text())
    del card["data"]["folders"]  # as format 3 wrote it: the data named by path only
    (older / CARD_FILE).write_text(json.dumps({**card, "format_version": 3}))
    code, output = invoke("info", older)  # a card before format 4
    assert (
        code == 0
        and (
            "  trained   speeds 0.1-0.15 m/s, the limb never turned (generate's defaults taken "
            "where the card does not record them)\n"
        )
        in output
    ), output
    code, output = invoke("info", model, "--json")
    assert code == 0 and ModelCard.model_validate_json(output) == load_model(model).card
    code, output = invoke("info", data)
    assert code == 0 and output.startswith(f"{data}: gown trials 3/3 train, 1/1 test; outcomes")
    code, output = invoke("info", data, "--json")
    assert code == 0 and json.loads(output)["task"] == "gown"


@pytest.mark.slow
def test_train_init_fine_tunes_a_model_and_its_card_and_info_name_it(
    model: Path, data: Path
) -> None:
    """`train --init MODEL`: the initial model's network, on this data, named in the card;
    a network option may repeat the model's (--hidden 4) but not change it."""
    out = data.parent / "fine-tuned"
    code, output = invoke("train", data, "-o", out, "--init", model, "--hidden", "4", "-q",
                          "--epochs", "1", "--lr", "1e-4")  # fmt: skip
    assert code == 0, output
    initial, tuned = load_model(model).card, load_model(out).card
    assert (tuned.hidden, tuned.layers, tuned.data.n_train) == (4, 1, 3)
    assert tuned.init is not None and tuned.init.weights_sha256 == initial.weights_sha256
    assert tuned.init.manifest_sha256 == initial.data.manifest_sha256
    assert tuned.init.test_ratio == initial.metrics["test_ratio"]
    code, output = invoke("info", out)
    assert (
        code == 0
        and (
            f"  init      fine-tuned from {model} (weights {initial.weights_sha256[:12]}, "
            f"test ratio {initial.metrics['test_ratio']:.3f})"
        )
        in output.splitlines()
    ), output
    code, output = invoke("train", data, "-o", out.with_name("8"), "--init", model, "--hidden", "8")
    assert (code, output) == (
        1,
        f"Error: {model}: --hidden 8 would change the initial model's network (1x4 LSTM), "
        "which fine-tuning keeps; leave --hidden out\n",
    )


@pytest.mark.slow
def test_a_fine_tuned_cards_signal_covers_the_initial_models_training_data_too(
    model: Path, data: Path
) -> None:
    """`infer` calls a trial unfamiliar by the card's `data.signal`: a model fine-tuned on
    rotated trials has learnt the in-range ones too, and must not call them unfamiliar."""
    elsewhere = data.parent / "trained-elsewhere"
    shutil.copytree(model, elsewhere)
    card = json.loads((elsewhere / CARD_FILE).read_text())  # as if trained on other data
    card["data"]["signal"] = {"mean": [1.0] * 9, "std": [2.0] * 9}
    (elsewhere / CARD_FILE).write_text(json.dumps(card))
    out = data.parent / "tuned-elsewhere"
    code, output = invoke("train", data, "-o", out, "--init", elsewhere, "-q", "--epochs", "1")
    assert code == 0, output
    arrays = load_dataset(data, progress=False)
    own = np.concatenate(arrays.sequences(arrays.rows("train")))
    before = card["data"]["n_train"] + card["data"]["n_val"]
    share = before / (before + 3)
    mean = share * 1.0 + (1 - share) * own.mean(0)
    variance = share * (4.0 + 1.0) + (1 - share) * (own.var(0) + own.mean(0) ** 2) - mean**2
    seen = load_model(out).card.data.signal
    assert seen is not None
    np.testing.assert_allclose(seen.mean, mean, rtol=1e-6)
    np.testing.assert_allclose(seen.std, np.sqrt(variance), rtol=1e-6)


@pytest.mark.slow
def test_train_pools_several_dataset_folders_of_one_task(
    data: Path, turned: Path, tmp_path: Path
) -> None:
    """`train A B`: both training splits to learn from, both test splits to score on, and
    the card naming both; a folder given twice, or of the other task, is refused."""
    out = tmp_path / "pooled"
    code, output = invoke("train", data, turned, "-o", out, "--epochs", "1", "--hidden", "4",
                          "--layers", "1", "-q")  # fmt: skip
    assert code == 0, output
    card = load_model(out).card
    assert (card.data.n_train, card.metrics["test_n_sequences"]) == (3 + 2, 1 + 1)
    assert card.data.description == f"{data} + {turned}"
    hashes = [load_manifest(folder).content_hash() for folder in (data, turned)]
    assert card.data.manifest_sha256 == hashlib.sha256(" ".join(hashes).encode()).hexdigest()
    code, output = invoke("train", data, turned, data, "-o", tmp_path / "m")
    assert (code, output) == (
        1,
        f"Error: {data}: is given twice; give each dataset folder once\n",
    )
    shorts = tmp_path / "shorts"
    generate(
        "shorts",
        2,
        shorts,
        execution=Execution(workers=1),
        test_fraction=0,
        overrides={"duration": 0.1},
    )
    code, output = invoke("train", data, shorts, "-o", tmp_path / "m")
    assert (code, output) == (
        1,
        f"Error: {shorts}: holds shorts trials but {data} holds gown; "
        "a model is trained for one task\n",
    )
    assert not (tmp_path / "m").exists()


@pytest.mark.slow
def test_a_model_of_one_simulator_is_swept_and_scored_on_its_own(tmp_path: Path) -> None:
    """A model trained on trials of simulator v8 reads such trials only: its sweep
    simulates them so, and `eval` names another version's."""
    near = {"duration": 0.5, "limb_offset": [0.30, 0.0, 0.05]}
    balanced = tmp_path / "balanced"
    generate("gown", 3, balanced, execution=Execution(workers=2), test_fraction=1 / 3,
             overrides={**near, "sim": {"simulator": 8, "wrench_from": "momentum"}})  # fmt: skip
    model = tmp_path / "model"
    code, output = invoke("train", balanced, "-o", model, "--epochs", "1", "--hidden", "4",
                          "--layers", "1", "-q")  # fmt: skip
    assert code == 0, output
    with pytest.warns(DresslogWarning, match="no sweep sequence"):  # 0.5 s reach no limb
        report = sweep(model, tmp_path / "sweep", speeds=[0.12], n=1, duration=0.5,
                       progress=False)  # fmt: skip
    assert [s.name for s in report.settings] == ["in-range", "speed:0.12"]
    for setting in report.settings:
        manifest = load_manifest(tmp_path / "sweep" / setting.folder)
        assert manifest.overrides["sim"] == {"simulator": 8, "wrench_from": "momentum"}
    current = tmp_path / "v9"
    generate("gown", 1, current, execution=Execution(workers=1), test_fraction=1, overrides=near)
    code, output = invoke("eval", model, current)
    assert code == 0, output
    assert "simulator v9 (trained on v8)" in output


@pytest.mark.slow
def test_a_cards_folders_keep_each_training_folders_conditions_through_fine_tuning(
    data: Path, turned: Path, tmp_path: Path
) -> None:
    """A model fine-tuned for a span of rotations named its folders only by path: `sweep`
    shaded the gown's default speeds whatever it was trained on, and could not show the
    span, nor `info` what the trials held."""
    near = {"duration": 1.5, "limb_offset": [0.30, 0.0, 0.05]}  # the `data` fixture's
    span = TURNED
    pooled = tmp_path / "pooled"
    train_dataset(
        [data, turned], pooled, TrainOptions(epochs=1, hidden=4, layers=1), progress=False
    )
    folders = load_model(pooled).card.data.folders
    assert folders == [
        TrainingFolder(folder=str(data), trials=3, overrides={**near, **V9}),
        TrainingFolder(
            folder=str(turned),
            trials=2,
            overrides={**near, "speed": 0.2, **V9},
            rotation_range=span,
        ),
    ]
    tuned = tmp_path / "tuned"
    train_dataset(data, tuned, TrainOptions(epochs=1), init=pooled, progress=False)
    card = load_model(tuned).card
    assert card.init is not None and card.init.folders == folders
    assert card.trained_folders() == [folders[0], *folders]
    seen = trained_conditions(card)
    near_box = ((0.30, 0.30), (0.0, 0.0), (0.05, 0.05))
    assert seen == Conditions(
        ((0.10, 0.15), (0.2, 0.2)),
        (("z", -15, 15),),
        True,
        (near_box,),
        durations=(1.5,),
        simulators=("v9",),
    )
    code, output = invoke("info", tuned)
    assert (
        code == 0
        and (
            f"  init      fine-tuned from {pooled} "
            f"(weights {card.init.weights_sha256[:12]}, test ratio {card.init.test_ratio:.3f})\n"
            f"            {data}: 3 trials; 1.5 s long, limb_offset [0.3, 0.0, 0.05], "
            "sim {'simulator': 9}\n"
            f"            {turned}: 2 trials; 1.5 s long, limb_offset [0.3, 0.0, 0.05], "
            "speed 0.2 m/s, sim {'simulator': 9}, rotation z -15...+15 deg drawn per trial\n"
            "  trained   speeds 0.1-0.15, 0.2 m/s; the limb unturned or turned about z "
            "-15...+15 deg\n"
        )
        in output
    ), output
    older = _before_format_4(load_model(SAMPLES / "models" / "gown").card)
    assert older.trained_folders() == [_unrecorded(older)]  # conditions not kept
    assert trained_conditions(older) == CURRENT  # a card that cannot say: generate's now


def _before_format_4(card: ModelCard) -> ModelCard:
    """`card` as format 3 wrote it (the v7 bundled models'): its data named by path only."""
    data = card.data.model_copy(update={"folders": None})
    return card.model_copy(update={"format_version": 3, "data": data})


def _unrecorded(card: ModelCard) -> TrainingFolder:
    return TrainingFolder(folder=card.data.description, trials=card.data.n_train + card.data.n_val)


#: The conditions of a v7 folder of `generate`'s gown trials: speeds drawn over 10-15 cm/s,
#: no rotation, limb offsets drawn over the paper's numbers on our axes, 7 s long.
DEFAULTS = Conditions(
    ((0.10, 0.15),), (), True, (((-0.05, 0.05), (-0.2, 0.2), (-0.1, 0.1)),), (7.0,)
)
#: The same of `generate` now (simulator v9): the offsets mapped from the paper's frame.
CURRENT = Conditions(
    ((0.10, 0.15),), (), True, (((-0.05, 0.05), (-0.1, 0.1), (-0.2, 0.2)),), (7.0,), ("v9",)
)


def test_a_card_before_format_4_gives_its_data_and_its_initial_models_as_not_recorded() -> None:
    """A format-3 card (the v7 bundled models') names its data by path only; so does one
    of a fine-tuned model, whose initial model's data it names not at all."""
    older = _before_format_4(load_model(SAMPLES / "models" / "gown").card)
    tuned = older.model_copy(
        update={"init": InitialModel(description="runs/first", weights_sha256="0" * 64)}
    )
    assert tuned.trained_folders() == [
        _unrecorded(older),
        TrainingFolder(folder="the data of runs/first"),
    ]
    assert trained_conditions(tuned) == CURRENT  # as generate's now


def held(overrides: dict | None = None, span: RotationRange | None = None) -> Conditions:
    """The conditions of a gown dataset whose manifest fixed `overrides` and drew `span`."""
    manifest = Manifest(task=Task.GOWN, n_train=0, n_test=0, overrides=overrides or {},
                        rotation_range=span)  # fmt: skip
    return data_conditions(manifest)


def test_the_conditions_a_model_was_not_trained_on_are_named() -> None:
    """What `eval` tells apart: data at a speed or rotation the model never saw, from
    data within its training's spans (a 0 deg rotation is the unturned limb)."""
    z15 = {"limb_rotation": {"axis": "z", "degrees": -15}}
    span = RotationRange(axis="z", low=-15, high=15)
    assert held() == DEFAULTS == held({"limb_rotation": {"axis": "y", "degrees": 0}})
    assert held({"speed": 0.2}).outside(DEFAULTS) == ["speed 0.2 m/s"]
    assert held({"speed": 0.12}).outside(DEFAULTS) == []
    assert held(z15).outside(DEFAULTS) == ["rotation about z -15 deg"]
    assert held(z15).outside(held(span=span)) == held().outside(held(span=span)) == []
    assert held().outside(held(z15)) == ["the limb unturned"]
    assert held(span=span).outside(held(z15)) == ["rotation about z -15...+15 deg"]
    assert held({"speed": 0.2}, span).outside(DEFAULTS) == [
        "speed 0.2 m/s", "rotation about z -15...+15 deg",
    ]  # fmt: skip
    far = {"limb_offset": [0.01, 0.35, -0.02]}
    assert held(far).outside(DEFAULTS) == ["limb offset y +0.35 m (trained on y -0.2...+0.2)"]
    assert held({"limb_offset": [0.01, 0.15, -0.02]}).outside(DEFAULTS) == []
    assert held().outside(held(far)) == [
        "limb offset x -0.05...+0.05, y -0.2...+0.2, z -0.1...+0.1 m "
        "(trained on x +0.01, y +0.35, z -0.02)"
    ]
    assert held(far).describe() == held().describe()  # named only when outside
    assert held({"duration": 20}).outside(DEFAULTS) == ["duration 20 s (trained on 7 s)"]
    assert held({"duration": 1.5}).outside(DEFAULTS) == []  # a shorter trial: a prefix
    v7 = {"sim": {"simulator": 8, "wrench_from": "constraint"}}  # as DEFAULTS' trials
    long = spec_conditions(random_spec("gown", 4, duration=7.5, **v7))  # what `infer` checks
    assert long.outside(DEFAULTS) == ["duration 7.5 s (trained on 7 s)"]
    balanced = {"sim": {"wrench_from": "momentum"}}
    assert held(balanced).outside(DEFAULTS) == ["simulator v8 (trained on v7)"]
    assert held().outside(held(balanced)) == ["simulator v7 (trained on v8)"]
    v9 = held({"sim": {"simulator": 9}})
    assert v9.outside(held(balanced)) == [
        "limb offset z -0.2...+0.2 m (trained on z -0.1...+0.1)",
        "simulator v9 (trained on v8)",
    ]
    assert held(balanced).outside(combined([held(), held(balanced)])) == []
    assert held(z15).describe() == "speeds 0.1-0.15 m/s; the limb turned about z -15 deg"
    assert combined([held(), held(z15)]).describe() == (  # the README's fine-tuning
        "speeds 0.1-0.15 m/s; the limb unturned or turned about z -15 deg"
    )


@pytest.mark.slow
def test_eval_says_when_the_data_lie_outside_what_the_model_was_trained_on(
    model: Path, tmp_path: Path
) -> None:
    """A model scored on faster trials than it was trained on gave a worse ratio with
    nothing to say that it measured generalisation, not the model's fit."""
    faster = tmp_path / "faster"
    near = {"duration": 1.5, "limb_offset": (0.30, 0.0, 0.05), "speed": 0.2}
    generate(
        "gown",
        1,
        faster,
        execution=Execution(workers=1),
        seed=3,
        splits={"test": 1},
        overrides=near,
    )
    code, output = invoke("eval", model, faster, "-q")
    assert code == 0, output
    assert (
        "trials    speeds 0.2 m/s, the limb never turned\n"
        "trained   speeds 0.1-0.15 m/s, the limb never turned\n"
        "outside   speed 0.2 m/s: these figures measure how the model generalises "
        "(as `dresslog sweep` does)\n"
    ) in output, output
    code, output = invoke("eval", model, faster, "--json")
    assert code == 0 and json.loads(output)["outside"] == ["speed 0.2 m/s"], output


def test_train_init_refuses_a_model_for_the_other_task_or_a_tampered_one(
    data: Path, tmp_path: Path
) -> None:
    shorts = _fake_model(tmp_path / "shorts", "shorts")
    code, output = invoke("train", data, "-o", tmp_path / "m", "--init", shorts)
    assert code == 1 and output.count("\n") == 1
    assert "model is for shorts but the data is gown; give a gown model" in output
    gown = _fake_model(tmp_path / "gown", "gown")
    weights = gown / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:-4] + b"\0\0\0\0")
    code, output = invoke("train", data, "-o", tmp_path / "m", "--init", gown)
    assert code == 1 and "does not match the sha256" in output and output.count("\n") == 1
    code, output = invoke("train", data, "-o", tmp_path / "m", "--init", data)  # a slip
    assert (code, output) == (
        1,
        f"Error: {data}: is a dataset folder, not a model: --init takes the model to start "
        "from; give the dataset folders as DATA\n",
    )
    assert not (tmp_path / "m").exists()


def test_info_describes_a_tampered_model_and_fails_and_refuses_a_folder_that_is_neither(
    tmp_path: Path,
) -> None:
    path = _fake_model(tmp_path / "gown", "gown")
    weights = path / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:-4] + b"\0\0\0\0")
    result = CliRunner().invoke(main, ["info", str(path)])
    assert result.exit_code == 1 and "gown, 300 limb points" in result.stdout
    assert "but the model does not load (the error says why)" in result.stdout
    assert result.stderr.count("\n") == 1 and "does not match the sha256" in result.stderr
    code, output = invoke("info", tmp_path)
    assert code == 1 and output.count("\n") == 1
    assert "neither a model folder (no card.json) nor a dataset folder" in output


@pytest.mark.parametrize("name", ["model.safetensors", "training.png"])
def test_info_on_a_model_folders_file_describes_the_model(tmp_path: Path, name: str) -> None:
    """As on its card.json; the weights were read as a trial, "not an MCAP file; for a ROS
    bag or a force/torque CSV, run `dresslog convert` first"."""
    path = _fake_model(tmp_path / "gown", "gown")
    (path / "training.png").write_bytes(b"\x89PNG")
    code, output = invoke("info", path / name)
    assert code == 0 and "dresslog model" in output and "gown, 300 limb points" in output, output


def test_train_refuses_to_overwrite_before_training(data: Path, tmp_path: Path) -> None:
    code, output = invoke("train", data, "-o", _fake_model(tmp_path / "m", "gown"))
    assert code == 1 and "model folder exists; pass --overwrite" in output


@pytest.mark.parametrize("name", ["x.mcap", "x.rrd", "X.MCAP", "x.bag"])
def test_train_refuses_a_model_folder_named_as_a_recording(tmp_path: Path, name: str) -> None:
    """`-o models/x.mcap` made a model folder named x.mcap, which every tool that opens a
    file by its name then took for a trial or a recording."""
    data = tmp_path / "d"
    generate("gown", 2, data, execution=Execution(workers=1, recorder=fake_record), test_fraction=0)
    before = sorted(tmp_path.rglob("*"))
    code, output = invoke("train", data, "-o", tmp_path / "models" / name, "-q")
    stem, suffix = Path(name).stem, Path(name).suffix
    assert code == 1 and output == (
        f"Error: {tmp_path / 'models' / name}: a model is a folder, not a {suffix.lower()} "
        f"recording; name it without {suffix} (e.g. {tmp_path / 'models' / stem})\n"
    ), output
    assert sorted(tmp_path.rglob("*")) == before  # no folder, lock or checkpoint


@pytest.mark.parametrize("name", ["x.mcap", "x.rrd", "X.MCAP", "x.bag"])
@pytest.mark.parametrize("command", ["generate", "sweep"])
def test_generate_and_sweep_refuse_a_folder_named_as_a_recording(
    tmp_path: Path, command: str, name: str
) -> None:
    """As `train` does: `generate -o data/x.mcap` and `sweep -o runs/x.rrd` made folders
    that every tool opening a file by its name then took for a trial or a recording."""
    model = _fake_model(tmp_path / "gown", "gown")
    before = sorted(tmp_path.rglob("*"))
    out = tmp_path / "runs" / name
    what, args = {
        "generate": ("a dataset", ["generate", "--task", "gown", "--trials", "2"]),
        "sweep": ("a sweep", ["sweep", model, "--speeds", "0.2", "-n", "1"]),
    }[command]
    code, output = invoke(*args, "-o", out, "-q")
    stem, suffix = Path(name).stem, Path(name).suffix
    assert code == 1 and output == (
        f"Error: {out}: {what} is a folder, not a {suffix.lower()} recording; name it "
        f"without {suffix} (e.g. {tmp_path / 'runs' / stem})\n"
    ), output
    assert sorted(tmp_path.rglob("*")) == before  # no folder made


@pytest.mark.parametrize(
    ("option", "problem"),
    [
        (["--keep-best"], "needs validation sequences"),  # 10% of 3 trials is none
        (["--window", "150"], "the longest has 150"),  # 1.5 s at 100 Hz
    ],
)
def test_train_refuses_a_bad_option_before_loading_any_trial(
    data: Path, tmp_path: Path, option: list[str], problem: str
) -> None:
    bare = tmp_path / "bare"  # the manifest alone: loading would fail on the first trial
    bare.mkdir()
    (bare / "manifest.json").write_bytes((data / "manifest.json").read_bytes())
    code, output = invoke("train", bare, "-o", tmp_path / "m", *option)
    assert code == 1 and problem in output and "Traceback" not in output, output
    assert not (tmp_path / "m").exists()


def test_train_refuses_a_bad_option_without_loading_torch(data: Path, tmp_path: Path) -> None:
    """Torch takes seconds to import; a typo in an option should not wait for it."""
    args = ["train", str(data), "-o", str(tmp_path / "m"), "--window", "150"]
    code = (
        "import sys; from dresslog.cli.main import main\n"
        f"try: main({args!r})\n"
        "except SystemExit as exit: print(exit.code, 'torch' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1", "False"], out.stdout + out.stderr


def test_train_overwrite_replaces_only_a_model_never_the_data(data: Path) -> None:
    before = sorted(p.relative_to(data) for p in data.rglob("*"))
    code, output = invoke("train", data, "-o", data, "--overwrite")
    assert code == 1 and "folder is not empty and holds no model" in output
    assert sorted(p.relative_to(data) for p in data.rglob("*")) == before


def test_a_saved_model_is_readable_by_others_as_its_card_is(tmp_path: Path) -> None:
    umask = os.umask(0o022)  # the usual one: files readable by all unless made private
    try:
        model = _fake_model(tmp_path / "m", "gown")
    finally:
        os.umask(umask)
    modes = {p.name: p.stat().st_mode & 0o777 for p in model.iterdir()}
    assert modes["model.safetensors"] == modes["card.json"], modes
    assert modes["model.safetensors"] & 0o044 == 0o044, modes  # group and others may read it


def test_sweep_plot_draws_no_trend_through_an_unmeasured_0_deg(tmp_path: Path) -> None:
    settings = [
        replace(s, scores=Scores(8, 0.01 * (i + 1), 0.02, 0.5, 0.8, 0.6, 0.3, 0.4))
        for i, s in enumerate(sweep_settings(Task.SHORTS, [0.2], ["x:15", "x:-15", "z:0", "z:10"]))
    ]
    report = SweepReport("shorts", "m", 8, 0.01, settings)
    x, rmse, zero = sweep_lines(report, "rotation")["x"]
    assert x == [-15, 0, 15] and np.isnan(rmse[1]) and np.isnan(zero[1])  # a gap, not a line
    assert sweep_lines(report, "rotation")["z"] == ([0, 10], [0.05, 0.06], [0.02, 0.02])
    assert sweep_lines(report, "speed") == {"": ([0.2], [0.02], [0.02])}
    plot_sweep(tmp_path / "sweep.png", report)
    assert matplotlib.image.imread(tmp_path / "sweep.png").std() > 0.05


def test_sweep_plot_names_its_model_and_marks_the_training_speeds_and_the_papers_figure() -> None:
    """Both panels were titled "gown, 8 sequences per setting", the model unnamed; nothing
    showed which speeds were in training nor where the paper's model went (4.4x in-range
    at 20 cm/s), which the README's table sets beside ours; nor, later, which rotations a
    fine-tuned model was trained on (a span, shaded in its axis's colour; one fixed, a bar)."""
    settings = [
        replace(s, scores=Scores(8, 0.01, 0.02, 0.5, 0.8, 0.6, 0.3, 0.4))
        for s in sweep_settings(Task.GOWN, [0.2], ["z:-15", "y:-15"])
    ]
    trained = [("x", 0.0, 10.0), ("y", -5.0, -5.0), ("z", -15.0, 15.0)]  # x: not swept
    report = SweepReport(
        "gown", "runs/models/gown-big", 8, 0.005, settings, [(0.10, 0.15)], trained
    )
    fig = sweep_figure(report)
    speed, rotation = fig.axes[:2]
    assert fig.get_suptitle() == (
        "Generalisation sweep of model gown-big (gown), 8 sequences per setting"
    )
    longer = sweep_figure(replace(report, duration=20.0))  # the trials' 7 s by default
    assert longer.get_suptitle().endswith("per setting, on 7 s trials (these 20 s)")
    assert [speed.get_title(), rotation.get_title()] == [
        "against speed (Fig. 12)",
        "against rotation (Fig. 13)",
    ]
    (span,) = speed.patches  # 0.10-0.15 m/s, the gown's training speeds
    assert np.allclose([span.get_x(), span.get_x() + span.get_width()], [0.10, 0.15])
    assert list(speed.get_xticks()) == [0.10, 0.15, 0.2]  # a lone speed beside them
    papers = {
        line.get_label(): (list(line.get_xdata()), list(line.get_ydata()))
        for ax in (speed, rotation)
        for line in ax.get_lines()
        if "the paper" in str(line.get_label())
    }
    assert papers == {
        "the paper (x in-range)": ([0.2], [pytest.approx(4.4 * 0.005)]),
        "about z, the paper (x in-range)": ([-15.0], [pytest.approx(1.65 * 0.005)]),
        "about y, the paper (x in-range)": ([-15.0], [pytest.approx(0.82 * 0.005)]),
    }
    colour = {line.get_label(): line.get_color() for line in rotation.get_lines()}
    (turned,) = rotation.patches  # the span about z, in its line's colour
    assert [turned.get_x(), turned.get_x() + turned.get_width()] == [-15, 15]
    assert turned.get_facecolor()[:3] == matplotlib.colors.to_rgb(colour["about z (paper's Y)"])
    (fixed,) = [line for line in rotation.get_lines() if line.get_label().endswith("about y")]
    assert (
        list(fixed.get_xdata()) == [-5, -5] and fixed.get_color() == colour["about y (paper's Z)"]
    )
    assert list(rotation.get_xticks()) == [-15, -5, 0, 15]
    assert report.trained() == (  # fine-tuned from a model of the unturned limb
        "trained at speeds 0.1-0.15 m/s; the limb unturned or turned about x +0...+10, "
        "about y -5, about z -15...+15 deg"
    )
    assert replace(report, trained_unturned=False).trained() == (
        "trained at speeds 0.1-0.15 m/s; the limb turned about x +0...+10, about y -5, "
        "about z -15...+15 deg"
    )
    right = [a.get_ylabel() for ax in (speed, rotation) for a in ax.child_axes]
    assert right == ["x in-range RMSE"] * 2  # a scale in x in-range beside each panel
    matplotlib.pyplot.close(fig)


def _card(epochs: int, n_val: int, kept: int | None = None) -> ModelCard:
    card = load_model(SAMPLES / "models" / "gown").card
    history = [
        e.model_copy(update={"val_loss": e.val_loss if n_val else None})
        for e in card.history[:epochs]
    ]
    metrics = {**card.metrics, "kept_epoch": kept} if kept else {}
    return card.model_copy(
        update={
            "history": history,
            "data": card.data.model_copy(update={"n_val": n_val}),
            "metrics": metrics,
        }
    )


def test_learning_curve_ticks_whole_epochs_and_says_when_nothing_was_validated() -> None:
    """One epoch got ticks at 0.96, 0.98, ... and three at 1.25, 1.5, ...; without a
    validation split the plot showed one line with no word of the other."""
    one = training_figure(_card(1, 0))
    (ax,) = one.axes
    assert list(ax.get_xticks()) == [1]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["training (no validation split)"]
    assert (
        ax.get_title()
        == "Learning curve: gown, 3x100 LSTM, lr 0.001 cosine\n225 training sequences"
    )
    (ax,) = training_figure(_card(3, 300, kept=2)).axes
    assert list(ax.get_xticks()) == [1, 2, 3]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "training",
        "validation",
        "kept (epoch 2)",
    ]
    assert ax.get_title().endswith("\n225 training sequences, 300 validation")
    (ax,) = training_figure(_card(60, 300, kept=43)).axes
    ticks = ax.get_xticks()
    assert all(t == int(t) for t in ticks) and 4 <= len(ticks) <= 10, ticks
    matplotlib.pyplot.close("all")


def test_the_sweep_table_csv_and_json_give_each_settings_ratio_to_all_zero(
    tmp_path: Path,
) -> None:
    """The README's sweep tables read the RMSE over all-zero per setting; the sweep's own
    table and CSV gave only the ratio to in-range."""
    from dresslog.experiments import sweeps

    settings = sweep_settings(Task.GOWN, [0.2], [])
    scores = [
        Scores(8, 0.01, 0.02, 0.5, 0.8, 0.6, 0.3, 0.4),
        Scores(8, 0.03, 0.04, 0.75, *[0.5] * 4),
    ]
    report = SweepReport(
        "gown", "m", 8, 0.01, [replace(s, scores=c) for s, c in zip(settings, scores, strict=True)]
    )
    table = report.table().splitlines()
    assert table[0].endswith("RMSE (N)    zero (N)   ratio  x in-range"), table[0]
    assert table[2].split() == ["speed:0.2", "8", "0.03000", "0.04000", "0.750", "3.00"]
    sweeps._write_sweep(tmp_path, report)
    rows = (tmp_path / "sweep.csv").read_text().splitlines()
    assert rows[0] == "setting,kind,axis,value,n,rmse,zero_rmse,ratio,ratio_to_in_range"
    assert rows[2] == "speed:0.2,speed,,0.2,8,0.03,0.04,0.75,3"
    saved = json.loads((tmp_path / "sweep.json").read_text())["settings"]  # keys as before
    assert [(s["scores"]["ratio"], s["ratio_to_in_range"]) for s in saved] == [(0.5, 1), (0.75, 3)]


def test_a_sweep_stopped_while_writing_leaves_the_last_table_and_plot_together(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from dresslog.experiments import sweeps

    def report(speed: float) -> SweepReport:
        settings = sweep_settings(Task.GOWN, [speed], [])
        scores = Scores(8, 0.01, 0.02, 0.5, 0.8, 0.6, 0.3, 0.4)
        return SweepReport("gown", "m", 8, 0.01, [replace(s, scores=scores) for s in settings])

    sweeps._write_sweep(tmp_path, report(0.2))
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert sorted(before) == ["sweep.csv", "sweep.json", "sweep.png"]

    def stopped(path: Path, report: SweepReport) -> None:  # matplotlib's import takes a second
        raise KeyboardInterrupt

    monkeypatch.setattr(sweeps, "plot_sweep", stopped)
    with pytest.raises(KeyboardInterrupt):
        sweeps._write_sweep(tmp_path, report(0.25))
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


@pytest.mark.slow
def test_a_model_reading_the_signals_change_still_infers_from_the_9d_signal(
    data: Path, tmp_path: Path
) -> None:
    out = tmp_path / "diff"
    args = ["--epochs", "1", "--hidden", "4", "--layers", "1", "--input-differences", "-q"]
    code, output = invoke("train", data, "-o", out, *args)
    assert code == 0, output
    code, output = invoke("info", out)
    assert "LSTM on 18-D input; phi and its change per step" in output, output
    trial = next((data / "test").glob("*.mcap"))
    code, output = invoke("infer", trial, "--model", out, "-o", tmp_path / "t.rrd")
    assert code == 0 and "RMSE" in output and (tmp_path / "t.rrd").is_file(), output


def test_a_second_train_on_the_same_output_is_refused_while_the_first_runs(
    data: Path, tmp_path: Path
) -> None:
    out = tmp_path / "m"
    with exclusive(tmp_path / ".m.train.lock", "dresslog train"):  # held by this live process
        code, output = invoke("train", data, "-o", out, "--epochs", "1", "--hidden", "4", "-q")
    assert code == 1 and output.startswith(f"Error: {out}: another `dresslog train` (")
    assert f"({socket.gethostname()} pid {os.getpid()}) is writing it" in output
    assert not out.exists()
    # a lock whose process is gone is taken over
    (tmp_path / ".m.train.lock").write_text(f"{socket.gethostname()} {2**22 + 12345}")
    code, output = invoke("train", data, "-o", out, "--epochs", "1", "--hidden", "4", "-q")
    assert code == 0, output
    assert not (tmp_path / ".m.train.lock").exists()


def test_train_dataset_refuses_a_window_the_data_make_meaningless_before_loading_any_trial(
    tmp_path: Path,
) -> None:
    """Checked against the manifest's step counts, not after the trials had been decoded."""
    data = tmp_path / "two"
    generate("gown", 2, data, execution=Execution(workers=1, recorder=fake_record), test_fraction=0)
    longest = max(t.steps for t in load_manifest(data).trials)
    with pytest.raises(ModelError, match=f"the longest has {longest}"):
        train_dataset(data, tmp_path / "m", TrainOptions(window=longest), progress=False)
    assert not (data / ".cache").exists() and not (tmp_path / "m").exists()
    with pytest.raises(DatasetError, match="task 'hat' is not one of gown, shorts"):
        sweep_settings("hat", [], ["y:10"])


def test_train_and_eval_name_a_split_too_small_to_use(tmp_path: Path) -> None:
    data = tmp_path / "one"
    with pytest.warns(DresslogWarning, match="1 trial at --test-fraction 0 leaves 1 to train on"):
        generate(  # what `train` then refuses: said while the trials were still to be made
            "gown", 1, data, execution=Execution(workers=1, recorder=fake_record), test_fraction=0
        )
    code, output = invoke("train", data, "-o", tmp_path / "m", "-q")
    assert code == 1 and "needs at least 2 training trials, has 1" in output
    code, output = invoke("eval", _fake_model(tmp_path / "gown", "gown"), data)
    assert code == 1 and f"{data}: the dataset has no test trials" in output
    assert "it holds train trials: pass --split train" in output  # said before decoding
    assert not (data / ".cache").exists()


@pytest.mark.parametrize(
    ("options", "code", "message"),
    [
        ([], 2, "Error: give --speeds, --rotations or both"),
        # malformed values are usage errors, as record's --rotation q 5 is; they were exit 1
        (["--speeds", "0.2,fast"], 2, "Invalid value for '--speeds': speed 'fast' is not a"),
        (["--rotations", "q:5"], 2, "Invalid value for '--rotations': rotation 'q:5' is not"),
        # a script's `--speeds "$SPEEDS"` of an empty variable: it was told to give --speeds
        (["--speeds", ""], 2, "Error: --speeds is empty; give --speeds, --rotations or both"),
        (["--rotations", " , "], 2, "Error: --rotations is empty; give --speeds, --rotations"),
    ],
)  # fmt: skip
def test_sweep_without_a_setting_or_with_a_bad_speed_is_refused(
    model: Path, tmp_path: Path, options: list[str], code: int, message: str
) -> None:
    exit_code, output = invoke("sweep", model, *options, "-o", tmp_path / "s")
    assert exit_code == code and message in output, output
    assert not (tmp_path / "s").exists()


@pytest.mark.slow
@prints_warnings
def test_a_model_trained_without_standardisation_still_warns_of_a_signal_far_from_its_data(
    model: Path, data: Path, tmp_path: Path
) -> None:
    """The paper's recipe (no --normalise) records its training signal in the card, so
    `infer` can still say when a log lies far from it (here a sensor not tared)."""
    from dresslog.dataset import Split, load_dataset
    from tests.test_replay import _csv_of

    card = load_model(model).card
    assert card.normalisation is None and card.data.signal is not None
    arrays = load_dataset(data, progress=False)
    signal = np.concatenate(arrays.sequences(arrays.rows(Split.TRAIN)))
    np.testing.assert_allclose(card.data.signal.mean, signal.mean(axis=0), rtol=1e-5, atol=1e-7)
    csv = _csv_of(SAMPLES / "gown.mcap", tmp_path / "untared.csv", -1.5 * 9.81)
    code, out = invoke("convert", csv, "-o", tmp_path / "untared.mcap", "--task", "gown")
    assert code == 0, out
    result = CliRunner().invoke(
        main,
        ["infer", str(tmp_path / "untared.mcap"), "-m", str(model), "-o", str(tmp_path / "u.rrd")],
    )
    assert result.exit_code == 0, result.output
    assert (
        "Warning: " in result.stderr and ": fz lies beyond 10 standard deviations" in result.stderr
    )


def test_a_dataset_and_a_model_swapped_are_told_which_is_which(model: Path, data: Path) -> None:
    """`dresslog eval DATA MODEL` (and `train MODEL`), where each had been told only that
    the folder is not a model (not a dataset), though it is the other."""
    code, output = invoke("eval", data, model)
    assert code == 1 and output == (
        f"Error: {data}: no card.json; a dataset folder, not a model (`eval` and `sweep` take "
        "the model first)\n"
    )
    code, output = invoke("train", model, "-o", data.parent / "unmade")
    assert code == 1 and output == (
        f"Error: {model}: no manifest.json; a model folder, not a dataset (`eval MODEL DATA` "
        "takes the dataset second)\n"
    )
    assert not (data.parent / "unmade").exists()
