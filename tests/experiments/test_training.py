"""`dresslog train` (dresslog.experiments.training): model folders, cards, fine-tuning,
pooled folders, overwrite and resume, and its bad input."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.colors
import matplotlib.image
import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.dataset import Execution, generate, load_dataset, load_manifest
from dresslog.errors import DatasetError, DresslogWarning, ModelError
from dresslog.experiments import TrainOptions, sweep_settings, train_dataset
from dresslog.folders import CARD_FILE
from dresslog.io.files import exclusive
from dresslog.model.conditions import Conditions, trained_conditions
from dresslog.model.files import InitialModel, ModelCard, TrainingFolder, load_model
from dresslog.spec import Task
from tests.conftest import SAMPLES, csv_of, fake_record, prints_warnings
from tests.experiments.conftest import TURNED, fake_model, invoke


@pytest.mark.slow
def test_trained_model_card_names_its_data_and_test_scores(model: Path, data: Path) -> None:
    card = json.loads((model / "card.json").read_text())
    assert card["data"]["manifest_sha256"] == load_manifest(data).content_hash()
    assert card["hidden"] == 4 and card["layers"] == 1 and card["hyperparameters"]["epochs"] == 2
    assert card["metrics"]["test_n_sequences"] == 1.0
    assert not list(data.parent.glob(".model.checkpoint.safetensors"))


@pytest.mark.slow
def test_trained_model_keeps_its_learning_curve_and_its_plot(model: Path) -> None:

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


#: The fields a folder of the current simulator saves beside what its request fixed.
V9 = {"sim": {"simulator": 9}}


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


def test_train_init_refuses_a_model_for_the_other_task_or_a_tampered_one(
    data: Path, tmp_path: Path
) -> None:
    shorts = fake_model(tmp_path / "shorts", "shorts")
    code, output = invoke("train", data, "-o", tmp_path / "m", "--init", shorts)
    assert code == 1 and output.count("\n") == 1
    assert "model is for shorts but the data is gown; give a gown model" in output
    gown = fake_model(tmp_path / "gown", "gown")
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


def test_train_refuses_to_overwrite_before_training(data: Path, tmp_path: Path) -> None:
    code, output = invoke("train", data, "-o", fake_model(tmp_path / "m", "gown"))
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
        model = fake_model(tmp_path / "m", "gown")
    finally:
        os.umask(umask)
    modes = {p.name: p.stat().st_mode & 0o777 for p in model.iterdir()}
    assert modes["model.safetensors"] == modes["card.json"], modes
    assert modes["model.safetensors"] & 0o044 == 0o044, modes  # group and others may read it


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
    code, output = invoke("eval", fake_model(tmp_path / "gown", "gown"), data)
    assert code == 1 and f"{data}: the dataset has no test trials" in output
    assert "it holds train trials: pass --split train" in output  # said before decoding
    assert not (data / ".cache").exists()


@pytest.mark.slow
@prints_warnings
def test_a_model_trained_without_standardisation_still_warns_of_a_signal_far_from_its_data(
    model: Path, data: Path, tmp_path: Path
) -> None:
    """The paper's recipe (no --normalise) records its training signal in the card, so
    `infer` can still say when a log lies far from it (here a sensor not tared)."""
    from dresslog.dataset import Split, load_dataset

    card = load_model(model).card
    assert card.normalisation is None and card.data.signal is not None
    arrays = load_dataset(data, progress=False)
    signal = np.concatenate(arrays.sequences(arrays.rows(Split.TRAIN)))
    np.testing.assert_allclose(card.data.signal.mean, signal.mean(axis=0), rtol=1e-5, atol=1e-7)
    csv = csv_of(SAMPLES / "gown.mcap", tmp_path / "untared.csv", -1.5 * 9.81)
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
