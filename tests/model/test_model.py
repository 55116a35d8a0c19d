"""The model layer: numpy inference equals torch, training learns, model files are safe."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import warnings
from dataclasses import asdict
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
import torch
from pydantic import ValidationError

from dresslog.errors import ModelError, first_problem
from dresslog.experiments.plots import plot_training
from dresslog.io.reader import TrialReader
from dresslog.model import (
    ModelCard,
    NumpyEstimator,
    apply_contact,
    check_task,
    contact_targets,
    load_model,
    network_targets,
    read_card,
    resolve_model,
    rmse,
    save_model,
    zero_baseline_rmse,
)
from dresslog.model.bounds import error_split
from dresslog.model.evaluate import score_sequences
from dresslog.model.files import (
    FORMAT_VERSION,
    EpochRecord,
    Hyperparameters,
    check_model_folder,
)
from dresslog.model.inputs import network_inputs
from dresslog.model.network import ForceMapLSTM
from dresslog.model.options import TrainOptions
from dresslog.model.postprocess import sequence_rmse
from dresslog.model.train import epoch_lr, make_card, train
from dresslog.spec import Task

N = 24


def random_network(n_points: int = N, seed: int = 0) -> ForceMapLSTM:
    """Weights larger than Glorot's so every gate leaves its linear range."""
    torch.manual_seed(seed)
    net = ForceMapLSTM(n_points)
    with torch.no_grad():
        for p in net.parameters():
            p.normal_(std=0.4)
    net.set_normalisation(np.linspace(-1, 1, 9), np.linspace(0.5, 2, 9))
    return net


def torch_forward(net: ForceMapLSTM, phi: np.ndarray) -> np.ndarray:
    with torch.no_grad():
        return net(torch.from_numpy(phi))[0].numpy()


def synthetic(n: int, seed: int, n_points: int = 8) -> tuple[list, list]:
    """Sequences whose force map follows the running sum of phi's first channel."""
    rng = np.random.default_rng(seed)
    phis, forces = [], []
    for _ in range(n):
        phi = rng.normal(scale=0.5, size=(int(rng.integers(20, 40)), 9)).astype(np.float32)
        progress = np.cumsum(phi[:, 0]) / 4
        centres = np.linspace(-1, 1, n_points)
        f = np.maximum(0.0, 0.3 - np.abs(progress[:, None] - centres[None]))
        phis.append(phi)
        forces.append(f.astype(np.float32))
    return phis, forces


def fit(phis, forces, *, progress=False, val=None, init=None, checkpoint=None,
        restart_other=False, on_epoch=None, **settings):  # fmt: skip
    """`train` with its settings as keywords, each test varying the few it is about."""
    return train(phis, forces, TrainOptions(**settings), val=val, init=init, progress=progress,
                 checkpoint=checkpoint, restart_other=restart_other, on_epoch=on_epoch)  # fmt: skip


@pytest.fixture(scope="module")
def trained() -> tuple[dict[str, np.ndarray], object]:
    phis, forces = synthetic(32, seed=1)
    options = TrainOptions(epochs=6, batch_size=8, lr=3e-3, hidden=12, layers=2, seed=3)
    return train(phis, forces, options, progress=False)


# -- numpy inference equals torch ---------------------------------------------------------
def test_numpy_forward_equals_torch_on_a_batch_of_sequences():
    net = random_network()
    phi = np.random.default_rng(0).normal(size=(3, 120, 9)).astype(np.float32)
    est = NumpyEstimator(net.weights())
    np.testing.assert_allclose(est.forward(phi), torch_forward(net, phi), atol=1e-5, rtol=0)
    np.testing.assert_allclose(est.forward(phi[1]), torch_forward(net, phi)[1], atol=1e-5)


def test_one_step_at_a_time_equals_the_whole_sequence_and_reset_starts_over():
    net = random_network()
    phi = np.random.default_rng(1).normal(size=(80, 9)).astype(np.float32)
    est = NumpyEstimator(net.weights())
    whole_f, whole_c = est.run(phi)
    for _ in range(2):  # the second pass checks reset()
        est.reset()
        steps = [est.step(p) for p in phi]
        np.testing.assert_allclose(np.stack([f for f, _ in steps]), whole_f, atol=1e-5)
        np.testing.assert_allclose(np.stack([c for _, c in steps]), whole_c, atol=1e-5)
    np.testing.assert_allclose(est.step_raw(phi[0]).shape, (2 * N,))


def test_a_nan_step_is_refused_and_leaves_the_state_as_it_was(trained):
    """A robot's estimator meets a NaN sample: refused, and the next steps are unharmed."""
    weights, _ = trained
    phi = synthetic(1, seed=4)[0][0]
    clean, bad = NumpyEstimator(weights), NumpyEstimator(weights)
    expected = [clean.step(p)[0] for p in phi[:5]]
    got = []
    for k, p in enumerate(phi[:5]):
        if k == 2:
            with pytest.raises(ModelError, match="finite"):
                bad.step(np.full(9, np.nan, np.float32))
            with pytest.raises(ModelError, match="finite"):  # finite, but not as float32
                bad.step(np.full(9, 1e39))
            with pytest.raises(ModelError, match="9 finite float32 numbers"):
                bad.step(np.zeros(8, np.float32))
        got.append(bad.step(p)[0])
    np.testing.assert_array_equal(np.stack(got), np.stack(expected))
    for wrong in (np.nan, 1e39):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # numpy's overflow warning stays unprinted
            with pytest.raises(ModelError, match="NaN or infinite"):
                NumpyEstimator(weights).run(np.full((4, 9), wrong))


def test_run_applies_eq2_to_the_raw_output():
    net = random_network()
    phi = np.random.default_rng(2).normal(size=(30, 9)).astype(np.float32)
    est = NumpyEstimator(net.weights())
    raw = est.forward(phi)
    forces, contact = est.run(phi)
    np.testing.assert_array_equal(forces, apply_contact(raw[:, :N], raw[:, N:]))
    np.testing.assert_array_equal(contact, raw[:, N:])
    assert (forces >= 0).all() and (forces[contact < 0] == 0).all()


def test_the_model_files_api_is_dresslog_models_own():
    """What `dresslog.model.files` documents is importable from the package."""
    import dresslog.model

    for name in ("read_card", "check_model_folder", "load_model", "save_model", "check_task"):
        assert name in dresslog.model.__all__ and hasattr(dresslog.model, name)


def test_importing_the_inference_side_does_not_import_torch():
    code = "import sys, dresslog.model, dresslog.model.evaluate; print('torch' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# -- post-processing and metric ------------------------------------------------------------
def test_eq2_zeroes_forces_without_contact_or_below_zero():
    forces_u = np.array([0.5, 0.5, -0.2, 0.3], np.float32)
    contact = np.array([0.1, -0.1, 0.1, 0.0], np.float32)
    np.testing.assert_array_equal(apply_contact(forces_u, contact), np.float32([0.5, 0, 0, 0.3]))


def test_contact_targets_and_network_targets_follow_eq1():
    forces = np.array([[0.0, 0.2], [0.01, 0.0]], np.float32)
    np.testing.assert_allclose(contact_targets(forces), [[-0.1, 0.1], [0.1, -0.1]])
    target = network_targets(forces)
    assert target.shape == (2, 4) and target.dtype == np.float32
    np.testing.assert_array_equal(target[:, :2], forces)


def test_rmse_is_per_sequence_then_averaged():
    trues = [np.full((1, 2), 3.0), np.zeros((4, 2))]
    ests = [np.zeros((1, 2)), np.zeros((4, 2))]
    # Per sequence 3 and 0, averaged: 1.5 (pooling all steps would give 3 / sqrt(5)).
    assert rmse(trues, ests) == pytest.approx(1.5)
    assert zero_baseline_rmse(trues) == pytest.approx(1.5)
    assert sequence_rmse(np.ones((2, 2)), np.zeros((2, 2))) == pytest.approx(1.0)


# -- training ----------------------------------------------------------------------------
def test_training_lowers_the_loss(trained):
    _, history = trained
    losses = [e.train_loss for e in history.epochs]
    assert len(losses) == 6 and history.n_train + history.n_val == 32
    assert losses[-1] < 0.7 * losses[0]
    last = history.epochs[-1].val_loss
    assert last is not None and np.isfinite(last)


def interrupted_then_resumed(ckpt: Path, stop_after: int, phis, forces, **kwargs):
    """`train` stopped (KeyboardInterrupt) after epoch `stop_after`, then run again on `ckpt`."""

    def stop(record: EpochRecord) -> None:
        if record.epoch == stop_after:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fit(phis, forces, checkpoint=ckpt, on_epoch=stop, **kwargs)
    return fit(phis, forces, checkpoint=ckpt, **kwargs)


def test_training_is_deterministic_and_resumes_after_an_interruption(tmp_path: Path):
    phis, forces = synthetic(8, seed=2, n_points=4)
    kwargs = {"epochs": 3, "batch_size": 4, "hidden": 6, "layers": 1, "progress": False}
    reference, _ = fit(phis, forces, **kwargs)
    ckpt = tmp_path / "run.ckpt"
    resumed, history = interrupted_then_resumed(ckpt, 1, phis, forces, **kwargs)
    assert [e.epoch for e in history.epochs] == [1, 2, 3]
    for name, value in reference.items():
        np.testing.assert_array_equal(resumed[name], value, err_msg=name)
    # named, so the interrupted run's options can be repeated: a checkpoint is not readable
    with pytest.raises(
        ModelError, match=r"other settings \(it had --epochs 3, this run --epochs 4\)"
    ):
        fit(phis, forces, checkpoint=ckpt, **{**kwargs, "epochs": 4})
    with pytest.raises(ModelError, match=r"\(it had --hidden 6, this run --hidden 7\)"):
        fit(phis, forces, checkpoint=ckpt, **{**kwargs, "hidden": 7})


def _interrupted_run(tmp_path: Path) -> tuple[list, list, dict, Path]:
    """A small run stopped after its first epoch: its data, options and checkpoint."""
    phis, forces = synthetic(8, seed=2, n_points=4)
    kwargs = {"epochs": 3, "batch_size": 4, "hidden": 6, "layers": 1, "progress": False}

    def stop(record: EpochRecord) -> None:
        raise KeyboardInterrupt

    ckpt = tmp_path / "run.ckpt"
    with pytest.raises(KeyboardInterrupt):
        fit(phis, forces, checkpoint=ckpt, on_epoch=stop, **kwargs)
    return phis, forces, kwargs, ckpt


def test_a_resume_with_other_normalisation_or_other_data_is_refused(tmp_path: Path):
    phis, forces, kwargs, ckpt = _interrupted_run(tmp_path)
    # the checkpoint's weights carry its input statistics: resuming would silently keep them
    with pytest.raises(ModelError, match=r"\(it had no --normalise, this run --normalise\)"):
        fit(phis, forces, checkpoint=ckpt, normalise=True, **kwargs)
    # options that change what the network reads (the seed: which sequences validate)
    # on the same data, which were said to be "other data"
    for option, value, had, has in (
        ("input_differences", True, "no --input-differences", "--input-differences"),
        ("balance_loss", True, "no --balance-loss", "--balance-loss"),
        ("seed", 1, "--seed 0", "--seed 1"),
    ):
        with pytest.raises(ModelError, match=rf"other settings \(it had {had}, this run {has}\)"):
            fit(phis, forces, checkpoint=ckpt, **{option: value}, **kwargs)
    more, more_forces = synthetic(9, seed=2, n_points=4)  # the dataset grew since
    with pytest.raises(ModelError, match="other data"):
        fit(more, more_forces, checkpoint=ckpt, **kwargs)


def test_a_checkpoint_holding_nan_weights_is_refused_not_resumed(tmp_path: Path):
    """A damaged checkpoint: the run would go on from weights that estimate NaN."""
    from safetensors import safe_open
    from safetensors.torch import save_file

    phis, forces, kwargs, ckpt = _interrupted_run(tmp_path)
    with safe_open(str(ckpt), framework="pt") as stream:
        metadata = stream.metadata()
        tensors = {name: stream.get_tensor(name) for name in stream.keys()}  # noqa: SIM118
    tensors["model.head.bias"][1] = float("nan")
    save_file(tensors, str(ckpt), metadata)
    with pytest.raises(ModelError, match=r"checkpoint's model\.head\.bias holds NaN or infinite"):
        fit(phis, forces, checkpoint=ckpt, **kwargs)


def test_fine_tuning_starts_from_the_initial_weights_whatever_the_force_scale(trained):
    """`init`: the run starts where the initial model ended (its outputs in newtons, the
    loss's forces scaled by --balance-loss), not from random weights."""
    weights, history = trained
    phis, forces = synthetic(32, seed=1)
    kwargs = {"batch_size": 8, "hidden": 12, "layers": 2, "seed": 3, "progress": False}
    still, _ = fit(phis, forces, epochs=1, lr=1e-9, balance_loss=True, init=weights, **kwargs)
    for name, value in weights.items():  # a step of 1e-8 at most: the initial weights
        np.testing.assert_allclose(still[name], value, atol=1e-6, err_msg=name)
    # at a fine-tuning rate: RMSprop starts afresh, and its first steps are ten times lr
    _, tuned = fit(phis, forces, epochs=1, lr=1e-4, init=weights, **kwargs)
    fresh = history.epochs[0].train_loss  # the same first epoch from random weights
    assert tuned.epochs[0].train_loss < 0.6 * fresh
    with pytest.raises(
        ModelError,
        match=r"^the initial weights are for 8 limb points, 12 cells x 2 layers, 9 inputs, "
        r"this run 8 limb points, 6 cells x 2 layers, 9 inputs$",
    ):
        fit(phis, forces, init=weights, **{**kwargs, "hidden": 6})


def test_a_resume_from_other_initial_weights_is_refused(tmp_path: Path, trained):
    weights, _ = trained
    phis, forces = synthetic(8, seed=2)
    kwargs = {"epochs": 3, "batch_size": 4, "hidden": 12, "layers": 2, "progress": False}
    ckpt = tmp_path / "run.ckpt"

    def stop(record: EpochRecord) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fit(phis, forces, checkpoint=ckpt, on_epoch=stop, init=weights, **kwargs)
    with pytest.raises(ModelError, match=r"\(it had --init of weights \w{8}, this run no --init\)"):
        fit(phis, forces, checkpoint=ckpt, **kwargs)
    other = {k: v + 0.01 for k, v in weights.items()}
    with pytest.raises(
        ModelError,
        match=r"\(it had --init of weights (\w{8}), this run --init of weights (?!\1)\w{8}\)",
    ):
        fit(phis, forces, checkpoint=ckpt, init=other, **kwargs)
    _, history = fit(phis, forces, checkpoint=ckpt, init=weights, **kwargs)  # resumed
    assert [e.epoch for e in history.epochs] == [1, 2, 3]


def test_keep_best_returns_the_epoch_of_lowest_validation_loss_across_a_resume(tmp_path: Path):
    phis, forces = synthetic(12, seed=5, n_points=4)
    kwargs = {"batch_size": 2, "hidden": 6, "layers": 1, "lr": 0.02, "seed": 3, "threads": 1}
    kwargs |= {"val_fraction": 0.25, "progress": False}  # a noisy validation loss
    best, history = fit(phis, forces, epochs=6, keep_best=True, **kwargs)
    run = {"epochs": 6, "keep_best": True, **kwargs}
    kept = history.kept
    assert kept is not None and kept.epoch < 6  # the validation loss rose after its best
    assert kept.val_loss == min(e.val_loss for e in history.epochs)
    # Each epoch's shuffle depends only on (seed, epoch): stopping there gives those weights.
    stopped, _ = fit(phis, forces, epochs=kept.epoch, **kwargs)
    for name, value in stopped.items():
        np.testing.assert_array_equal(best[name], value, err_msg=name)
    resumed, _ = interrupted_then_resumed(
        tmp_path / "run.ckpt", kept.epoch + 1, phis, forces, **run
    )
    for name, value in best.items():
        np.testing.assert_array_equal(resumed[name], value, err_msg=name)
    card = make_card(Task.GOWN, best, history)
    assert card.hyperparameters.keep_best and card.metrics["kept_epoch"] == kept.epoch
    assert card.metrics["val_loss"] == kept.val_loss
    assert [e.val_loss for e in card.history] == [e.val_loss for e in history.epochs]
    plot_training(tmp_path / "training.png", card)  # both curves and the kept epoch
    image = matplotlib.image.imread(tmp_path / "training.png")
    assert image.shape[0] > 200 and image.std() > 0.05  # drawn, not blank


def test_cosine_schedule_anneals_the_learning_rate_and_resumes_on_the_same_curve(tmp_path: Path):
    settings = Hyperparameters(epochs=4, lr=0.01, lr_schedule="cosine")
    assert [epoch_lr(settings, e) for e in range(4)] == pytest.approx(
        [0.01, 0.01 * (1 + 0.5**0.5) / 2, 0.005, 0.01 * (1 - 0.5**0.5) / 2]
    )
    assert epoch_lr(Hyperparameters(epochs=4, lr=0.01), 3) == 0.01
    phis, forces = synthetic(8, seed=2, n_points=4)
    kwargs = {"epochs": 3, "batch_size": 4, "hidden": 6, "layers": 1, "progress": False}
    cosine, history = fit(phis, forces, lr_schedule="cosine", **kwargs)
    constant, _ = fit(phis, forces, **kwargs)
    assert not np.array_equal(cosine["head.weight"], constant["head.weight"])
    resumed, _ = interrupted_then_resumed(
        tmp_path / "run.ckpt", 1, phis, forces, lr_schedule="cosine", **kwargs
    )
    for name, value in cosine.items():
        np.testing.assert_array_equal(resumed[name], value, err_msg=name)
    assert make_card(Task.GOWN, cosine, history).hyperparameters.lr_schedule == "cosine"


def test_balanced_loss_makes_training_invariant_to_the_force_unit():
    """With --balance-loss, forces 100x smaller train the same network, outputs 100x smaller."""
    phis, forces = synthetic(8, seed=4, n_points=4)
    kwargs = {"epochs": 2, "batch_size": 4, "hidden": 6, "layers": 1, "progress": False}
    big, big_history = fit(phis, forces, balance_loss=True, **kwargs)
    small, small_history = fit(phis, [f / 100 for f in forces], balance_loss=True, **kwargs)
    positive = np.concatenate([f[f > 0] for f in forces])
    assert big_history.settings.force_scale == pytest.approx(0.1 / positive.mean(), rel=1e-5)
    scales = small_history.settings.force_scale, big_history.settings.force_scale
    assert scales[0] == pytest.approx(100 * scales[1])
    out_big, _ = NumpyEstimator(big).run(phis[0])
    out_small, _ = NumpyEstimator(small).run(phis[0])
    np.testing.assert_allclose(out_small * 100, out_big, rtol=1e-3, atol=1e-5)


def test_training_rejects_mismatched_data_in_one_line():
    with pytest.raises(ModelError, match="sequence 0"):
        fit([np.zeros((5, 9), np.float32)], [np.zeros((4, 3), np.float32)], progress=False)
    phis, forces = synthetic(3, seed=2, n_points=4)
    phis[1][3, 2] = np.nan
    with pytest.raises(ModelError, match="sequence 1 has NaN"):
        fit(phis, forces, progress=False)
    with pytest.raises(ValidationError, match="epochs, batch size"):
        fit(synthetic(3, seed=2)[0], synthetic(3, seed=2)[1], epochs=0, progress=False)
    for size in ("batch_size", "hidden", "layers", "threads"):  # 0 is no default
        with pytest.raises(ValidationError, match="must all be 1 or more"):
            TrainOptions(**{size: 0})
    assert TrainOptions(hidden=7).network() == (7, 3)


def test_a_diverging_run_stops_with_one_line_and_leaves_no_checkpoint(tmp_path: Path):
    phis, forces = synthetic(8, seed=2, n_points=4)
    kwargs = {"epochs": 3, "hidden": 4, "layers": 1, "progress": False}
    ckpt = tmp_path / "run.ckpt"
    with pytest.raises(ModelError, match=r"training diverged in epoch .*lower the learning rate"):
        fit(phis, forces, lr=1e30, checkpoint=ckpt, **kwargs)
    assert not ckpt.exists()
    for lr in (float("inf"), float("nan"), 0.0):
        with pytest.raises(ValidationError, match="learning rate must be a positive number"):
            fit(phis, forces, lr=lr, **kwargs)


@pytest.mark.parametrize("content", ["garbage", "pickle", "other format", "other weights"])
def test_a_checkpoint_not_our_own_is_one_line(tmp_path: Path, content: str) -> None:
    from safetensors import safe_open
    from safetensors.torch import save_file

    ckpt = tmp_path / "run.ckpt"
    phis, forces = synthetic(4, seed=2, n_points=4)
    kwargs = {"epochs": 1, "hidden": 4, "layers": 1, "checkpoint": ckpt, "progress": False}
    if content == "garbage":
        ckpt.write_bytes(b"garbage\n")
    elif content == "pickle":  # what torch.save writes: never unpickled
        torch.save({"key": {}}, ckpt)
    elif content == "other format":
        save_file({"x": torch.zeros(2)}, ckpt, {"format": "something else"})
    else:  # our run's key and metadata, weights of another shape
        fit(phis, forces, **kwargs)
        with safe_open(str(ckpt), framework="pt") as stream:
            metadata = stream.metadata()
        save_file({"model.junk": torch.zeros(2)}, ckpt, metadata)
    with pytest.raises(ModelError, match=r"not a checkpoint dresslog can read.*--overwrite") as err:
        fit(phis, forces, **kwargs)
    assert "\n" not in str(err.value)


def test_options_the_data_make_meaningless_are_refused_not_recorded():
    phis, forces = synthetic(4, seed=2, n_points=4)  # 10% of 4 rounds to no validation
    kwargs = {"epochs": 1, "hidden": 4, "layers": 1, "progress": False}
    with pytest.raises(ModelError, match="needs validation sequences"):
        fit(phis, forces, keep_best=True, **kwargs)
    _, history = fit(phis, forces, keep_best=True, val_fraction=0.25, **kwargs)
    assert history.n_val == 1 and history.kept is not None
    longest = max(len(p) for p in phis)
    with pytest.raises(ModelError, match=f"the longest has {longest}"):
        fit(phis, forces, window=longest, **kwargs)
    for window in (1, 0, -5):  # torch's own error, after the data had been decoded
        with pytest.raises(ValidationError, match=f"2 steps or more, not {window}"):
            fit(phis, forces, window=window, **kwargs)
    _, history = fit(phis, forces, window=longest - 1, **kwargs)
    assert history.settings.window == longest - 1


def test_an_unknown_schedule_or_a_validation_share_outside_0_1_is_refused():
    """A schedule was pydantic's traceback after the data were prepared, a share of 2 or
    -0.5 was taken silently: both are refused when the options are built."""
    phis, forces = synthetic(4, seed=2, n_points=4)
    kwargs = {"epochs": 1, "hidden": 4, "layers": 1, "progress": False}
    with pytest.raises(ValidationError) as err:
        fit(phis, forces, lr_schedule="linear", **kwargs)
    assert first_problem(err.value) == "lr_schedule: Input should be 'constant' or 'cosine'"
    for share in (2.0, -0.5, 1.0, float("nan")):
        with pytest.raises(ValidationError) as err:
            fit(phis, forces, val_fraction=share, **kwargs)
        assert re.fullmatch(rf"val_fraction .* in \[0, 1\), not {share}", first_problem(err.value))


def test_evaluate_scores_after_eq2_against_the_zero_baseline(trained):
    weights, _ = trained
    est = NumpyEstimator(weights)
    phis, forces = synthetic(5, seed=9)
    result = score_sequences(est, phis, forces, batch_size=2).scores()
    ests = [est.run(p)[0] for p in phis]
    assert result.rmse == pytest.approx(rmse(forces, ests), rel=1e-5)
    assert result.zero_rmse == pytest.approx(zero_baseline_rmse(forces))
    assert result.ratio == pytest.approx(result.rmse / result.zero_rmse)
    said = np.concatenate([est.run(p)[1] > 0 for p in phis]).ravel()
    real = np.concatenate(forces).ravel() > 0
    assert result.contact_precision == pytest.approx((said & real).sum() / said.sum())
    assert result.contact_recall == pytest.approx((said & real).sum() / real.sum())
    at_true_total, true_shape = np.mean(
        [error_split(f, e) for f, e in zip(forces, ests, strict=True)], axis=0
    )
    assert result.ratio_at_true_total == pytest.approx(at_true_total / result.zero_rmse, rel=1e-5)
    assert result.ratio_true_shape == pytest.approx(true_shape / result.zero_rmse, rel=1e-5)
    assert result.n == 5
    assert set(result.as_metrics()) >= {"rmse", "zero_rmse", "ratio"}


def test_a_group_scored_from_one_pass_is_the_group_scored_alone(trained):
    """`eval` runs the split through the network once and scores each outcome from the
    sequences' kept figures: the same as running that group by itself."""
    est = NumpyEstimator(trained[0])
    phis, forces = synthetic(6, seed=11)
    each = score_sequences(est, phis, forces, batch_size=4)
    for which in ([0, 2, 5], [1], [3, 4]):
        group = [phis[k] for k in which], [forces[k] for k in which]
        alone = score_sequences(est, *group).scores()
        mask = np.isin(np.arange(6), which)
        for name, value in asdict(each.scores(mask)).items():
            assert value == pytest.approx(getattr(alone, name), rel=1e-6), name
    assert each.scores(np.zeros(6, bool)).n == 0


# -- model files -------------------------------------------------------------------------
@pytest.fixture
def saved(tmp_path: Path, trained) -> Path:
    weights, history = trained
    save_model(tmp_path / "gown", weights, make_card(Task.GOWN, weights, history))
    return tmp_path / "gown"


def test_save_load_round_trip_gives_identical_outputs(saved: Path, trained):
    weights, history = trained
    model = load_model(saved)
    assert read_card(saved) == model.card
    assert model.card.task is Task.GOWN and model.card.n_points == 8
    assert model.card.hidden == 12 and model.card.layers == 2 and "val_loss" in model.card.metrics
    assert model.card.history == history.epochs  # the learning curve travels with the weights
    phi = np.random.default_rng(4).normal(size=(25, 9)).astype(np.float32)
    loaded = model.estimator().forward(phi)
    np.testing.assert_array_equal(loaded, NumpyEstimator(weights).forward(phi))
    net = ForceMapLSTM.from_weights(model.weights)
    np.testing.assert_allclose(model.estimator().forward(phi), torch_forward(net, phi), atol=1e-5)


def test_save_refuses_to_overwrite_unless_asked(saved: Path, trained):
    weights, history = trained
    card = make_card(Task.GOWN, weights, history)
    with pytest.raises(ModelError, match="exists"):
        save_model(saved, weights, card)
    save_model(saved, weights, card, overwrite=True)
    assert sorted(p.name for p in saved.parent.iterdir()) == ["gown"]
    (saved / "data").mkdir()  # a dataset generated into the model folder by mistake
    (saved / "data" / "manifest.json").write_text("{}")
    with pytest.raises(ModelError, match="also holds data, which replacing the model would"):
        save_model(saved, weights, card, overwrite=True)
    assert (saved / "data" / "manifest.json").exists()
    with pytest.raises(ModelError, match="exists; pass --overwrite"):  # a path as text too
        check_model_folder(str(saved), False)
    check_model_folder(str(saved.parent / "new"), False)


def test_more_files_go_into_the_model_folder_before_it_is_in_place(tmp_path: Path, trained):
    """A run stopped between the model and its learning curve left a folder without it."""
    weights, history = trained
    path = tmp_path / "gown"

    def stopped(folder: Path, card: ModelCard) -> None:
        (folder / "training.png").write_bytes(b"half a plot")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        save_model(path, weights, make_card(Task.GOWN, weights, history), also=stopped)
    assert list(tmp_path.iterdir()) == []
    card = save_model(
        path,
        weights,
        make_card(Task.GOWN, weights, history),
        also=lambda folder, card: (folder / "training.png").write_text(card.weights_sha256),
    )
    assert (path / "training.png").read_text() == card.weights_sha256


def test_tampered_weights_are_refused(saved: Path):
    data = bytearray((saved / "model.safetensors").read_bytes())
    data[-1] ^= 0x01
    (saved / "model.safetensors").write_bytes(bytes(data))
    with pytest.raises(ModelError, match="sha256"):
        load_model(saved)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        ({"format": "keras"}, "not a dresslog model card"),
        ({"format_version": 99}, "newer"),
        (  # the version is named before the field this dresslog does not know
            {"format_version": FORMAT_VERSION + 1, "a_later_field": 1},
            f"format version {FORMAT_VERSION + 1} is newer",
        ),
        ({"n_points": 9}, "has shape"),
        (  # `sweep` and `info` read a folder's conditions as a trial spec's fields
            {"data": {"folders": [{"folder": "d", "overrides": {"speed": -1}}]}},
            "d's fixed spec fields: speed: Input should be greater than 0",
        ),
        ({"task": "socks"}, "task"),
    ],
)
def test_foreign_or_inconsistent_cards_are_refused(saved: Path, edit: dict, message: str):
    card = json.loads((saved / "card.json").read_text())
    (saved / "card.json").write_text(json.dumps({**card, **edit}))
    with pytest.raises(ModelError, match=message) as info:
        load_model(saved)
    assert "\n" not in str(info.value)


def test_missing_pieces_are_refused(tmp_path: Path, saved: Path):
    with pytest.raises(ModelError, match="no such model folder"):
        load_model(tmp_path / "absent")
    (saved / "model.safetensors").unlink()
    with pytest.raises(ModelError, match=r"no model\.safetensors"):
        load_model(saved)
    (saved / "card.json").write_text("{not json")
    with pytest.raises(ModelError, match="not readable JSON"):
        load_model(saved)


def test_a_model_refuses_a_trial_of_the_other_task(saved: Path, make_trial):
    model = load_model(saved)
    path, _ = make_trial(Task.SHORTS, steps=10)
    with TrialReader(path) as reader:
        task = reader.metadata.task
    with pytest.raises(ModelError, match="model is for gown but the trial is shorts"):
        check_task(model, task)
    check_task(model, "gown", n_points=8)
    with pytest.raises(ModelError, match="8 limb points"):
        check_task(model, Task.GOWN, n_points=300)
    with pytest.raises(ModelError, match="task 'hat' is not one of gown, shorts"):
        check_task(model, "hat")


def test_the_bundled_model_of_an_unknown_task_is_a_model_error() -> None:
    """Was the enum's ValueError; a task given as text is taken as the CLI gives it."""
    with pytest.raises(ModelError, match="task 'hat' is not one of gown, shorts"):
        resolve_model(None, "hat", 300)
    loaded = resolve_model(None, "gown", None)
    assert loaded is not None and loaded.card.task is Task.GOWN


@pytest.mark.parametrize(
    ("weights", "problem"),
    [({}, "not force-map LSTM weights"), ("no input_std", "weight input_std: expected shape")],
)
def test_the_estimator_refuses_weights_that_are_not_a_force_map_lstm(
    trained, weights: object, problem: str
):
    if weights == "no input_std":
        weights = {k: v for k, v in trained[0].items() if k != "input_std"}
    with pytest.raises(ModelError, match=problem):
        NumpyEstimator(weights)  # type: ignore[arg-type]


def test_a_card_needs_its_task():
    with pytest.raises(ValueError, match="task"):
        ModelCard(n_points=3)  # type: ignore[call-arg]


def test_input_normalisation_is_learned_saved_and_checked(tmp_path: Path):
    phis, forces = synthetic(6, seed=5, n_points=4)
    weights, history = fit(phis, forces, epochs=1, hidden=4, layers=1, normalise=True,
                             progress=False)  # fmt: skip
    card = save_model(tmp_path / "m", weights, make_card("shorts", weights, history))
    assert card.normalisation is not None
    assert all(s > 0 for s in card.normalisation.std) and any(card.normalisation.mean)
    model = load_model(tmp_path / "m")
    net = ForceMapLSTM.from_weights(model.weights)
    np.testing.assert_allclose(model.estimator().forward(phis[0]), torch_forward(net, phis[0]),
                               atol=1e-5)  # fmt: skip
    raw = json.loads((tmp_path / "m" / "card.json").read_text())
    raw["normalisation"] = None
    (tmp_path / "m" / "card.json").write_text(json.dumps(raw))
    with pytest.raises(ModelError, match="normalisation"):
        load_model(tmp_path / "m")


# -- a network that reads phi's change per step too ---------------------------------------
def test_a_network_reading_phis_change_gets_it_from_phi_step_by_step_and_whole():
    torch.manual_seed(2)
    net = ForceMapLSTM(N, input_dim=18)
    with torch.no_grad():
        for p in net.parameters():
            p.normal_(std=0.4)
    net.set_normalisation(np.linspace(-1, 1, 18), np.linspace(0.5, 2, 18))
    phi = np.random.default_rng(6).normal(size=(2, 60, 9)).astype(np.float32)
    est = NumpyEstimator(net.weights())
    assert est.differences and est.input_dim == 18
    expected = torch_forward(net, network_inputs(phi, differences=True))
    np.testing.assert_allclose(est.forward(phi), expected, atol=1e-5, rtol=0)
    assert not network_inputs(phi, differences=True)[:, 0, 9:].any()  # no change at t = 0
    for _ in range(2):  # the second pass checks that reset() forgets the last phi
        est.reset()
        steps = np.stack([est.step_raw(p).copy() for p in phi[1]])
        np.testing.assert_allclose(steps, expected[1], atol=1e-5, rtol=0)


def test_training_on_phis_change_is_recorded_and_round_trips(tmp_path: Path):
    phis, forces = synthetic(6, seed=5, n_points=4)
    weights, history = fit(phis, forces, epochs=1, hidden=4, layers=1, normalise=True,
                             input_differences=True, progress=False)  # fmt: skip
    card = save_model(tmp_path / "m", weights, make_card("shorts", weights, history))
    assert card.input_dim == 18 and card.hyperparameters.input_differences
    assert card.normalisation is not None and len(card.normalisation.std) == 18
    model = load_model(tmp_path / "m")
    net = ForceMapLSTM.from_weights(model.weights)
    x = network_inputs(phis[0], differences=True)
    np.testing.assert_allclose(model.estimator().forward(phis[0]), torch_forward(net, x),
                               atol=1e-5)  # fmt: skip
    raw = json.loads((tmp_path / "m" / "card.json").read_text())
    raw["hyperparameters"]["input_differences"] = False  # a card that misdescribes the net
    (tmp_path / "m" / "card.json").write_text(json.dumps(raw))
    with pytest.raises(ModelError, match="input_dim 18 for a network that reads 9") as info:
        load_model(tmp_path / "m")
    assert "\n" not in str(info.value)


def test_a_checkpoint_that_cannot_be_written_is_one_line(tmp_path: Path, monkeypatch) -> None:
    """safetensors reports a full disk as its own error, not an OSError: a traceback."""
    import safetensors.torch
    from safetensors import SafetensorError

    def full(*args: object, **kwargs: object) -> None:
        raise SafetensorError("Error while serializing: I/O error: No space left on device")

    monkeypatch.setattr(safetensors.torch, "save_file", full)
    phis, forces = synthetic(4, seed=2, n_points=4)
    kwargs = {"epochs": 1, "hidden": 4, "layers": 1, "progress": False}
    with pytest.raises(ModelError, match=r"cannot write the checkpoint: .*No space left"):
        fit(phis, forces, checkpoint=tmp_path / "run.ckpt", **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_a_training_window_starts_with_no_change_as_a_trial_does_in_inference() -> None:
    """`--window` with `--input-differences`: a crop is read from a fresh state, so its
    first step carries no change, as a trial's first step does when the model runs."""
    from dresslog.model.train import _crop

    phi = np.random.default_rng(0).normal(size=(50, 9)).astype(np.float32)
    inputs, y = network_inputs(phi, True), np.arange(50.0)[:, None]
    starts = []
    for seed in range(20):
        crop, target = _crop(inputs, y, 10, np.random.default_rng(seed))
        start = int(target[0, 0])
        starts.append(start)
        np.testing.assert_array_equal(crop, network_inputs(phi[start : start + 10], True))
    assert max(starts) > 0  # some windows start inside the sequence


def test_sequences_of_different_lengths_are_padded_with_zeros_after_them() -> None:
    from dresslog.trial import padded

    a, b = np.arange(6.0).reshape(3, 2), np.full((1, 2), 7.0)
    batch = padded([a, b])
    assert batch.dtype == np.float32 and batch.shape == (2, 3, 2)
    np.testing.assert_array_equal(batch[0], a)
    np.testing.assert_array_equal(batch[1], [[7, 7], [0, 0], [0, 0]])
    np.testing.assert_array_equal(padded([a, b], length=2)[0], a[:2])  # cut at length
    with pytest.raises(ValueError, match="no sequences to pad"):
        padded([])
