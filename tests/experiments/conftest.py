"""Fixtures of the experiments tests: a small real gown dataset, a model trained on it,
and the `dresslog` invocation they share.

The fixtures are module-scoped: each test file that asks for them simulates and trains its
own copy once, so a file's tests (some of which add to or overwrite the folders) never
depend on which other file ran first. `tests/model/test_recipe.py` imports `data` too."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.dataset import Execution, generate
from dresslog.model.files import ModelCard, save_model
from dresslog.model.numpy_lstm import expected_shapes
from dresslog.spec import RotationRange


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
    """`dresslog ARGS` in-process: its exit code and output."""
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.output


def fake_model(path: Path, task: str) -> Path:
    """A real model folder of random weights (hidden 4, 1 layer) for `task`, untrained: for
    the tests of refusals and descriptions, which need no training."""
    rng = np.random.default_rng(0)
    n = 300 if task == "gown" else 400
    weights = {
        k: rng.normal(size=s).astype(np.float32) for k, s in expected_shapes(n, 4, 1, 9).items()
    }
    weights["input_mean"], weights["input_std"] = np.zeros(9, np.float32), np.ones(9, np.float32)
    save_model(path, weights, ModelCard(task=task, n_points=n, hidden=4, layers=1))
    return path
