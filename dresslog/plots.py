"""The PNG figures dresslog writes: sweep results (Figs. 12-13) and training curves.

Public API
----------
``plot_sweep(path, report)``: RMSE against speed and against limb rotation, each with the
    all-zero estimate of the same sequences and the in-range line (``dresslog sweep``).
``sweep_lines(report, kind)``: the points ``plot_sweep`` joins, per axis.
``plot_training(path, card)``: training and validation loss per epoch from a model card's
    ``history``, log scale, the kept epoch marked when ``keep_best`` chose it (``dresslog
    train`` writes it beside the model as ``training.png``).
``training_figure(card)``: the same as a matplotlib Figure, to show in a notebook or read
    back.
``plot_sweep`` and ``plot_training`` write atomically; all import matplotlib (Agg, no
display) only when called.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dresslog.io.files import atomic_path
from dresslog.spec import PAPER_AXES

if TYPE_CHECKING:
    from dresslog.experiments.sweeps import SweepReport
    from dresslog.model.files import ModelCard


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | Path) -> None:
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120, bbox_inches="tight")
    _pyplot().close(fig)


def training_figure(card: ModelCard) -> Any:
    """The learning curve as a matplotlib Figure: is the model still improving, over-fitting,
    or done? ``plot_training`` saves it."""
    plt = _pyplot()
    from matplotlib.ticker import MaxNLocator

    epochs = [e.epoch for e in card.history]
    fig, ax = plt.subplots(figsize=(6, 4))
    # without a validation split the legend says why there is no second line
    train_label = "training" if card.data.n_val else "training (no validation split)"
    ax.plot(epochs, [e.train_loss for e in card.history], "o-", ms=3, label=train_label)
    scored = [e for e in card.history if e.val_loss is not None]
    if scored:
        ax.plot(
            [e.epoch for e in scored], [e.val_loss for e in scored], "o-", ms=3, label="validation"
        )
    kept = card.metrics.get("kept_epoch")
    if kept is not None:
        ax.axvline(kept, color="gray", ls="--", label=f"kept (epoch {kept:g})")
    ax.set_yscale("log")
    if len(epochs) <= 10:  # one tick per epoch: one epoch alone got 0.96, 0.98, ...
        ax.set_xticks(epochs)
    else:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 5, 10]))
    ax.set_xlabel("epoch")
    ax.set_ylabel("loss (MSE of force and contact map)")
    hp = card.hyperparameters
    held = f", {card.data.n_val} validation" if card.data.n_val else ""
    ax.set_title(
        f"Learning curve: {card.task.value}, {card.layers}x{card.hidden} LSTM, "
        f"lr {hp.lr:g} {hp.lr_schedule}\n{card.data.n_train} training sequences{held}",
        fontsize="medium",
    )
    ax.legend()
    return fig


def plot_training(path: str | Path, card: ModelCard) -> None:
    """Write the learning curve (``training_figure``) as a PNG."""
    _save(training_figure(card), path)


def sweep_lines(report: SweepReport, kind: str) -> dict[str, tuple[list[float], ...]]:
    """Per axis ('' for speed): setting values, RMSE and all-zero RMSE, in order of value.

    A rotation axis with no 0 deg setting gets a gap (NaN) at 0: the in-range line stands
    for 0 deg there, and a straight line from -15 to +15 deg would draw a trend never measured.
    """
    lines: dict[str, tuple[list[float], ...]] = {}
    chosen = [(s, s.scores) for s in report.settings if s.kind == kind and s.scores]
    for axis in sorted({s.axis for s, _ in chosen}):
        points = [(s.value, sc.rmse, sc.zero_rmse) for s, sc in chosen if s.axis == axis]
        if kind == "rotation" and all(value != 0 for value, _, _ in points):
            points.append((0.0, math.nan, math.nan))
        values, rmse, zero = zip(*sorted(points), strict=True)
        lines[axis] = (list(values), list(rmse), list(zero))
    return lines


def plot_sweep(path: str | Path, report: SweepReport) -> None:
    """Fig. 12 (RMSE against speed) and Fig. 13 (against rotation, one line per axis)."""
    plt = _pyplot()
    kinds = [k for k in ("speed", "rotation") if any(s.kind == k for s in report.settings)]
    fig, axes = plt.subplots(1, len(kinds), figsize=(5 * len(kinds), 4.4), squeeze=False)
    for ax, kind in zip(axes[0], kinds, strict=True):
        lines = sweep_lines(report, kind)
        for axis, (values, rmse, zero) in lines.items():
            label = f"about {axis} (paper's {PAPER_AXES[axis]})" if axis else "model"
            (drawn,) = ax.plot(values, rmse, "o-", label=label)
            # the all-zero estimate of the same sequences: how much force there was to find
            zero_label = f"{label}, all-zero" if axis else "all-zero estimate"
            ax.plot(values, zero, "x:", color=drawn.get_color(), label=zero_label)
        ax.axhline(report.baseline_rmse, color="gray", ls="--", label="in-range")
        swept = sorted({v for values, *_ in lines.values() for v in values})
        if len(swept) <= 8:  # ticks at the settings: one speed alone got a crowd of them
            ax.set_xticks(swept)
        ax.set_xlabel("end-effector speed (m/s)" if kind == "speed" else "limb rotation (deg)")
        ax.set_ylabel("RMSE (N)")
        ax.set_title(f"{report.task}, {report.n} sequences per setting")
        # below the axes: inside, it hides the lines it names
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize="small")
    _save(fig, path)
