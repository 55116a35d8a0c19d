"""The paper's experiments on dataset folders: train a model, evaluate it, sweep it (Sec. V).

This is the glue between `dresslog.dataset` (folders, manifests, cached arrays) and
`dresslog.model` (network, training, metrics), so that the CLI commands and a Python
user make the same one call. Simulation and decoding run in spawned worker processes:
call these from under ``if __name__ == "__main__":`` in a script.

Public API
----------
``train_dataset(data, out, options=PAPER, *, init=None, overwrite=False,
workers=None, progress=True, on_epoch=None) -> ModelCard``
    Trains on the training split (holding out ``options.val_fraction`` of it, a tenth,
    for the per-epoch validation loss), scores
    the test split, and saves a model folder whose card names the data by its manifest
    hash and keeps the per-epoch losses, with their plot (``TRAINING_PLOT``,
    ``training.png``). Resumes from ``.<out>.checkpoint.safetensors`` beside `out`.
    ``TrainOptions`` (`dresslog.model.options`): every setting of the run, one field
    each; ``PAPER`` is ``TrainOptions()``, the paper's (3 layers of 50 cells, lr 0.001,
    10 epochs); ``hidden``
    and ``layers`` left None take the paper's sizes or, with ``init``, the initial
    model's.
``evaluate_dataset(model, data, *, split="test", bounds=False, plot=None, per_sequence=None,
overwrite=False, workers=None, progress=True) -> EvalReport``
    RMSE after Eq. 2, the all-zero baseline and their ratio, overall and per outcome
    (each a ``Scores``), with contact-map precision and recall, and the data's speeds and
    rotations beside the model's training ones (`conditions`), naming those outside
    them (``EvalReport.outside``); with ``plot``, a PNG of where along the limb and at
    what total force the model errs (`plots.plot_eval`); with ``per_sequence``, a
    CSV of each sequence's spec, outcome and scores; with ``bounds``, the
    oracle ratios too (none when the split carries no force, which a ``DresslogWarning``
    naming `data` explains: the all-zero RMSE is 0, so the ratios are nan). ``.table()``
    is what ``eval`` prints, ``.to_json()`` what ``eval --json`` prints.
``dataset_bounds(data, *, split="test", workers=None) -> dict[str, float]``
    Those oracle ratios alone (`dresslog.model.bounds`), each an estimate handed part of
    the truth; empty when the split carries no force.
``sweep(model, out, *, speeds=(), rotations=(), n=128, seed=0, duration=None,
execution=LOCAL, progress=True) -> SweepReport``
    Figs. 12 and 13: the same `n` fresh sequences (sweep seeds, disjoint from every
    training and test seed) re-simulated per setting; RMSE per setting and its ratio to
    the in-range setting; `out/sweep.csv`, `out/sweep.json` and `out/sweep.png`; a
    ``DresslogWarning`` names the settings whose sequences carry no force (ratios nan).
    ``execution`` (`dresslog.dataset.Execution`) is where the trials run and how many
    at once, as for `dresslog.dataset.generate`.
    ``SweepReport.table()`` is what ``sweep`` prints. The pieces it is made of:
    ``sweep_settings(task, speeds, rotations, duration=None, simulator="v9")`` (the
    ``Setting``s, the in-range one first, simulated by the model's simulator version; a
    rotation is swept at the task's mid-range ``ROTATION_SPEED``),
    ``parse_speed("0.2")``, ``parse_rotation("y:-15")`` and
    ``default_sweep_folder(model)`` (``./NAME-sweep``).
"""

from dresslog.experiments.evaluation import EvalReport, dataset_bounds, evaluate_dataset
from dresslog.experiments.sweeps import (
    ROTATION_SPEED,
    Setting,
    SweepReport,
    default_sweep_folder,
    parse_rotation,
    parse_speed,
    sweep,
    sweep_settings,
)
from dresslog.experiments.training import TRAINING_PLOT, train_dataset
from dresslog.model.evaluate import Scores
from dresslog.model.options import PAPER, TrainOptions

__all__ = [
    "PAPER",
    "ROTATION_SPEED",
    "TRAINING_PLOT",
    "EvalReport",
    "Scores",
    "Setting",
    "SweepReport",
    "TrainOptions",
    "dataset_bounds",
    "default_sweep_folder",
    "evaluate_dataset",
    "parse_rotation",
    "parse_speed",
    "sweep",
    "sweep_settings",
    "train_dataset",
]
