"""The codebase stays ruff-clean and type-checks: both are part of the test run.

mypy starts when the run's tests are collected and runs beside them (`tests/conftest.py`).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import mypy_run, start_mypy

REPO = Path(__file__).resolve().parents[1]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", *args], cwd=REPO, capture_output=True, text=True)


def test_ruff_check_is_clean() -> None:
    result = _run("ruff", "check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_is_clean(request: pytest.FixtureRequest) -> None:
    """The package ships py.typed: its hints are a promise to users' type checkers."""
    process = request.config.stash.get(mypy_run, None) or start_mypy()
    output, _ = process.communicate()
    assert process.returncode == 0, output
