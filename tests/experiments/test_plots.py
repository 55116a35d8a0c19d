"""The figures of dresslog.experiments.plots: the sweep plot and the learning curve."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib.colors
import matplotlib.image
import matplotlib.pyplot
import numpy as np
import pytest

from dresslog.experiments import Scores, SweepReport, sweep_settings
from dresslog.experiments.plots import plot_sweep, sweep_figure, sweep_lines, training_figure
from dresslog.model.files import ModelCard, load_model
from dresslog.spec import Task
from tests.conftest import SAMPLES


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
    # the bundled model's epochs, repeated as far as `epochs` asks
    history = [
        e.model_copy(update={"epoch": k + 1, "val_loss": e.val_loss if n_val else None})
        for k, e in enumerate(card.history[k % len(card.history)] for k in range(epochs))
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
    n_train = _card(1, 0).data.n_train  # the bundled model's
    (ax,) = one.axes
    assert list(ax.get_xticks()) == [1]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["training (no validation split)"]
    assert (
        ax.get_title()
        == f"Learning curve: gown, 3x100 LSTM, lr 0.001 cosine\n{n_train} training sequences"
    )
    (ax,) = training_figure(_card(3, 300, kept=2)).axes
    assert list(ax.get_xticks()) == [1, 2, 3]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "training",
        "validation",
        "kept (epoch 2)",
    ]
    assert ax.get_title().endswith(f"\n{n_train} training sequences, 300 validation")
    (ax,) = training_figure(_card(60, 300, kept=43)).axes
    ticks = ax.get_xticks()
    assert all(t == int(t) for t in ticks) and 4 <= len(ticks) <= 10, ticks
    matplotlib.pyplot.close("all")
