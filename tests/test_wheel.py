"""An installed, non-editable wheel works outside the checkout: command and schemas."""

from __future__ import annotations

import shutil
import site as sitelib
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import write_synthetic_trial

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("wheel")
    source = root / "src"
    shutil.copytree(
        REPO, source, ignore=shutil.ignore_patterns(".git", "data", "runs", "*.egg-info", "build")
    )
    run = {"check": True, "capture_output": True, "text": True}
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "-w", str(root / "dist"), str(source)], **run,
    )  # fmt: skip
    wheel = next((root / "dist").glob("dresslog-*.whl"))
    subprocess.run([sys.executable, "-m", "venv", str(root / "venv")], **run)
    # The dependencies come from the running interpreter's site-packages, a venv's or the
    # base's: --system-site-packages would reach the base interpreter's even from a venv.
    # Listed in a .pth, they follow the venv's own site-packages, so the wheel's dresslog
    # wins, and their .pth files (our editable install's among them) are not run.
    site = next((root / "venv").glob("lib/python*/site-packages"))
    (site / "running-interpreter.pth").write_text("\n".join(sitelib.getsitepackages()) + "\n")
    pip = root / "venv" / "bin" / "pip"
    subprocess.run([pip, "install", "--no-deps", "--no-index", str(wheel)], **run)
    return root / "venv"


def test_wheel_holds_the_cli_and_schemas_inside_the_package(venv: Path) -> None:
    site = next(venv.glob("lib/python*/site-packages"))
    assert (site / "dresslog" / "cli" / "main.py").is_file()
    assert (site / "dresslog" / "schemas" / "dresslog_msgs" / "msg" / "ForceMap.msg").is_file()
    assert not (site / "cli").exists()
    in_repo = {p.relative_to(REPO).as_posix() for p in (REPO / "dresslog").rglob("*.py")}
    in_repo |= {f"dresslog/{p.relative_to(REPO).as_posix()}" for p in (REPO / "cli").glob("*.py")}
    installed = {p.relative_to(site).as_posix() for p in (site / "dresslog").rglob("*.py")}
    assert in_repo <= installed, f"missing from the wheel: {sorted(in_repo - installed)}"
    samples = {p.relative_to(REPO).as_posix() for p in (REPO / "samples").rglob("*") if p.is_file()}
    shipped = {p.relative_to(site / "dresslog").as_posix() for p in (site / "dresslog").rglob("*")}
    assert samples - {"samples/__init__.py"} <= shipped


def test_installed_command_reads_a_trial_outside_the_checkout(venv: Path, tmp_path: Path) -> None:
    path = tmp_path / "trial.mcap"
    write_synthetic_trial(path, steps=20)
    where = subprocess.run(
        [venv / "bin" / "python", "-c", "import dresslog; print(dresslog.__file__)"],
        cwd=tmp_path, capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert where.stdout.startswith(str(venv))
    result = subprocess.run(
        [venv / "bin" / "dresslog", "info", str(path)], cwd=tmp_path, capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    assert "steps     20" in result.stdout


def test_wheel_holds_every_schema_and_the_foxglove_layout(venv: Path, tmp_path: Path) -> None:
    """The standard messages a trial registers (sensor_msgs, visualization_msgs, tf2_msgs)
    ship as dresslog's own do, and the installed package writes its Foxglove layout."""
    site = next(venv.glob("lib/python*/site-packages"))
    msgs = {p.relative_to(REPO).as_posix() for p in (REPO / "schemas").rglob("*.msg")}
    shipped = {f"schemas/{p.relative_to(site / 'dresslog' / 'schemas').as_posix()}"
               for p in (site / "dresslog" / "schemas").rglob("*.msg")}  # fmt: skip
    assert msgs <= shipped, f"missing from the wheel: {sorted(msgs - shipped)}"
    out = tmp_path / "layout.json"
    subprocess.run(
        [venv / "bin" / "python", "-m", "dresslog.replay.foxglove", str(out)],
        cwd=tmp_path, check=True, capture_output=True,
    )  # fmt: skip
    assert out.read_bytes() == (REPO / "dresslog" / "replay" / "foxglove_layout.json").read_bytes()
