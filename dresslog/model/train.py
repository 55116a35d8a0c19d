"""Train the force-map LSTM on (phi, force map) sequences, with the paper's defaults.

Public API
----------
``train(sequences, forces, options=PAPER, *, val=None, init=None, progress=True,
checkpoint=None, restart_other=False, on_epoch=None) -> (weights, TrainHistory)``
    ``sequences``: list of phi arrays (T_i, 9); ``forces``: matching ground-truth force
    maps (T_i, N). Targets are ``[forces, contact map]`` (Eq. 1), the loss their MSE,
    the optimiser RMSprop, as in the paper. ``weights`` is the float32 dict that
    ``save_model`` writes; ``history.settings`` is the card's ``Hyperparameters``.

    Lengths may differ: a batch is zero-padded at the end to its longest sequence and the
    padded steps are masked out of the loss; the LSTM is causal, so padding never changes
    a valid step's output. ``options`` (``dresslog.model.options.TrainOptions``) holds
    every setting, the paper's by default; ``options.window=W`` instead trains on one
    random W-step crop per sequence per epoch (faster on long trials, but the network
    then learns to start mid-trial from a zero state, unlike inference; full sequences
    are the default).

    ``val``: (sequences, forces) to validate on; otherwise ``options.val_fraction`` of the
    sequences (chosen by the seed) is held out. ``keep_best``: return the weights of the
    epoch with the lowest validation loss rather than the last (the paper kept the last).
    ``lr_schedule="cosine"`` anneals the learning rate from ``lr`` towards 0 over the
    epochs (set per epoch from its number alone, so a resumed run follows the same curve);
    the paper's is constant. ``input_differences``: the network reads phi's change per
    step as 9 more inputs (``dresslog.model.inputs``; not in the paper).
    ``init``: weights (as ``save_model`` writes them) to start from instead of random ones,
    their input standardisation kept (``normalise`` is then theirs): fine-tuning. Their
    sizes must be ``options.network()`` and the inputs'; the optimiser starts afresh.
    Same data, seed and threads give the same weights. ``checkpoint``: a file written
    after every epoch (safetensors, its settings as JSON metadata: nothing is unpickled)
    from which an interrupted run resumes;
    one of other settings or data is refused, or with ``restart_other`` replaced by a
    fresh run (resuming one of the same is what a fresh run would compute anyway).
    ``options.threads``: torch CPU threads, default min(2, cores), restored afterwards.

``make_card(task, weights, history, *, data=None, init=None, metrics=None) -> ModelCard``
    The card for freshly trained weights: sizes and normalisation read from the weights,
    hyperparameters and the kept epoch's losses from the history; ``save_model`` adds the hash.

``balanced_force_scale(forces) -> float``: what ``balance_loss`` multiplies the force
    targets by (the mean non-zero force to the contact map's 0.1).
``epoch_lr(settings, epoch) -> float``: the learning rate of a 0-based epoch.

``TrainHistory``: ``settings``, ``epochs`` (list of ``EpochRecord(epoch, train_loss,
    val_loss, seconds)``, the card's ``history``), ``n_train``, ``n_val``,
    ``kept`` (the record of the epoch whose
    weights were returned).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from dresslog.errors import ModelError
from dresslog.model.checkpoint import RunState, fingerprint, resume, run_key, save_checkpoint
from dresslog.model.files import (
    DataProvenance,
    EpochRecord,
    Hyperparameters,
    InitialModel,
    ModelCard,
    Normalisation,
)
from dresslog.model.inputs import PHI_DIM, network_inputs, reads_differences
from dresslog.model.network import ForceMapLSTM
from dresslog.model.numpy_lstm import infer_sizes
from dresslog.model.options import PAPER, TrainOptions, check_options, held_out
from dresslog.model.postprocess import network_targets
from dresslog.spec import Task, task_of
from dresslog.trial import padded

Batch = tuple[torch.Tensor, torch.Tensor, torch.Tensor]


@dataclass
class TrainHistory:
    """Per-epoch losses and the settings that produced them (for the model card)."""

    settings: Hyperparameters
    n_train: int
    n_val: int
    epochs: list[EpochRecord] = field(default_factory=list)

    @property
    def kept(self) -> EpochRecord | None:
        """The epoch whose weights `train` returns: the last, or the best if `keep_best`."""
        scored = [e for e in self.epochs if e.val_loss is not None]
        if self.settings.keep_best and scored:
            return min(scored, key=lambda e: e.val_loss or 0.0)
        return self.epochs[-1] if self.epochs else None


def _check_data(sequences: Sequence[np.ndarray], forces: Sequence[np.ndarray]) -> int:
    """Validate shapes up front so a bad dataset fails in one line, not deep in torch."""
    if len(sequences) != len(forces):
        raise ModelError(f"{len(sequences)} input sequences but {len(forces)} force maps")
    if not sequences:
        raise ModelError("no training sequences")
    n_points = forces[0].shape[-1]
    for k, (phi, f) in enumerate(zip(sequences, forces, strict=True)):
        if phi.ndim != 2 or phi.shape[1] != PHI_DIM or len(phi) == 0:
            raise ModelError(f"sequence {k}: phi has shape {phi.shape}, expected (T, {PHI_DIM})")
        if f.shape != (len(phi), n_points):
            raise ModelError(
                f"sequence {k}: force map has shape {f.shape}, expected ({len(phi)}, {n_points})"
            )
        if not (np.isfinite(phi).all() and np.isfinite(f).all()):
            raise ModelError(f"sequence {k} has NaN or infinite values")
    return n_points


def _batch(
    phis: Sequence[np.ndarray], targets: Sequence[np.ndarray], device: torch.device
) -> Batch:
    """Zero-pad a batch to its longest sequence, on `device`; mask marks the real steps."""
    x, y = padded(phis), padded(targets)
    real = np.array([len(p) for p in phis])[:, None] > np.arange(x.shape[1])
    mask = real[..., None].astype(np.float32)
    return (
        torch.from_numpy(x).to(device),
        torch.from_numpy(y).to(device),
        torch.from_numpy(mask).to(device),
    )


def training_device(name: str) -> torch.device:
    """The torch device `train --device` names: "auto" takes CUDA when torch sees one.

    Raises:
        ModelError: "cuda" asked for where torch sees no CUDA device.
    """
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda" and not torch.cuda.is_available():
        raise ModelError(
            f"--device cuda: torch {torch.__version__} sees no CUDA device "
            "(a CPU build, or no GPU here); use --device cpu or auto"
        )
    return torch.device(name)


def _crop(
    inputs: np.ndarray, y: np.ndarray, window: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """A random `window` of a sequence, read as a sequence of its own.

    The network starts it from a fresh state, so a network that reads phi's change
    gets no change at its first step, as at a trial's first step in inference.
    """
    if len(inputs) <= window:
        return inputs, y
    start = int(rng.integers(0, len(inputs) - window + 1))
    cropped = inputs[start : start + window]
    if start and reads_differences(inputs.shape[1]):
        cropped = cropped.copy()
        cropped[0, PHI_DIM:] = 0.0
    return cropped, y[start : start + window]


def _masked_mse(out: torch.Tensor, y: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean squared error over real steps and all 2N outputs (Keras's MSE when unpadded)."""
    return ((out - y) ** 2 * mask).sum() / (mask.sum() * out.shape[-1])


def _evaluate_loss(
    net: ForceMapLSTM, phis: list[np.ndarray], targets: list[np.ndarray], batch_size: int
) -> float:
    total, count = 0.0, 0.0
    order = np.argsort([len(p) for p in phis])  # similar lengths together: less padding
    device = next(net.parameters()).device
    with torch.no_grad():
        for start in range(0, len(order), batch_size):
            idx = order[start : start + batch_size]
            x, y, mask = _batch([phis[k] for k in idx], [targets[k] for k in idx], device)
            out, _ = net(x)
            total += float(((out - y) ** 2 * mask).sum())
            count += float(mask.sum()) * out.shape[-1]
    return total / count


def train(
    sequences: Sequence[np.ndarray],
    forces: Sequence[np.ndarray],
    options: TrainOptions = PAPER,
    *,
    val: tuple[Sequence[np.ndarray], Sequence[np.ndarray]] | None = None,
    init: Mapping[str, np.ndarray] | None = None,
    progress: bool = True,
    checkpoint: str | Path | None = None,
    restart_other: bool = False,
    on_epoch: Callable[[EpochRecord], None] | None = None,
) -> tuple[dict[str, np.ndarray], TrainHistory]:
    """Train a ForceMapLSTM (the module docstring says how).

    Args:
        sequences: phi arrays, (T_i, 9) each.
        forces: their ground-truth force maps, (T_i, N) each.
        options: every setting of the run; by default the paper's.
        val: (sequences, forces) to validate on instead of a held-out share.
        init: weights to start from (fine-tuning), as `save_model` writes them.
        progress: show a progress bar of the epochs.
        checkpoint: a file written after every epoch, from which a run resumes.
        restart_other: replace a checkpoint of other settings or data, not refuse it.
        on_epoch: called with each epoch's record as it ends.

    Returns:
        The float32 weights and the run's `TrainHistory`.

    Raises:
        ModelError: mismatched or non-finite data, settings the data make meaningless,
            initial weights of other sizes, a checkpoint of another run, a diverged run.
    """
    opts = options
    hidden, layers = opts.network()
    n_points = _check_data(sequences, forces)
    differences = opts.input_differences
    phis = [network_inputs(np.asarray(p, np.float32), differences) for p in sequences]
    scale = balanced_force_scale(forces) if opts.balance_loss else 1.0
    targets = [network_targets(f, scale) for f in forces]
    rng = np.random.default_rng(opts.seed)
    if val is not None:
        _check_data(val[0], val[1])
        val_phis = [network_inputs(np.asarray(p, np.float32), differences) for p in val[0]]
        val_targets = [network_targets(f, scale) for f in val[1]]
    else:
        n_val = held_out(len(phis), opts.val_fraction)
        perm = rng.permutation(len(phis))
        held, kept = perm[:n_val], perm[n_val:]
        val_phis, val_targets = [phis[k] for k in held], [targets[k] for k in held]
        phis, targets = [phis[k] for k in kept], [targets[k] for k in kept]
    check_options([len(p) for p in phis], len(val_phis), opts)
    if init is not None and (sizes := infer_sizes(init)) != (
        wanted := (n_points, hidden, layers, phis[0].shape[1])
    ):
        shown = "{} limb points, {} cells x {} layers, {} inputs"
        raise ModelError(
            f"the initial weights are for {shown.format(*sizes)}, this run {shown.format(*wanted)}"
        )

    settings = Hyperparameters(
        epochs=opts.epochs,
        batch_size=opts.batch_size,
        lr=opts.lr,
        seed=opts.seed,
        window=opts.window,
        val_fraction=0.0 if val is not None else opts.val_fraction,
        force_scale=scale,
        keep_best=opts.keep_best,
        lr_schedule=opts.lr_schedule,
        input_differences=differences,
    )
    history = TrainHistory(settings=settings, n_train=len(phis), n_val=len(val_phis))
    device = training_device(opts.device)
    previous_threads = torch.get_num_threads()
    torch.set_num_threads(opts.threads or min(2, os.cpu_count() or 1))

    def build() -> tuple[ForceMapLSTM, torch.optim.Optimizer]:
        torch.manual_seed(opts.seed)
        net = ForceMapLSTM(n_points, hidden=hidden, layers=layers, input_dim=phis[0].shape[1])
        if init is not None:  # its outputs in newtons, the loss's forces in newtons x scale
            start = {k: np.array(v, np.float32) for k, v in init.items()}
            start["head.weight"][:n_points] *= scale
            start["head.bias"][:n_points] *= scale
            net.load_state_dict({k: torch.from_numpy(v) for k, v in start.items()})
        elif opts.normalise:
            steps = np.concatenate(phis)
            net.set_normalisation(steps.mean(axis=0), steps.std(axis=0))
        net.to(device)  # before the optimiser, whose state lives beside the parameters
        return net, torch.optim.RMSprop(net.parameters(), lr=opts.lr)

    try:
        net, optim = build()
        ckpt = Path(checkpoint) if checkpoint is not None else None
        data = fingerprint(phis, targets, val_phis, val_targets)
        initial = None if init is None else fingerprint([init[name] for name in sorted(init)])
        key = run_key(net, history, opts.normalise, data, initial)
        run = RunState(net, optim, history, key)
        if ckpt is not None and ckpt.exists():
            try:
                resume(ckpt, run)
            except ModelError:
                if not restart_other:
                    raise
                ckpt.unlink()  # another run's (or unreadable): this one starts afresh
                history.epochs = []
                run = RunState(*build(), history, run.key)
        _fit(run, phis, targets, val_phis, val_targets, progress, ckpt, on_epoch)
        if run.best:
            run.net.load_state_dict(run.best)
    finally:
        torch.set_num_threads(previous_threads)
    weights = run.net.weights()
    weights["head.weight"][:n_points] /= scale  # outputs in newtons again
    weights["head.bias"][:n_points] /= scale
    return weights, history


def balanced_force_scale(forces: Sequence[np.ndarray]) -> float:
    """Scale that brings the mean non-zero force to 0.1, the contact map's magnitude.

    The paper sized the contact map (+-0.1) to the forces it expected; where the
    forces are much smaller (our gown), the MSE is all contact map and the network
    learns to ignore the force map. Scaling the force targets restores the balance.
    """
    total, count = 0.0, 0
    for f in forces:
        positive = f[f > 0]
        total += float(positive.sum())
        count += positive.size
    return 0.1 / (total / count) if count else 1.0


def epoch_lr(settings: Hyperparameters, epoch: int) -> float:
    """The learning rate of 0-based `epoch`: constant, or annealed by half a cosine."""
    if settings.lr_schedule == "cosine":
        return settings.lr * 0.5 * (1.0 + math.cos(math.pi * epoch / settings.epochs))
    return settings.lr


def _fit(
    run: RunState,
    phis: list[np.ndarray],
    targets: list[np.ndarray],
    val_phis: list[np.ndarray],
    val_targets: list[np.ndarray],
    progress: bool,
    ckpt: Path | None,
    on_epoch: Callable[[EpochRecord], None] | None,
) -> None:
    from tqdm import tqdm

    net, optim, history = run.net, run.optim, run.history
    device = next(net.parameters()).device
    s = history.settings
    bar = tqdm(total=s.epochs, initial=len(history.epochs), unit="epoch", disable=not progress)
    for epoch in range(len(history.epochs), s.epochs):
        started = time.perf_counter()
        # Each epoch's shuffle depends only on (seed, epoch), so a resumed run matches.
        rng = np.random.default_rng([s.seed, epoch])
        for group in optim.param_groups:
            group["lr"] = epoch_lr(s, epoch)
        order = rng.permutation(len(phis))
        net.train()
        total, count = 0.0, 0
        for start in range(0, len(order), s.batch_size):
            idx = order[start : start + s.batch_size]
            pairs = [(phis[k], targets[k]) for k in idx]
            if s.window is not None:
                pairs = [_crop(p, t, s.window, rng) for p, t in pairs]
            x, y, mask = _batch([p for p, _ in pairs], [t for _, t in pairs], device)
            out, _ = net(x)
            loss = _masked_mse(out, y, mask)
            optim.zero_grad(set_to_none=True)
            loss.backward()
            optim.step()
            total += loss.item() * len(idx)
            count += len(idx)
        net.eval()
        val_loss = _evaluate_loss(net, val_phis, val_targets, 64) if val_phis else None
        if not math.isfinite(total + (val_loss or 0.0)):
            if ckpt is not None:  # resuming would only diverge again
                ckpt.unlink(missing_ok=True)
            raise ModelError(
                f"training diverged in epoch {epoch + 1} (its loss is not finite); "
                "nothing was saved: lower the learning rate (--lr)"
            )
        record = EpochRecord(
            epoch=epoch + 1,
            train_loss=total / count,
            val_loss=val_loss,
            seconds=time.perf_counter() - started,
        )
        history.epochs.append(record)
        if s.keep_best and history.kept is record:
            run.best.update({k: v.detach().clone() for k, v in net.state_dict().items()})
        if ckpt is not None:
            save_checkpoint(ckpt, run)
        shown = {"loss": f"{record.train_loss:.3g}"}
        bar.set_postfix(shown if val_loss is None else {**shown, "val": f"{val_loss:.3g}"})
        bar.update()
        if on_epoch is not None:
            with tqdm.external_write_mode():  # the bar steps aside for the caller's lines
                on_epoch(record)
    bar.close()


def make_card(
    task: Task | str,
    weights: dict[str, np.ndarray],
    history: TrainHistory,
    *,
    data: DataProvenance | None = None,
    init: InitialModel | None = None,
    metrics: dict[str, float] | None = None,
) -> ModelCard:
    """A model card for trained weights; evaluation metrics can be added later."""
    n_points, hidden, layers, input_dim = infer_sizes(weights)
    mean, std = weights["input_mean"], weights["input_std"]
    identity = not mean.any() and bool(np.all(std == 1.0))
    data = data or DataProvenance()
    data = data.model_copy(update={"n_train": history.n_train, "n_val": history.n_val})
    kept = history.kept
    losses = {"train_loss": kept.train_loss if kept else float("nan")}
    if kept is not None and kept.val_loss is not None:
        losses["val_loss"] = kept.val_loss
    if history.settings.keep_best and kept is not None:
        losses["kept_epoch"] = float(kept.epoch)
    return ModelCard(
        task=task_of(task, ModelError),
        n_points=n_points,
        hidden=hidden,
        layers=layers,
        input_dim=input_dim,
        normalisation=None if identity else Normalisation(mean=mean.tolist(), std=std.tolist()),
        hyperparameters=history.settings,
        data=data,
        init=init,
        metrics={**losses, **(metrics or {})},
        history=history.epochs,
    )
