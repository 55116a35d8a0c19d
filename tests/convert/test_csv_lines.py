"""pyarrow's streaming read of a plain CSV gives what the `np.loadtxt` path gives, and every
file it cannot read as `np.loadtxt` would goes that path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dresslog.convert import csv_lines
from dresslog.convert.csv_lines import data_rows

HEADER = "time,fx,fy,fz\n"


def _rows(path: Path, exact: set[int]) -> list[csv_lines.Column]:
    read, warned = data_rows(path, 0, ",", [0, 1, 3], 4, exact)
    assert warned == []
    return read


def _numpy_path(path: Path, exact: set[int], monkeypatch: pytest.MonkeyPatch) -> list:
    with monkeypatch.context() as patch:
        patch.setattr(csv_lines, "_arrow_rows", lambda *args: None)
        return _rows(path, exact)


@pytest.mark.parametrize(
    "times",
    [
        [f"{0.001 * i:.6f}" for i in range(5000)],  # seconds
        [str(1_700_000_000_000_000_000 + 1_000_000 * i) for i in range(5000)],  # ns since 1970
        [str(10 * i) for i in range(5000)],  # whole ms, below 2**53: floats, as loadtxt reads
    ],
    ids=["seconds", "epoch-ns", "whole-ms"],
)
def test_a_plain_file_reads_the_same_by_both_paths(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, times: list[str]
) -> None:
    rng = np.random.default_rng(3)
    cells = rng.normal(size=(len(times), 3))
    lines = [f'{t},{a:.17g},{b:.9g},"{c}"' for t, (a, b, c) in zip(times, cells, strict=True)]
    (path := tmp_path / "ft.csv").write_text(HEADER + "\n".join(lines) + "\n")
    calls = []
    real = csv_lines._arrow_rows
    monkeypatch.setattr(csv_lines, "_arrow_rows", lambda *args: calls.append(1) or real(*args))
    fast = _rows(path, {0})
    assert calls == [1]
    slow = _numpy_path(path, {0}, monkeypatch)
    for a, b in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(a.values, b.values)
        # numpy's path gives whole numbers below 2**53 as int64 or float64 as the chunk's
        # other cells happen to parse (a quoted one: as text, then int64): both exact
        small = np.abs(b.values).max() < 2**53
        assert a.values.dtype == b.values.dtype or (small and a.values.dtype.kind == "f")
        assert (a.bad, a.not_finite) == (b.bad, b.not_finite) == (None, None)


@pytest.mark.parametrize(
    "body",
    [
        "0.0,1,2,3\n# a note\n0.1,1,2,3\n",  # a comment line
        "0.0,1,2,3\n0.1,1,2,3 # a note\n",  # a comment after the cells
        "0.0,1,2,3\n0.1,,2,3\n",  # an empty cell
        "0.0,1,2,3\nnan,1,2,3\n",  # a time that is no time
        "0.0,1,2,3\n0.1,x,2,3\n",  # a used cell that is no number
        "0.0,1,2,3\n0.1,1,2\n0.2,1,2,3\n",  # a short line in the middle
    ],
    ids=["comment-line", "comment-after", "empty-cell", "nan-time", "text", "short-line"],
)
def test_a_file_pyarrow_cannot_read_as_loadtxt_goes_the_loadtxt_way(
    tmp_path: Path, body: str
) -> None:
    (path := tmp_path / "ft.csv").write_text(HEADER + body)
    assert csv_lines._arrow_rows(path, 0, ",", [0, 1, 3], {0}) is None
