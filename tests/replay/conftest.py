"""Fixtures of the replay tests: a real model folder of random weights."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dresslog.model.files import ModelCard, Normalisation, save_model
from dresslog.model.numpy_lstm import expected_shapes
from dresslog.spec import Task
from tests.conftest import N_POINTS

STEPS = 40


def save_random_model(
    folder: Path, task: Task = Task.GOWN, seed: int = 0, std: float = 2.0
) -> Path:
    """A real model folder (save_model) with random weights large enough to saturate gates,
    its inputs standardised by `std` (the training signal's spread, as the card says)."""
    rng = np.random.default_rng(seed)
    shapes = expected_shapes(N_POINTS[task])
    weights = {k: rng.normal(0, 0.4, size=s).astype(np.float32) for k, s in shapes.items()}
    weights["input_mean"][:] = 0.0
    weights["input_std"][:] = std
    path = folder / f"model-{task.value}"
    norm = Normalisation(mean=[0.0] * 9, std=[std] * 9)
    save_model(path, weights, ModelCard(task=task, n_points=N_POINTS[task], normalisation=norm))
    return path
