"""The README's Python example runs as written (on the bundled sample and model)."""

from __future__ import annotations

import re
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
