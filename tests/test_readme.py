"""The README's Python example runs as written (on the bundled sample and model)."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_readme_python_example_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert blocks, "the README lost its Python example"
    monkeypatch.chdir(ROOT)  # the example names samples/ relative to the repository
    scope: dict[str, object] = {}
    exec(compile(blocks[0], "README.md", "exec"), scope)
    forces, truth = scope["forces"], scope["truth"]
    assert isinstance(forces, np.ndarray) and forces.shape == truth.shape == (700, 300)
    np.testing.assert_allclose(scope["forces_t"], forces[-1], atol=1e-5)  # step == run


def _bash_commands(section: str) -> list[list[str]]:
    """The `dresslog` commands of the README's ```bash block in `section`, as argv lists."""
    text = (ROOT / "README.md").read_text().split(f"### {section}", 1)[1]
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert block, f"the README's {section!r} lost its example"
    joined = block.group(1).replace("\\\n", " ")
    lines = [line.split("#", 1)[0].strip() for line in joined.splitlines()]
    return [shlex.split(line) for line in lines if line]


def test_readme_robot_log_example_runs_on_the_bundled_log(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The "Your robot's data" commands, as written, on samples/robot/: the converted log
    is the sample gown trial again (the signal to the sensor's noise, the velocity to the
    difference between central and backward differences), silently, and the model's
    estimate on it scores as on the trial."""
    from click.testing import CliRunner

    from dresslog.cli.main import main
    from dresslog.io import TrialReader
    from dresslog.model import load_model, sequence_rmse

    (tmp_path / "samples").symlink_to(ROOT / "samples")
    monkeypatch.chdir(tmp_path)
    commands = _bash_commands("Your robot's data")
    assert [c[:2] for c in commands] == [["dresslog", "convert"], ["dresslog", "infer"]]
    for argv in commands:
        result = CliRunner().invoke(main, argv[1:])
        assert result.exit_code == 0 and not result.stderr, result.output
    assert (tmp_path / "runs/day1/trial.rrd").stat().st_size > 0
    with (
        TrialReader("runs/day1/trial.mcap") as log,
        TrialReader(ROOT / "samples/gown.mcap") as trial,
    ):
        logged, phi = log.measurements.phi, trial.measurements.phi
        hold = len(logged) - len(phi)  # the gown hanging still before the gripper moves
        converted = logged[hold:]
        truth = trial.force_map.forces
    assert hold == 100
    error = np.sqrt(np.mean((converted - phi) ** 2, axis=0))
    assert np.all(error[:3] < 0.015) and np.all(error[3:6] < 0.001), error  # noise: 0.009 N
    assert np.all(error[6:] < 0.004), error  # velocity, against up to 0.1 m/s
    model = load_model(ROOT / "samples/models/gown").estimator()
    on_trial, _ = model.run(phi)
    model.reset()
    on_log, _ = model.run(logged)  # what `infer` estimated
    assert sequence_rmse(truth, on_log[hold:]) < 1.1 * sequence_rmse(truth, on_trial)


def test_robot_sample_is_what_its_script_makes(tmp_path: Path) -> None:
    """samples/robot/ comes from samples/gown.mcap by scripts/robot_sample.py, byte for byte."""
    script = ROOT / "scripts/robot_sample.py"
    subprocess.run(
        [sys.executable, str(script), str(ROOT / "samples/gown.mcap"), "-o", str(tmp_path)],
        check=True, capture_output=True,
    )  # fmt: skip
    for name in ("ft.csv", "pose.csv"):
        assert (tmp_path / name).read_bytes() == (ROOT / "samples/robot" / name).read_bytes()
