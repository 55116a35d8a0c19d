"""`train --recipe` and `--device`, and the `dresslog train` line `info MODEL` prints:
run as printed, it trains the same weights."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
import torch
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.model.files import read_card
from dresslog.model.options import BUNDLED, PAPER
from dresslog.model.recipe import options_of, train_command
from tests.conftest import SAMPLES
from tests.experiments.conftest import data  # noqa: F401  (the module's 4 gown trials)

TINY = ["--epochs", "2", "--hidden", "4", "--layers", "1", "--quiet"]


def invoke(*args: str | Path) -> tuple[int, str]:
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result.exit_code, result.output


def test_the_bundled_models_lines_name_their_folders_and_the_bundled_recipe() -> None:
    gown = read_card(SAMPLES / "models" / "gown")
    shorts = read_card(SAMPLES / "models" / "shorts")
    assert (
        train_command(gown)
        == "dresslog train data/gown-v9-4k -o MODEL --recipe bundled --epochs 30"
    )
    assert train_command(shorts, "out") == (
        "dresslog train data/shorts-v9-4k -o out --recipe bundled --epochs 30"
    )
    # the bundled recipe, but for the epochs each task's 3,000 sequences needed
    for card in (gown, shorts):
        assert options_of(card).model_dump(exclude={"hidden", "layers", "epochs"}) == (
            BUNDLED.model_dump(exclude={"hidden", "layers", "epochs"})
        )
        assert options_of(card).epochs == 30


def test_info_prints_the_line_that_trains_the_same_weights_again(
    data: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    first = tmp_path / "first"
    code, output = invoke(
        "train", data, "-o", first, "--recipe", "bundled", "--no-keep-best", "--seed", "3",
        "--lr", "0.002", *TINY,
    )  # fmt: skip
    assert code == 0, output
    code, output = invoke("info", first)
    assert code == 0, output
    line = next(row for row in output.splitlines() if row.startswith("  again"))
    words = shlex.split(line.split(None, 1)[1])
    assert words[:2] == ["dresslog", "train"] and "--no-keep-best" in words
    assert words[words.index("--recipe") + 1] == "bundled"
    again = tmp_path / "again"
    words[words.index("-o") + 1] = str(again)
    code, output = invoke(*words[1:], "--quiet")
    assert code == 0, output
    weights = "model.safetensors"
    assert (again / weights).read_bytes() == (first / weights).read_bytes()
    kept = read_card(again).hyperparameters
    assert (kept.epochs, kept.lr, kept.seed, kept.keep_best) == (2, 0.002, 3, False)
    assert kept.input_differences and kept.force_scale != 1.0  # the recipe's, not the paper's


def test_device_cpu_and_auto_train_the_same_weights_here(
    data: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    made = {}
    for device in ("cpu", "auto"):
        out = tmp_path / device
        code, output = invoke("train", data, "-o", out, "--device", device, *TINY)
        assert code == 0, output
        made[device] = (out / "model.safetensors").read_bytes()
    assert made["cpu"] == made["auto"]
    assert PAPER.device == "auto"


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has a CUDA device")
def test_device_cuda_without_a_gpu_is_one_line_before_any_work(
    data: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    code, output = invoke("train", data, "-o", tmp_path / "m", "--device", "cuda", *TINY)
    assert code == 1
    assert output.strip().splitlines() == [
        f"Error: --device cuda: torch {torch.__version__} sees no CUDA device "
        "(a CPU build, or no GPU here); use --device cpu or auto"
    ]
    assert not (tmp_path / "m").exists()
