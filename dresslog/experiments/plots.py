"""The PNG figures dresslog writes: sweep results (Figs. 12-13) and training curves.

Public API
----------
``plot_sweep(path, report)``: RMSE against speed and against limb rotation, each with the
    all-zero estimate of the same sequences, the in-range line, the speeds and rotations
    the model was trained on shaded, a right-hand scale in x in-range and the paper's x
    in-range where ``PAPER_SWEEP`` has it for a setting swept (``dresslog sweep``).
``sweep_lines(report, kind)``: the points ``plot_sweep`` joins, per axis.
``plot_training(path, card)``: training and validation loss per epoch from a model card's
    ``history``, log scale, the kept epoch marked when ``keep_best`` chose it (``dresslog
    train`` writes it beside the model as ``training.png``).
``plot_eval(path, profile, task, title, *, overwrite=True)``: where along the limb a
    model errs (each point's mean true and estimated force and its RMSE, by distance from
    the hand or foot) and at what total force (estimated against true per step), from an
    ``ErrorProfile`` (``dresslog eval --plot``).
``sweep_figure(report)``, ``training_figure(card)``, ``eval_figure(...)``: the same as
    matplotlib Figures, to show in a notebook or read back.
``plot_sweep``, ``plot_training`` and ``plot_eval`` write atomically; all import matplotlib
(Agg, no display) only when called.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dresslog.io.files import atomic_path
from dresslog.spec import PAPER_AXES

#: The paper's RMSE over its in-range RMSE where the README's sweep table quotes one, by
#: (kind, our axis, value): the gown's at 20 cm/s, forearm -15 deg about its Y (our z) and
#: about its Z (our y); the shorts' at 30 cm/s.
PAPER_SWEEP: dict[str, dict[tuple[str, str, float], float]] = {
    "gown": {
        ("speed", "", 0.20): 4.4,
        ("rotation", "z", -15.0): 1.65,
        ("rotation", "y", -15.0): 0.82,
    },
    "shorts": {("speed", "", 0.30): 3.6},
}

if TYPE_CHECKING:
    from dresslog.experiments.sweeps import SweepReport
    from dresslog.model.evaluate import ErrorProfile
    from dresslog.model.files import ModelCard
    from dresslog.spec import Task

#: Width (m) of the bands along the limb whose points `eval_figure` averages.
ALONG_BIN = 0.02
#: Steps a bin of true total force needs for `eval_figure` to draw its mean estimate.
MIN_STEPS = 20


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | Path, *, overwrite: bool = True) -> None:
    fig.tight_layout()
    with atomic_path(path, overwrite=overwrite) as tmp:
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


def sweep_figure(report: SweepReport) -> Any:
    """Fig. 12 (RMSE against speed) and Fig. 13 (against rotation, one line per axis) as a
    matplotlib Figure; ``plot_sweep`` saves it."""
    plt = _pyplot()
    from matplotlib.transforms import ScaledTranslation

    kinds = [k for k in ("speed", "rotation") if any(s.kind == k for s in report.settings)]
    fig, axes = plt.subplots(1, len(kinds), figsize=(5.5 * len(kinds), 4.6), squeeze=False)
    base = report.baseline_rmse
    paper = PAPER_SWEEP.get(report.task, {})
    for ax, kind in zip(axes[0], kinds, strict=True):
        lines = sweep_lines(report, kind)
        colours = {}
        for axis, (values, rmse, zero) in lines.items():
            (drawn,) = ax.plot(values, rmse, "o-", label=_name(axis))
            colours[axis] = drawn.get_color()
            # the all-zero estimate of the same sequences: how much force there was to find
            zero_label = f"{_name(axis)}, all-zero" if axis else "all-zero estimate"
            ax.plot(values, zero, "x:", color=colours[axis], label=zero_label)
        ax.axhline(base, color="gray", ls="--", label="in-range")
        # the paper's x in-range at the settings swept here, on the right-hand scale
        for (k, axis, value), ratio in paper.items():
            if k == kind and value in _swept(lines, axis) and base > 0:
                ax.plot(value, ratio * base, "*", ms=12, mec="black", color=colours[axis],
                        label=_paper_name(axis))  # fmt: skip
        if base > 0:
            right = ax.secondary_yaxis("right", functions=(lambda y: y / base, lambda r: r * base))
            right.set_ylabel("x in-range RMSE")
        trained = _mark_trained(ax, report, kind, colours)
        swept = sorted({v for values, *_ in lines.values() for v in values} | trained)
        if len(swept) <= 8:  # ticks at the settings: one speed alone got a crowd of them
            ax.set_xticks(swept)
        ax.set_xlabel("end-effector speed (m/s)" if kind == "speed" else "limb rotation (deg)")
        ax.set_ylabel("RMSE (N)")
        ax.set_title(f"against {'speed (Fig. 12)' if kind == 'speed' else 'rotation (Fig. 13)'}")
        # below the axes (inside, it hides the lines it names), by a fixed 0.5 inch: a
        # share of the axes' height went under the axis label when tight_layout shrank them
        below = ax.transAxes + ScaledTranslation(0, -0.5, fig.dpi_scale_trans)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0), bbox_transform=below, ncol=2,
                  fontsize="small")  # fmt: skip
    name = Path(report.model).name
    model = name if name == report.task else f"{name} ({report.task})"
    fig.suptitle(
        f"Generalisation sweep of model {model}, {report.n} sequences per setting{report.longer()}"
    )
    return fig


def _mark_trained(ax: Any, report: SweepReport, kind: str, colours: dict[str, str]) -> set[float]:
    """Shade the speeds or rotations the model was trained on (a line for one fixed
    value), a rotation in its axis's colour and only on an axis swept; return their ends,
    for the ticks."""
    if kind == "speed":
        spans = [("", low, high) for low, high in report.trained_speeds]
    else:
        spans = [span for span in report.trained_rotations if span[0] in colours]
    ends: set[float] = set()
    for axis, low, high in spans:
        label = "training speeds" if kind == "speed" else f"training rotations about {axis}"
        if label in ax.get_legend_handles_labels()[1]:
            label = "_nolegend_"  # two spans about one axis: named once
        colour = colours[axis] if axis else "gray"  # speed: not the model line's colour
        if high > low:
            ax.axvspan(low, high, color=colour, alpha=0.12, lw=0, label=label)
        else:
            ax.axvline(low, color=colour, alpha=0.25, lw=7, label=label)
        ends |= {low, high}
    return ends


def _name(axis: str) -> str:
    """A sweep line's name in the legend: the model's, or its rotation axis's."""
    return f"about {axis} (paper's {PAPER_AXES[axis]})" if axis else "model"


def _paper_name(axis: str) -> str:
    """The legend's name for the paper's x in-range at a setting."""
    return f"about {axis}, the paper (x in-range)" if axis else "the paper (x in-range)"


def _swept(lines: dict[str, tuple[list[float], ...]], axis: str) -> set[float]:
    """The values measured (not gaps) on one axis's line."""
    values, rmse, _ = lines.get(axis, ([], [], []))
    return {v for v, r in zip(values, rmse, strict=True) if not math.isnan(r)}


def plot_sweep(path: str | Path, report: SweepReport) -> None:
    """Write the sweep's figure (``sweep_figure``) as a PNG."""
    _save(sweep_figure(report), path)


def eval_figure(profile: ErrorProfile, task: Task | str, title: str) -> Any:
    """Where along the limb the model errs, and at what total force, as a matplotlib
    Figure; ``plot_eval`` saves it. The left panel averages the points of each 2 cm band
    along the limb; the right one shows each step's estimated total force against the
    true one, with the mean estimate at each true total: an MSE estimate that cannot
    tell a high total from a middling one bends away from the diagonal there."""
    import numpy as np

    from dresslog.limb import along_limb, build_limb, chain_joints, limb_points

    plt = _pyplot()
    limb = build_limb(task)
    along = along_limb(limb, limb_points(limb).points) * 100  # cm
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.6))
    bands = np.floor(along / (ALONG_BIN * 100)).astype(int)
    held = np.unique(bands)
    centres = (held + 0.5) * ALONG_BIN * 100
    for values, label, style in (
        (profile.mean_true, "true force", {"color": "black"}),
        (profile.mean_estimate, "estimate", {"color": "C0"}),
        (profile.rmse, "RMSE", {"color": "C3", "ls": "--"}),
    ):
        banded = [values[bands == b].mean() for b in held]
        left.plot(centres, banded, label=label, **style)
    for name, at in zip(limb.chain, chain_joints(limb) * 100, strict=True):
        left.axvline(at, color="gray", ls=":", lw=0.8)
        left.annotate(name, (at, 1), xycoords=("data", "axes fraction"), xytext=(2, -12),
                      textcoords="offset points", fontsize="small", color="gray")  # fmt: skip
    left.set_xlabel(f"along the {limb.name} from the tip of the {limb.chain[0]} (cm)")
    left.set_ylabel("force per limb point (N), over every step")
    if (worst := float(profile.rmse.max())) > 0:  # log: the force at the hand would
        left.set_yscale("log")  # flatten the rest to 0; below 1e-5 of the worst, none
        left.set_ylim(worst * 1e-5, worst * 2)
    left.set_title("Where: mean force and RMSE per limb point", fontsize="medium")
    left.legend(loc="best")
    totals = profile.totals
    true, estimate = totals[:, 0], totals[:, 1]
    if len(true) and true.max() > 0:
        top = float(max(true.max(), estimate.max()))
        cells = right.hexbin(true, estimate, gridsize=40, bins="log", mincnt=1,
                             extent=(0, top, 0, top), cmap="viridis")  # fmt: skip
        fig.colorbar(cells, ax=right, label="steps")
        right.plot([0, top], [0, top], color="gray", lw=0.8, label="estimate = truth")
        which = np.minimum((true / true.max() * 20).astype(int), 19)  # 20 bins of truth
        means = [(true[which == b].mean(), estimate[which == b].mean())
                 for b in range(20) if np.count_nonzero(which == b) >= MIN_STEPS]  # fmt: skip
        right.plot(*zip(*means, strict=True), "o-", color="C1", ms=3,
                   label="mean estimate at that truth")  # fmt: skip
        r = np.corrcoef(true, estimate)[0, 1] if estimate.std() > 0 else math.nan
        right.set_title(f"How much: total force per step (r = {r:.2f})", fontsize="medium")
        right.legend(loc="upper left")
    else:
        right.set_title("How much: no force on the limb in these steps", fontsize="medium")
    right.set_xlabel("true total force on the limb (N)")
    right.set_ylabel("estimated total force (N)")
    fig.suptitle(title, fontsize="medium")
    return fig


def plot_eval(
    path: str | Path, profile: ErrorProfile, task: Task | str, title: str, *, overwrite: bool = True
) -> None:
    """Write ``eval_figure`` as a PNG; without `overwrite`, never over an existing file."""
    _save(eval_figure(profile, task, title), path, overwrite=overwrite)
