"""`dresslog eval` (dresslog.experiments.evaluation): scores, per-outcome ratios, the
conditions a model was trained on, and its bad input."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import matplotlib.colors
import matplotlib.image
import matplotlib.pyplot
import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.dataset import Execution, Manifest, generate, load_dataset, load_manifest
from dresslog.errors import DatasetError
from dresslog.experiments import dataset_bounds
from dresslog.experiments.evaluation import data_conditions, limb_parts
from dresslog.experiments.plots import eval_figure
from dresslog.model.bounds import describe_oracle
from dresslog.model.conditions import Conditions, combined, spec_conditions
from dresslog.model.evaluate import ErrorProfile, score_sequences
from dresslog.model.files import load_model
from dresslog.sim.specs import random_spec
from dresslog.spec import RotationRange, Task, TrialSpec
from tests.conftest import SAMPLES, prints_warnings
from tests.experiments.conftest import fake_model, invoke


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
    assert set(report["per_part"]) == {"fist", "forearm", "elbow", "upper_arm"}
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
    # each limb part scored over its own points, as the paper's RMSE is over the whole map
    parts = limb_parts(Task.GOWN)
    assert sum(m.astype(int) for m in parts.values()).tolist() == [1] * arrays.n_points
    each = score_sequences(
        load_model(model), arrays.sequences(rows), arrays.force_maps(rows), parts=parts
    )
    for name, scores in each.part_scores().items():
        mask = parts[name]
        own = [
            np.sqrt(np.mean((e[:, mask] - t[:, mask]) ** 2))
            for t, e in zip(truths, estimates, strict=True)
        ]
        zero = [np.sqrt(np.mean(t[:, mask] ** 2)) for t in truths]
        assert scores.rmse == pytest.approx(np.mean(own), rel=1e-5, abs=1e-9)
        assert scores.zero_rmse == pytest.approx(np.mean(zero), rel=1e-9)
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


def test_eval_refuses_a_model_for_the_other_task(data: Path, tmp_path: Path) -> None:
    code, output = invoke("eval", fake_model(tmp_path / "shorts", "shorts"), data)
    assert code == 1 and output.count("\n") == 1
    assert "model is for shorts but the data is gown" in output
    assert "--model" not in output  # eval takes the model as its MODEL argument


def test_eval_refuses_a_tampered_model(data: Path, tmp_path: Path) -> None:
    path = fake_model(tmp_path / "gown", "gown")
    weights = path / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:-4] + b"\0\0\0\0")
    code, output = invoke("eval", path, data)
    assert code == 1 and "does not match the sha256" in output


#: The conditions of a v7 folder of `generate`'s gown trials: speeds drawn over 10-15 cm/s,
#: no rotation, limb offsets drawn over the paper's numbers on our axes, 7 s long.
DEFAULTS = Conditions(
    ((0.10, 0.15),), (), True, (((-0.05, 0.05), (-0.2, 0.2), (-0.1, 0.1)),), (7.0,)
)


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
