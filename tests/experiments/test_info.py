"""`dresslog info` on a model folder and a dataset folder (trials: tests/test_cli.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.folders import CARD_FILE
from dresslog.model.files import EpochRecord, Hyperparameters, ModelCard, load_model, save_model
from tests.conftest import SAMPLES
from tests.experiments.conftest import fake_model, invoke


def test_info_counts_one_epoch_in_the_singular(tmp_path: Path) -> None:
    """A model trained for one epoch (a smoke test's) read `1 epochs` twice."""
    path = fake_model(tmp_path / "gown", "gown")
    card = load_model(path).card.model_copy(
        update={
            "hyperparameters": Hyperparameters(epochs=1),
            "history": [EpochRecord(epoch=1, train_loss=0.5, seconds=2.0)],
        }
    )
    weights = load_model(path).weights
    save_model(path, weights, card, overwrite=True)
    code, output = invoke("info", path)
    assert code == 0, output
    assert "training  1 epoch, batch 16" in output and "history   1 epoch in 2 s" in output


@pytest.mark.slow
def test_info_summarises_a_model_folder_and_a_dataset_folder(
    model: Path, data: Path, tmp_path: Path
) -> None:
    code, output = invoke("info", model)
    assert code == 0, output
    assert "gown, 300 limb points" in output and "1x4 LSTM" in output
    assert "2 epochs in" in output and "weights   sha256" in output
    assert "  trained   speeds 0.1-0.15 m/s, the limb never turned\n" in output  # as eval's
    older = tmp_path / "format3"
    bundled = load_model(SAMPLES / "models" / "gown")
    save_model(older, bundled.weights, bundled.card)
    card = json.loads((older / CARD_FILE).read_text())
    del card["data"]["folders"]  # as format 3 wrote it: the data named by path only
    (older / CARD_FILE).write_text(json.dumps({**card, "format_version": 3}))
    code, output = invoke("info", older)  # a card before format 4
    assert (
        code == 0
        and (
            "  trained   speeds 0.1-0.15 m/s, the limb never turned (generate's defaults taken "
            "where the card does not record them)\n"
        )
        in output
    ), output
    code, output = invoke("info", model, "--json")
    assert code == 0 and ModelCard.model_validate_json(output) == load_model(model).card
    code, output = invoke("info", data)
    assert code == 0 and output.startswith(f"{data}: gown trials 3/3 train, 1/1 test; outcomes")
    code, output = invoke("info", data, "--json")
    assert code == 0 and json.loads(output)["task"] == "gown"


def test_info_describes_a_tampered_model_and_fails_and_refuses_a_folder_that_is_neither(
    tmp_path: Path,
) -> None:
    path = fake_model(tmp_path / "gown", "gown")
    weights = path / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:-4] + b"\0\0\0\0")
    result = CliRunner().invoke(main, ["info", str(path)])
    assert result.exit_code == 1 and "gown, 300 limb points" in result.stdout
    assert "but the model does not load (the error says why)" in result.stdout
    assert result.stderr.count("\n") == 1 and "does not match the sha256" in result.stderr
    code, output = invoke("info", tmp_path)
    assert code == 1 and output.count("\n") == 1
    assert "neither a model folder (no card.json) nor a dataset folder" in output


@pytest.mark.parametrize("name", ["model.safetensors", "training.png"])
def test_info_on_a_model_folders_file_describes_the_model(tmp_path: Path, name: str) -> None:
    """As on its card.json; the weights were read as a trial, "not an MCAP file; for a ROS
    bag or a force/torque CSV, run `dresslog convert` first"."""
    path = fake_model(tmp_path / "gown", "gown")
    (path / "training.png").write_bytes(b"\x89PNG")
    code, output = invoke("info", path / name)
    assert code == 0 and "dresslog model" in output and "gown, 300 limb points" in output, output
