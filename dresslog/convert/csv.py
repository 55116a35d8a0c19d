"""Read force/torque sensor CSV exports (and an optional motion CSV) into a `Source`.

Exports name their columns every way imaginable (`Fx`, `Force X (N)`,
`field.wrench.force.x`, `Mx`, `torque_x`); a header is reduced to a key
(lower case, units in brackets dropped, ROS prefixes dropped, letters and
digits only) and the key matched against a few patterns. A unit in brackets is
read: values are scaled to SI (`Fx (kN)`, `Tz [N-mm]`, `vx (mm/s)`), and a unit
not known is refused rather than taken for SI. Anything else is
mapped by the caller (`columns={"fx": "Kraft X"}`, `--column fx="Kraft X"`).

Time: seconds or nanoseconds, absolute or relative. A unit in the header
(`time_ns`, `Time (s)`, rostopic's `%time`) wins; otherwise nanoseconds are
recognised by size (epoch times above 1e12, or steps of 1000 or more, which
no seconds column at a sensor rate has). Milliseconds and microseconds need
the header to say so, or `time_unit`. A unit guessed or written in a header
must give a sensor's rate, since a label can be wrong (`Time (s)` over
milliseconds); `time_unit` is the user's override and is taken as given.
"""

from __future__ import annotations

import csv
import math
import re
from collections import Counter
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from dresslog.convert.csv_lines import Column, data_rows, is_number
from dresslog.convert.source import Source, SourceStream
from dresslog.convert.units import (
    NO_UNIT,
    RAW,
    VALUE_UNITS,
    bracketed,
    is_unit,
    si_factor,
    value_scale,
)
from dresslog.errors import ConversionError

#: Roles a column can play; each group is all-or-nothing except where noted.
FORCE, TORQUE = ("fx", "fy", "fz"), ("tx", "ty", "tz")
LINEAR, ANGULAR = ("vx", "vy", "vz"), ("wx", "wy", "wz")
POSITION, ORIENTATION = ("x", "y", "z"), ("qx", "qy", "qz", "qw")
ROLES = ("time", *FORCE, *TORQUE, *LINEAR, *ANGULAR, *POSITION, *ORIENTATION)
UNITS = {"s": 1e9, "ms": 1e6, "us": 1e3, "ns": 1.0}
#: A CSV stream's clock, as `info` names it: whatever its time column counts.
CSV_CLOCK = "time column"

_PREFIX = re.compile(r"^(field|header|wrench|twist|pose|ee|ft|sensor|robot)+")
_PATTERNS = [
    (re.compile(r"^(f|force)([xyz])$"), "f"),
    (re.compile(r"^(t|m|tau|torque|moment)([xyz])$"), "t"),
    (re.compile(r"^(v|vel|velocity|linear|linearvelocity|linvel)([xyz])$"), "v"),
    (re.compile(r"^(w|omega|angular|angularvelocity|angvel)([xyz])$"), "w"),
    (re.compile(r"^(p|pos|position)?([xyz])$"), ""),
    (re.compile(r"^(q|quat|quaternion|orientation|rot)([xyzw])$"), "q"),
]
_TIME = re.compile(
    r"^(time|t|timestamp|stamp|rostime|elapsed|elapsedtime|sec|secs|seconds|ns|nsec)"
    r"(s|sec|secs|seconds|ms|msec|us|usec|ns|nsec|nanoseconds)?$"
)
_UNIT_NAMES = {
    "s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s",
    "ms": "ms", "msec": "ms", "millisec": "ms", "millisecond": "ms", "milliseconds": "ms",
    "us": "us", "usec": "us", "\u00b5s": "us", "\u03bcs": "us", "\u00b5sec": "us",
    "microsec": "us", "microsecond": "us", "microseconds": "us",
    "ns": "ns", "nsec": "ns", "nanosec": "ns", "nanosecond": "ns", "nanoseconds": "ns",
}  # fmt: skip
#: Time units a header may name that dresslog does not read: refused, never guessed past.
_OTHER_TIME_UNITS = {"min", "mins", "minute", "minutes", "h", "hr", "hrs", "hour", "hours"}
#: A number written with a decimal comma, as spreadsheets in many locales export them.
_DECIMAL_COMMA = re.compile(r"^[-+]?\d*,\d+([eE][-+]?\d+)?$")


def _preamble(path: Path, header_line: int) -> tuple[dict[str, str], str]:
    """`key: value` pairs of the lines above the header, each split by its own separator
    (`Key,value`, `Key;value`, `Key: value`, `Key=value`; keys lower-cased), and their text."""
    pairs: dict[str, str] = {}
    with path.open(newline="", encoding="utf-8-sig", errors="replace") as stream:
        lines = [line for _, line in zip(range(header_line), stream, strict=False)]
    for line in lines:
        text = line.strip()
        delimiter = next((d for d in "\t;," if d in text), None)
        cells = next(csv.reader([text], delimiter=delimiter), []) if delimiter else [text]
        if len(cells) < 2 or not cells[1].strip():
            cells = re.split(r"\s*[:=]\s*", cells[0] if cells else "", maxsplit=1)
        if len(cells) >= 2:
            pairs[" ".join(cells[0].lower().rstrip(":= ").split())] = cells[1].strip()
    return pairs, "".join(lines)


def _counts_scales(path: Path, header_line: int) -> dict[str, float]:
    """SI factor per count of the force and torque columns, from an ATI logger's preamble.

    ATI's Net F/T demo writes raw counts, with `Counts per Unit Force` and `Force Units`
    (likewise torque) above the header: read as newtons they are 10^6 times too large.
    It always gives both; a preamble that gives one, or that cannot be read, is refused.
    """
    preamble, above = _preamble(path, header_line)
    # `Counts per Unit Force`, `Counts per Force`, a .cal file's `CountsPerForce`; `Force
    # Units`, `ForceUnits`: the keys' letters alone
    keyed = {re.sub(r"[^a-z]", "", key): value for key, value in preamble.items()}
    counts_per = {
        q: keyed.get(f"countsperunit{q}", keyed.get(f"countsper{q}")) for q in ("force", "torque")
    }
    given = [q for q in ("force", "torque") if counts_per[q] is not None]
    if not given:
        if re.search(r"counts\s*per", above, re.IGNORECASE):
            raise ConversionError(
                "the preamble mentions counts per unit, but not as `Counts per Unit Force,N` "
                "lines dresslog reads; give the values in N and N m",
                path=path,
            )
        return {}
    if len(given) == 1:
        other = "torque" if given == ["force"] else "force"
        raise ConversionError(
            f"the preamble gives counts per unit {given[0]} but not {other}, so the "
            f"{other} columns' unit is unknown; add `Counts per Unit {other.title()}`, or "
            "remove the line if the columns are already in N and N m",
            path=path,
        )
    scales = {}
    for group, quantity in (("f", "force"), ("t", "torque")):
        counts = counts_per[quantity] or ""
        unit = keyed.get(f"{quantity}units", "")
        per = float(counts) if is_number(counts) else math.nan
        factor = si_factor(unit, group)
        if factor is None or not (math.isfinite(per) and per > 0):
            raise ConversionError(
                f"the {quantity} columns are in counts ({counts!r} per {unit or 'unit'!r}), "
                f"which dresslog cannot scale; give the {quantity} units as one of "
                f"{', '.join(VALUE_UNITS[group])} and a positive count",
                path=path,
            )
        scales[group] = factor / per
    return scales


def _unit_in(name: str, path: Path) -> str | None:
    """A time unit written in a header: `Time (s)`, `stamp[ns]`, `time_ns`, `%time`.

    Any bracket may hold it (`Time (UTC) [ms]`); one that names another unit (`min`)
    is refused, since reading its values as seconds would be silently wrong.
    """
    if _ros_stamp(name):
        return "ns"
    brackets = [b.rstrip(".").lower() for b in bracketed(name)]
    if known := [b for b in brackets if b in _UNIT_NAMES]:
        return _UNIT_NAMES[known[0]]
    if other := [
        b for b in brackets if b in _OTHER_TIME_UNITS or (b not in NO_UNIT and is_unit(b))
    ]:
        raise ConversionError(
            f"time column {name!r} is in {other[0]!r}, a unit dresslog does not read; give "
            "its values in s, ms, us or ns, or say which with --time-unit",
            path=path,
        )
    match = _TIME.match(_key(name))
    if match and match.group(2):
        return _UNIT_NAMES[match.group(2)]
    if match and match.group(1) in ("sec", "secs", "seconds", "ns", "nsec"):
        return _UNIT_NAMES[match.group(1)]
    return None


def _ros_stamp(name: str) -> bool:
    """A time column written by ROS tools (rostopic echo -p, rosbag-to-CSV): always in ns."""
    return name.strip() == "%time" or name.strip().endswith("header.stamp")


def _key(name: str) -> str:
    """`Force X (N)` -> `forcex`; `field.wrench.force.x` -> `forcex`."""
    name = re.sub(r"[\(\[].*?[\)\]]", "", name.lower())
    return _PREFIX.sub("", re.sub(r"[^a-z0-9]", "", name))


def role_of(name: str) -> str | None:
    """The role a header plays, or None when it is not recognised."""
    key = _key(name)
    if _TIME.match(key):  # `%time` and `header.stamp` too: their keys are `time`, `stamp`
        return "time"
    for pattern, prefix in _PATTERNS:
        if match := pattern.match(key):
            return prefix + match.group(2)
    return None


def _header(path: Path) -> tuple[int, list[str], str | None]:
    """Line number, column names and delimiter of the header (comment lines skipped).

    The header is the last line of text before the first row of mostly numbers, so
    a preamble some loggers write above it (an ATI sensor's serial number and
    calibration) is passed over.
    """
    header: tuple[int, list[str], str | None] | None = None
    try:
        with path.open(newline="", encoding="utf-8-sig") as stream:
            for number, line in enumerate(stream):
                if not line.strip() or line.lstrip().startswith("#"):
                    continue
                # a `;` or tab separates where commas may be decimal commas
                delimiter = next((d for d in "\t;," if d in line), None)
                cells = (
                    next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))
                    if delimiter
                    else line.split()
                )
                cells = [c.strip() for c in cells]
                filled = [c for c in cells if c]
                numbers = sum(is_number(c) for c in filled)
                commas = [c for c in filled if _DECIMAL_COMMA.match(c)]
                if header is not None and 2 * len(commas) > len(filled):
                    raise ConversionError(
                        f"numbers are written with decimal commas (line {number + 1}: "
                        f"{commas[0]!r}); export the CSV with decimal points",
                        path=path,
                    )
                if header is not None and 2 * numbers > len(filled):  # mostly numbers: data
                    text_above = not all(is_number(c) for c in header[1] if c)
                    if text_above and abs(len(cells) - len(header[1])) > 1:
                        continue  # numbers in the preamble (`Tool Transform,0,0,0,0,0,0`)
                    if not text_above:  # numbers above numbers
                        raise ConversionError(
                            f"has no header row (line {header[0] + 1} is numbers); add a line "
                            "naming the columns, such as time,fx,fy,fz,tx,ty,tz,vx,vy,vz",
                            path=path,
                        )
                    return header
                header = number, cells, delimiter
    except (OSError, UnicodeDecodeError) as err:
        raise ConversionError(f"cannot read CSV: {err}", path=path) from None
    if header is None:
        raise ConversionError("CSV file is empty", path=path)
    return header


def assign_columns(
    names: list[str], columns: Mapping[str, str], path: Path
) -> tuple[dict[str, int], list[str]]:
    """Column index per role (explicit mapping first), and the names left unrecognised.

    A name the header holds twice is refused where it would be used: the second `Fx (N)`
    was ignored unsaid (then `fy` reported missing), and a mapping cannot tell them apart.
    """
    for name, count in Counter(names).items():
        role = role_of(name)
        if count > 1 and (name in columns.values() or (role is not None and role not in columns)):
            first, second = [i + 1 for i, n in enumerate(names) if n == name][:2]
            raise ConversionError(
                f"column {name!r} appears twice in the header (columns {first} and {second}); "
                "rename one, as --column cannot tell them apart",
                path=path,
            )
    found: dict[str, int] = {}
    for role, name in columns.items():
        if role not in ROLES:
            raise ConversionError(
                f"unknown column role {role!r}; roles: {', '.join(ROLES)}", path=path
            )
        if name in names:  # a mapping may name a column of the other file
            found[role] = names.index(name)
    shared = [i for i, n in Counter(found.values()).items() if n > 1]
    if shared:  # a typo in an axis swap would lose an axis unseen
        index = shared[0]
        twice = [r for r, i in found.items() if i == index]
        raise ConversionError(
            f"column {names[index]!r} is given as both {twice[0]} and {twice[1]}; "
            "map each role to a column of its own",
            path=path,
        )
    taken = set(found.values())
    ignored = []
    # a sensor's header stamp beats a receive time (rostopic's `%time`) when both are there
    order = sorted(range(len(names)), key=lambda i: "stamp" not in _key(names[i]))
    for index in order:
        guess = role_of(names[index])
        if index in taken:
            continue
        if guess is not None and guess in found and guess != "time" and guess not in columns:
            raise ConversionError(  # which of the two is the sensor's is the user's to say
                f"columns {names[found[guess]]!r} and {names[index]!r} both read as {guess}; "
                f"name the one to use with --column {guess}=HEADER",
                path=path,
            )
        if guess is None or guess in found:
            ignored.append(names[index])
        else:
            found[guess] = index
    return found, ignored


#: A stamp split in two, as bagpy (`header.stamp.secs`, `.nsecs`) and ROS 2 exports
#: (`header.stamp.sec`, `.nanosec`) write it: the whole seconds alone would repeat.
_WHOLE_SECONDS = ("stampsecs", "stampsec")
_NANOSECONDS = ("stampnsecs", "stampnsec", "stampnanosec", "stampnanosecs")


def _nanoseconds_of(names: list[str], time_index: int) -> int | None:
    """The column holding the nanoseconds of a split stamp whose seconds are `time_index`."""
    if _key(names[time_index]) not in _WHOLE_SECONDS:
        return None
    prefix = names[time_index].lower().rsplit("sec", 1)[0]
    return next(
        (
            i
            for i, name in enumerate(names)
            if _key(name) in _NANOSECONDS and name.lower().startswith(prefix)
        ),
        None,
    )


def _missing_hint(missing: list[str], names: list[str]) -> str:
    example = f"--column {missing[0]}=HEADER"
    return (
        f"no column recognised as {', '.join(missing)} (columns: {', '.join(names)}); "
        f"name them with {example}"
    )


def _time_ns(column: Column, unit: str | None, name: str, path: Path) -> tuple[np.ndarray, str]:
    """Integer nanoseconds from a time column, and the unit used."""
    values = _numbers(column, name, path)
    if column.not_finite is not None:
        line, cell = column.not_finite
        raise ConversionError(
            f"column {name!r}, line {line}: time {cell!r} is not a finite number; drop that row",
            path=path,
        )
    if unit is None:
        steps = np.diff(values)
        big = np.abs(values).max(initial=0) > 1e12
        unit = "ns" if big or (len(steps) and np.median(steps) >= 1000) else "s"
    if unit == "ns" and values.dtype == np.int64:
        return values, unit
    return np.round(values.astype(np.float64) * UNITS[unit]).astype(np.int64), unit


def _numbers(column: Column, name: str, path: Path) -> np.ndarray:
    """A column's numbers, or an error naming the first cell that is not a number."""
    if column.bad is not None:
        line, cell = column.bad
        raise ConversionError(
            f"column {name!r}, line {line}: {cell!r} is not a "
            "number (empty cells and decimal commas are not read)",
            path=path,
        )
    return column.values


def _check_rate(t_ns: np.ndarray, unit: str, name: str, path: Path, *, header: bool) -> None:
    """The unit read (guessed from the numbers, or written in the `header`) must give a
    sensor's rate (10 Hz-20 kHz), or say so.

    Milliseconds read as seconds would make a 1 kHz log 1,000 times too long (and a
    file of mostly gap); microseconds read as nanoseconds, 1,000 times too short (a
    100 Hz log in microseconds would read as 100 kHz: above any F/T sensor's rate).
    A header's unit is checked too: a logger's `Time (s)` over milliseconds is as wrong.
    """
    if len(t_ns) < 2:
        return
    step = float(np.median(np.diff(t_ns)))
    if step <= 0 or 5e4 <= step <= 1e8:  # 20 kHz ... 10 Hz
        return
    read = f"read as {unit}, as its header says," if header else f"read as {unit}"
    fix = "if the header is wrong, give the unit" if header else "give its unit"
    raise ConversionError(
        f"time column {name!r} {read} gives samples {step / 1e9:.3g} s apart "
        f"({1e9 / step:.3g} Hz), no sensor's rate; {fix} with --time-unit ms|us|s|ns",
        path=path,
    )


def read_table(
    path: str | Path, columns: Mapping[str, str] | None = None, time_unit: str | None = None
) -> tuple[np.ndarray, dict[str, np.ndarray], list[str], list[str]]:
    """Time (int64 ns) and one float column per recognised role, in SI; notes on what was assumed,
    and warnings (a last line cut off, dropped)."""
    path = Path(path)  # read_csv has read its header: it is a file
    if time_unit is not None and time_unit not in UNITS:
        raise ConversionError(f"time unit {time_unit!r} is not one of {', '.join(UNITS)}")
    line, names, delimiter = _header(path)
    found, ignored = assign_columns(names, columns or {}, path)
    if "time" not in found:
        raise ConversionError(_missing_hint(["time"], names), path=path)
    nanos = None if "time" in (columns or {}) else _nanoseconds_of(names, found["time"])
    if nanos is not None:
        found["nanoseconds"] = nanos
        ignored = [n for n in ignored if n != names[nanos]]
    roles = sorted(found, key=found.__getitem__)
    usecols, exact = [found[r] for r in roles], {roles.index("time")}
    if nanos is not None:
        exact.add(roles.index("nanoseconds"))
    read, cut = data_rows(path, line, delimiter, usecols, len(names), exact)
    if len(read[0].values) == 0:
        raise ConversionError("CSV has a header but no rows", path=path)
    data = dict(zip(roles, read, strict=True))
    given = time_unit or _unit_in(names[found["time"]], path)
    time_name = names[found["time"]]
    t_ns, unit = _time_ns(data.pop("time"), "s" if nanos is not None else given, time_name, path)
    if nanos is not None:
        t_ns = t_ns + _time_ns(data.pop("nanoseconds"), "ns", names[nanos], path)[0]
        unit = f"s + {names[nanos]!r} in ns"
    elif time_unit is None and not _ros_stamp(time_name):  # ROS tools write ns, always
        _check_rate(t_ns, unit, time_name, path, header=given is not None)
    values = {role: _numbers(col, names[found[role]], path) for role, col in data.items()}
    notes = [f"{path.name}: time column {time_name!r} read as {unit}"]
    notes += _scale_to_si(values, {role: names[found[role]] for role in values}, path, line)
    if ignored:
        notes.append(f"{path.name}: ignored columns {', '.join(ignored)}")
    return t_ns, values, notes, cut


def _scale_to_si(
    values: dict[str, np.ndarray], headers: dict[str, str], path: Path, header_line: int
) -> list[str]:
    """Scale each role's column in `values` to SI, by the unit its header gives or by the
    preamble's counts per unit; notes on what was scaled."""
    counts = _counts_scales(path, header_line)
    scaled = []
    for role, name in headers.items():
        brackets = bracketed(name)
        raw = [b for b in brackets if RAW & set(re.findall(r"[a-z]+", b.lower()))]
        has_unit = any(b.lower() not in NO_UNIT and is_unit(b) for b in brackets)
        if raw and not has_unit and role[:-1] not in counts:  # `Fx (N) [raw]` is unfiltered N
            raise ConversionError(
                f"column {name!r} holds {raw[0]!r} readings, not a unit; scale "
                "them to SI first (an ATI Net F/T log's counts per unit in its preamble are read)",
                path=path,
            )
        given = value_scale(name, role, path)  # (unit, SI factor) or None
        factor = 1.0 if given is None else given[1]
        if role[:-1] in counts:
            if given is not None:
                raise ConversionError(
                    f"column {name!r} gives a unit, but the preamble says the "
                    "column is in counts; keep one",
                    path=path,
                )
            column = values[role]
            if len(odd := np.flatnonzero(np.isfinite(column) & (column != np.round(column)))):
                raise ConversionError(
                    f"column {name!r}, line {header_line + odd[0] + 2}: "
                    f"{column[odd[0]]:g} is not a count, though the preamble gives counts per "
                    "unit; remove those lines if the values are in N and N m",
                    path=path,
                )
            factor = counts[role[:-1]]
        if factor != 1.0:
            values[role] = values[role] * factor
            scaled.append(f"{name!r}")
    notes = []
    if counts:
        notes.append(f"{path.name}: force and torque are counts, scaled by the preamble")
    if scaled:
        notes.append(f"{path.name}: scaled to SI units: {', '.join(scaled)}")
    return notes


def _group(values: dict[str, np.ndarray], roles: tuple[str, ...]) -> np.ndarray | None:
    """The columns of `roles` side by side, or None unless every one is there."""
    return np.stack([values[r] for r in roles], axis=1) if all(r in values for r in roles) else None


def _incomplete(values: dict[str, np.ndarray], path: Path) -> None:
    for group in (FORCE, TORQUE, LINEAR, ANGULAR, POSITION, ORIENTATION):
        have = [r for r in group if r in values]
        if have and len(have) < len(group):
            missing = [r for r in group if r not in values]
            raise ConversionError(
                f"columns {', '.join(have)} found but not {', '.join(missing)}; "
                f"name them with --column {missing[0]}=HEADER",
                path=path,
            )


def _motion(
    t_ns: np.ndarray, values: dict[str, np.ndarray], name: str
) -> tuple[SourceStream | None, SourceStream | None]:
    """Twist and pose streams from velocity and position columns (angular parts optional)."""
    twist = pose = None
    if (linear := _group(values, LINEAR)) is not None:
        angular = _group(values, ANGULAR)
        angular = np.zeros_like(linear) if angular is None else angular
        twist = SourceStream(
            "twist", name, t_ns, np.concatenate([linear, angular], axis=1), clock=CSV_CLOCK
        )
    if (position := _group(values, POSITION)) is not None:
        quat = _group(values, ORIENTATION)
        held = quat is not None
        if quat is None:
            quat = np.tile([0.0, 0.0, 0.0, 1.0], (len(t_ns), 1))
        pose = SourceStream(
            "pose", name, t_ns, np.concatenate([position, quat], axis=1), clock=CSV_CLOCK,
            has_orientation=held,
        )  # fmt: skip
    return twist, pose


def read_csv(
    path: str | Path,
    *,
    motion: str | Path | None = None,
    columns: Mapping[str, str] | None = None,
    time_unit: str | None = None,
) -> Source:
    """Wrench from `path`; velocity or position from `path` itself or from `motion`."""
    path, motion = Path(path), None if motion is None else Path(motion)
    columns = dict(columns or {})
    named = {f: _header(f)[1] for f in (path, motion) if f is not None}
    if unknown := [
        f"{r}={n}" for r, n in columns.items() if all(n not in h for h in named.values())
    ]:
        held = "; ".join(f"{f.name}: {', '.join(h)}" for f, h in named.items())
        raise ConversionError(
            f"--column {', '.join(unknown)}: no such column (columns of {held})", path=path
        )
    t_ns, values, notes, found = read_table(path, columns, time_unit)
    if missing := [r for r in (*FORCE, *TORQUE) if r not in values]:
        raise ConversionError(_missing_hint(missing, named[path]), path=path)
    _incomplete(values, path)
    wrench = SourceStream(
        "wrench", path.name, t_ns, np.stack([values[r] for r in (*FORCE, *TORQUE)], axis=1),
        clock=CSV_CLOCK,
    )  # fmt: skip
    twist, pose = _motion(t_ns, values, path.name)
    if motion is not None:
        m_ns, m_values, m_notes, m_found = read_table(motion, columns, time_unit)
        _incomplete(m_values, motion)
        notes += m_notes
        found += m_found
        twist, pose = _motion(m_ns, m_values, motion.name)
        if twist is None and pose is None:
            raise ConversionError(_missing_hint([*LINEAR, *POSITION], named[motion]), path=motion)
    if twist is None and pose is None:
        raise ConversionError(
            "no velocity (vx vy vz) or position (x y z) columns for the end-effector velocity; "
            "add them, or give a second file with --motion FILE",
            path=path,
        )
    return Source(
        path=path, format="csv", wrench=wrench, twist=twist, pose=pose, notes=notes,
        warnings=found,
    )  # fmt: skip
