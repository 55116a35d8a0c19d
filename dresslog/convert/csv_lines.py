"""The data lines of a CSV: parsed fast when whole, a last line cut off mid-write dropped.

A logger killed mid-write leaves a last line with fewer fields than the one above,
or a last number cut short (`1.2e`, `-`). That line alone is dropped, with a
warning naming it; a short line anywhere else is refused by its line number,
counted from 1 as an editor counts (numpy's own `row N` counts data rows).
"""

from __future__ import annotations

import itertools
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.errors import ConversionError


def is_number(text: str) -> bool:
    """Whether `float` reads `text`."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _fields(line: str, delimiter: str | None) -> list[str]:
    """A data line's cells as `np.loadtxt` splits them (a `#` comment cut off); [] for none."""
    line = line.split("#", 1)[0].rstrip("\r\n")
    if not line.strip():
        return []
    return line.split(delimiter) if delimiter else line.split()


def _last_rows(path: Path, delimiter: str | None) -> list[list[str]]:
    """The cells of the file's last two data lines (fewer in a shorter file), read from its end."""
    with path.open("rb") as stream:
        size = stream.seek(0, 2)
        block = 1 << 14
        while True:
            start = max(0, size - block)
            stream.seek(start)
            text = stream.read().decode("utf-8", "replace")
            lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
            rows = [cells for t in lines[1 if start else 0 :] if (cells := _fields(t, delimiter))]
            if len(rows) >= 2 or start == 0:  # a block's first line may be part of one
                return rows[-2:]
            block *= 8


def _cut_off(rows: list[list[str]]) -> str | None:
    """How the last of `rows` (the file's last two data lines) shows it was cut off
    mid-write, if it does: fewer cells than the line above, or a last cell that is no
    number where the line above has one (`1.2e`, `-`, nothing)."""
    if len(rows) < 2:
        return None
    above, last = rows
    if not any(is_number(c.strip().strip('"')) for c in above):  # the header: nothing to go by
        return None
    if len(last) < len(above):
        return f"{len(last)} of {len(above)} fields"
    cell, over = (row[-1].strip().strip('"') for row in (last, above))
    if len(last) == len(above) and is_number(over) and not is_number(cell):
        return f"its last field {cell!r} is not a number"
    return None


def _scan(
    path: Path, header_line: int, delimiter: str | None, need: int
) -> tuple[int, int, tuple[int, int] | None]:
    """The number of the last data line, how many there are, and the first with fewer than
    `need` cells (its number and cell count), if any; lines counted from 1, as editors do."""
    last, count, short = header_line + 1, 0, None
    with path.open(encoding="utf-8-sig", errors="replace") as stream:
        for number, text in enumerate(stream, 1):
            if number <= header_line + 1 or not (cells := _fields(text, delimiter)):
                continue
            last, count = number, count + 1
            if short is None and len(cells) < need:
                short = number, len(cells)
    return last, count, short


def data_rows(
    path: str | Path, header_line: int, delimiter: str | None, usecols: list[int], width: int
) -> tuple[np.ndarray, list[str]]:
    """The used columns' cells as text, and a warning when a last line cut off is dropped.

    A whole file is parsed by `np.loadtxt` from its path, the fast way; only one that
    fails it, or whose last line is cut, is read again to find and name the line.
    """
    path = Path(path)
    options: dict[str, Any] = {
        "delimiter": delimiter, "usecols": usecols, "dtype": str, "ndmin": 2, "comments": "#",
    }  # fmt: skip
    cut = _cut_off(_last_rows(path, delimiter))
    problem = ""
    if cut is None:
        try:
            with warnings.catch_warnings():  # "no data": the caller says so in its own words
                warnings.simplefilter("ignore", UserWarning)
                rows = np.loadtxt(path, skiprows=header_line + 1, encoding="utf-8-sig", **options)
        except (ValueError, IndexError) as err:
            problem = f"cannot parse CSV: {err}"  # numpy's words, when no short line explains it
        else:
            return rows, []
    last, count, short = _scan(path, header_line, delimiter, max(usecols) + 1)
    if count == 0:  # the "last line" was the header: no rows, as the caller says
        return np.empty((0, len(usecols)), dtype=str), []
    if short is not None and (cut is None or short[0] != last or count == 1):
        raise ConversionError(
            f"line {short[0]} is incomplete ({short[1]} of {width} fields); only a last line "
            "cut off mid-write is dropped, so mend or remove this one",
            path=path,
        )
    if cut is None:
        return _reparsed(path, header_line, None, options, problem), []
    if count == 1:  # a lone line cut short leaves no log to keep
        raise ConversionError(f"line {last}, the only row, is incomplete ({cut})", path=path)
    rows = _reparsed(path, header_line, last - 1, options)  # all but the last line
    return rows, [
        f"{path.name}: line {last} is incomplete ({cut}), as a log cut off mid-write; dropped"
    ]


def _reparsed(
    path: Path, header_line: int, stop: int | None, options: dict[str, Any], problem: str = ""
) -> np.ndarray:
    """The data lines up to line `stop` (all: None) parsed again, lines of only spaces or
    tabs skipped as blank (numpy reads one as a row of one empty cell); `problem` is the
    error to give if they still fail, else numpy's own words."""
    with path.open(encoding="utf-8-sig", errors="replace") as stream:
        lines = (t for t in itertools.islice(stream, header_line + 1, stop) if t.strip())
        try:
            return np.loadtxt(lines, **options)
        except (ValueError, IndexError) as err:
            raise ConversionError(problem or f"cannot parse CSV: {err}", path=path) from None
