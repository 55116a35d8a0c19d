"""The data lines of a CSV, parsed a chunk at a time; a last line cut off mid-write dropped.

A long log's text is never held whole. A plain file (one-character delimiter, every used
cell a bare number, no comment, no line cut off) is streamed by pyarrow's CSV reader,
3-6x faster than `np.loadtxt`; any other, or one pyarrow refuses, is read
`CHUNK_LINES` lines at a time by `np.loadtxt`, which knows comments and runs of spaces
and names the line of a bad cell. Only the used columns' numbers are kept. A logger killed mid-write
leaves a last line with fewer fields than the one above, or a last number cut short
(`1.2e`, `-`). That line alone is dropped, with a warning naming it; a short line
anywhere else is refused by its line number, counted from 1 as an editor counts
(numpy's own `row N` counts data rows).
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from dresslog.errors import ConversionError

#: Lines parsed at a time: all of a long log's text that is held at once.
CHUNK_LINES = 100_000


@dataclass
class Column:
    """One used column's numbers, and its first cell that is not a number (`bad`), or, in
    a time column, not finite (`not_finite`): (its line, from 1, the cell), the first as
    read without its spaces and quotes, the second as written. Float64, but int64 for a
    time column of integers that float64 would round (nanoseconds since 1970)."""

    values: np.ndarray
    bad: tuple[int, str] | None = None
    not_finite: tuple[int, str] | None = None


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


def _chunks(
    stream: TextIO, header_line: int, delimiter: str | None
) -> Iterator[tuple[int, list[str], int | None]]:
    """The lines below the header, `CHUNK_LINES` at a time, each list with the number of
    its first line and, in the last that holds data, the index of the file's last data
    line (None in the others); lists of only blank or comment lines are passed over."""
    lines = itertools.islice(stream, header_line + 1, None)
    first, held = header_line + 2, None
    while chunk := list(itertools.islice(lines, CHUNK_LINES)):
        if any(_fields(text, delimiter) for text in reversed(chunk)):
            if held is not None:
                yield *held, None
            held = first, chunk
        first += len(chunk)
    if held is not None:
        number, chunk = held
        last = next(i for i in reversed(range(len(chunk))) if _fields(chunk[i], delimiter))
        yield number, chunk, last


def _parsed(
    lines: list[str],
    number: int,
    options: dict[str, Any],
    exact: Collection[int],
    width: int,
    path: Path,
) -> list[np.ndarray]:
    """The used columns of `lines` (the first is line `number`): floats where every cell
    reads as one, else the cells' text; text too in a time column (at `exact`) whose
    floats do not give what its text does. Lines of only spaces or tabs are blank (numpy
    reads one as a row of one empty cell)."""
    rows = lines
    with warnings.catch_warnings():  # "no data" (comments alone): the caller counts rows
        warnings.simplefilter("ignore", UserWarning)
        block = _floats(rows, options)
        if block is None and len(rows := [text for text in lines if text.strip()]) < len(lines):
            block = _floats(rows, options)
        if block is not None:
            columns = [np.ascontiguousarray(column) for column in block.T]
            if redo := [i for i in exact if not _as_written(columns[i])]:
                usecols = [options["usecols"][i] for i in redo]
                text = np.loadtxt(rows, dtype=str, ndmin=2, **(options | {"usecols": usecols}))
                for i, cells in zip(redo, text.T, strict=True):
                    columns[i] = cells
            return columns
        try:
            text = np.loadtxt(rows, dtype=str, ndmin=2, **options)
        except (ValueError, IndexError) as err:
            need = max(options["usecols"]) + 1
            for index, line in enumerate(lines):
                if 0 < len(cells := _fields(line, options["delimiter"])) < need:
                    raise _incomplete(number + index, len(cells), width, path) from None
            raise ConversionError(f"cannot parse CSV: {err}", path=path) from None
    return list(text.T)


def _floats(rows: list[str], options: dict[str, Any]) -> np.ndarray | None:
    """The used columns of `rows` as floats in one pass, or None if a cell is no bare number."""
    try:
        return np.loadtxt(rows, dtype=np.float64, ndmin=2, **options)
    except (ValueError, IndexError):
        return None


def _as_written(values: np.ndarray) -> bool:
    """Whether a time column's floats give what its text does: all finite (else the first
    is named as written), and below 2**53, where whole numbers read as integers are the
    same numbers (nanoseconds since 1970 are not: read as text, they are kept as int64)."""
    return bool(np.isfinite(values).all()) and float(np.abs(values).max(initial=0)) < 2**53


def _incomplete(number: int, cells: int, width: int, path: Path) -> ConversionError:
    return ConversionError(
        f"line {number} is incomplete ({cells} of {width} fields); only a last line cut off "
        "mid-write is dropped, so mend or remove this one",
        path=path,
    )


def _as_floats(cells: np.ndarray) -> tuple[np.ndarray, tuple[int, str] | None]:
    """Cells as floats, spaces and quotes around a number dropped (a logger that quotes
    every cell); or NaN, with the first cell that is not a number and its index."""
    if cells.dtype.kind == "f":
        return cells, None
    try:
        return cells.astype(np.float64), None  # bare numbers: nothing to drop
    except ValueError:
        cells = np.char.strip(np.char.strip(cells), '"')
    try:
        return cells.astype(np.float64), None
    except ValueError:
        row = next(i for i, cell in enumerate(cells) if not is_number(cell))
        return np.full(len(cells), np.nan), (row, str(cells[row]))


class _Gathered:
    """One column's numbers, chunk by chunk, and its first cells that are not numbers or,
    if `exact` (a time column), not finite."""

    def __init__(self, exact: bool) -> None:
        self.exact = exact
        self.parts: list[np.ndarray] = []
        self.bad: tuple[int, str] | None = None
        self.not_finite: tuple[int, str] | None = None

    def add(self, cells: np.ndarray, row: int) -> None:
        """The column's cells of one chunk, whose first is data row `row`."""
        if self.exact and cells.dtype.kind == "U":  # whole numbers as text: integers, exact
            try:
                self.parts.append(cells.astype(np.int64))
                return
            except ValueError:
                pass
        values, bad = _as_floats(cells)
        self.parts.append(values)
        if bad is not None:
            self.bad = self.bad or (row + bad[0], bad[1])
        elif self.exact and self.not_finite is None and not np.isfinite(values).all():
            index = int(np.argmin(np.isfinite(values)))
            self.not_finite = row + index, str(cells[index])

    def column(self) -> Column:
        """The chunks as one column: int64 if each one was, else float64."""
        kinds = {part.dtype for part in self.parts}
        dtype = np.int64 if kinds == {np.dtype(np.int64)} else np.float64
        values = np.concatenate(self.parts, dtype=dtype) if self.parts else np.empty(0)
        self.parts.clear()
        return Column(values, self.bad, self.not_finite)


#: Bytes of a file searched at a time for a comment's `#` (pyarrow knows no comments).
_SCAN = 1 << 22


def _has_comment(path: Path) -> bool:
    with path.open("rb") as stream:
        while block := stream.read(_SCAN):
            if b"#" in block:
                return True
    return False


def _arrow_rows(
    path: Path, header_line: int, delimiter: str | None, usecols: list[int], exact: Collection[int]
) -> list[Column] | None:
    """The used columns as `np.loadtxt` gives them, streamed by pyarrow, for a plain file;
    None for any other (a comment, runs of spaces, a cell that is no bare number, a line
    of another length): the `np.loadtxt` path reads it and words what is wrong."""
    if delimiter is None or len(delimiter) != 1 or _has_comment(path):
        return None
    import pyarrow as pa
    from pyarrow import csv as pa_csv

    names = [f"f{i}" for i in usecols]
    floats = {name: pa.float64() for i, name in enumerate(names) if i not in exact}
    try:
        batches = pa_csv.open_csv(
            path,
            read_options=pa_csv.ReadOptions(
                skip_rows=header_line + 1, autogenerate_column_names=True, block_size=1 << 22
            ),
            parse_options=pa_csv.ParseOptions(delimiter=delimiter),
            convert_options=pa_csv.ConvertOptions(
                include_columns=names, column_types=floats, null_values=[],
                strings_can_be_null=False, quoted_strings_can_be_null=False,
            ),
        )  # fmt: skip
        table = pa.Table.from_batches(list(batches))
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError, UnicodeDecodeError):
        return None
    columns = []
    for i, name in enumerate(names):
        column = table.column(name)
        whole = i in exact and pa.types.is_integer(column.type)  # a time column of integers
        if column.null_count or not (pa.types.is_floating(column.type) or whole):
            return None
        values = column.to_numpy()
        if i in exact and values.dtype.kind == "f" and not _as_written(values):
            return None  # not finite, or past what float64 holds exactly: read as text
        if i in exact and values.dtype.kind in "iu":  # what loadtxt's floats give below 2**53
            values = values.astype(np.int64)
            if np.abs(values).max(initial=0) < 2**53:
                values = values.astype(np.float64)
        columns.append(Column(np.ascontiguousarray(values)))
    return columns


def data_rows(
    path: str | Path,
    header_line: int,
    delimiter: str | None,
    usecols: list[int],
    width: int,
    exact: Collection[int] = (),
) -> tuple[list[Column], list[str]]:
    """The used columns' numbers (those at `exact`, indices into `usecols`, kept exact as
    int64 where whole), and a warning when a last line cut off is dropped.

    `CHUNK_LINES` lines at a time are parsed, so a long log's text is never held whole;
    a cell that is not a number is kept to be named, not refused at once, so that a
    short line further down is named first, as it is in a file read whole.
    """
    path = Path(path)
    options: dict[str, Any] = {"delimiter": delimiter, "usecols": usecols, "comments": "#"}
    cut = _cut_off(_last_rows(path, delimiter))
    if cut is None and (fast := _arrow_rows(path, header_line, delimiter, usecols, exact)):
        return fast, []
    gathered = [_Gathered(i in exact) for i in range(len(usecols))]
    rows, dropped = 0, None
    with path.open(encoding="utf-8-sig", errors="replace") as stream:
        for number, lines, last in _chunks(stream, header_line, delimiter):
            if cut is not None and last is not None:
                dropped = number + last, lines[last]
                lines = lines[:last]  # what follows it is blank or comments
            columns = _parsed(lines, number, options, exact, width, path)
            for column, cells in zip(gathered, columns, strict=True):
                column.add(cells, rows)
            rows += len(columns[0])
    read = _numbered([column.column() for column in gathered], path, header_line, delimiter)
    if dropped is None:
        return read, []
    last, line = dropped
    if rows == 0:  # a lone line cut short leaves no log to keep
        if (count := len(_fields(line, delimiter))) < max(usecols) + 1:
            raise _incomplete(last, count, width, path)
        raise ConversionError(f"line {last}, the only row, is incomplete ({cut})", path=path)
    return read, [
        f"{path.name}: line {last} is incomplete ({cut}), as a log cut off mid-write; dropped"
    ]


def _numbered(
    columns: list[Column], path: Path, header_line: int, delimiter: str | None
) -> list[Column]:
    """`columns` with the data rows of their bad cells turned into line numbers, from 1
    as an editor counts: blank and comment lines above a bad cell count too. The file
    is read again only when a column has one."""
    rows = {cell[0] for c in columns for cell in (c.bad, c.not_finite) if cell is not None}
    if not rows:
        return columns
    lines: dict[int, int] = {}
    with path.open(encoding="utf-8-sig", errors="replace") as stream:
        data = (n for n, t in enumerate(stream, 1) if n > header_line + 1 and _fields(t, delimiter))
        for row, number in enumerate(data):
            if row in rows:
                lines[row] = number
            if len(lines) == len(rows):
                break

    def at_line(cell: tuple[int, str] | None) -> tuple[int, str] | None:
        return None if cell is None else (lines[cell[0]], cell[1])

    return [Column(c.values, at_line(c.bad), at_line(c.not_finite)) for c in columns]
