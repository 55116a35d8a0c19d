"""Units written in a CSV header's brackets: which are units, and their SI factors.

`Fx (kN)`, `Tz [N-mm]`, `vx (mm/s)` are scaled to SI; a unit dresslog does not convert
(`dN`, `km/h`, a DAQ's `V`) is refused rather than read as SI; a bracket that reads as
no unit (`Fx (tool)`) is a label.

Public API
----------
``value_scale(name, role, path) -> (unit, factor) | None``: the unit a value column's
    header gives and its SI factor; a unit not converted is a ``ConversionError``.
``si_factor(written, group) -> float | None``, ``is_unit(written) -> bool``,
``bracketed(name) -> list[str]``: the pieces, for the counts-per-unit preamble and time
    columns of `dresslog.convert.csv`.
``VALUE_UNITS`` (SI factors by role group), ``NO_UNIT`` and ``RAW`` (brackets that mean
    no unit, or raw sensor readings).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from dresslog.errors import ConversionError

#: SI factor of each unit a value column's header may give in brackets, by role
#: group (`fx` -> "f", `x` -> ""); matched ignoring case, spaces, dots and dashes.
VALUE_UNITS: dict[str, dict[str, float]] = {
    "f": {"N": 1.0, "kN": 1e3, "mN": 1e-3, "lbf": 4.4482216152605},
    "t": {"N m": 1.0, "N mm": 1e-3, "mN m": 1e-3, "kN m": 1e3,
          "lbf in": 0.1129848290276167, "in lbf": 0.1129848290276167,
          "lb in": 0.1129848290276167, "in lb": 0.1129848290276167,
          "lbf ft": 1.3558179483314004, "ft lbf": 1.3558179483314004,
          "lb ft": 1.3558179483314004, "ft lb": 1.3558179483314004},
    "v": {"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3},
    "w": {"rad/s": 1.0, "deg/s": np.pi / 180},
    "": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "q": {},
}  # fmt: skip


#: Units spelt out, by the key of their symbol.
_SPELLED = {"newton": "n", "newtons": "n", "kilonewton": "kn", "kilonewtons": "kn"}


#: What a unit is written with: a bracket made only of these (and `/`) names a unit,
#: anything else (`Fx (tool)`, `Fx [sensor 2]`) is a label. SI bases take any common
#: prefix (`dN`, `km/h`), so a unit not converted is refused, never read as SI.
_UNIT_ATOMS = re.compile(
    r"^((da|[kmcdunµμhg])?(n|m|s|g|h|hr|min|rad|deg)"
    r"|lbf|lb|kgf|gf|ozf|oz|ft|in|yd|mi|mph|kph|kmh|rpm|rev|dps|sec|kn|knots?"
    r"|dyn|dynes?|kips?|pdl)+$"  # these combine too: kip-ft, dyn-cm
)


#: Units written only whole: as atoms they would make words of others (`h` + `ips`).
#: Volts are a DAQ's reading before calibration, never newtons.
_WHOLE_UNITS = {
    "fps",
    "ips",
    "v",
    "mv",
    "volt",
    "volts",
    "newton",
    "newtons",
    "kilonewton",
    "kilonewtons",
    "pound",
    "pounds",
}


#: Brackets that say a column has no unit.
NO_UNIT = {"", "-", "1", "none", "unitless", "dimensionless"}


#: Brackets that say a column holds a sensor's raw readings, not a physical unit.
RAW = {"raw", "counts", "count", "cnt", "cnts", "adc", "lsb", "bits"}


def _unit_key(unit: str) -> str:
    """`N·m`, `N-m`, `Nm` -> `nm`; `°/sec`, `deg s-1`, `degree/s`, `dps` -> `deg/s`."""
    unit = re.sub(r"\s+per\s+", "/", unit)  # mm per s
    unit = re.sub(r"[\s·⋅×*._]*([a-zA-Zµμ°]+)\s*(?:\^-1|-1|⁻¹)", r"/\1", unit)  # s-1 -> /s
    key = re.sub(r"[\s·⋅×*._\-]", "", unit.lower()).replace("\u00b0", "deg")
    key = re.sub(r"/sec(ond)?s?$", "/s", key)
    key = key.replace("degrees", "deg").replace("degree", "deg")
    return "deg/s" if key == "dps" else key


def bracketed(name: str) -> list[str]:
    """What a header holds in round or square brackets: `Fx [sensor 1] (kN)` -> both."""
    return [b.strip() for b in re.findall(r"[\(\[]([^\)\]]*)[\)\]]", name)]


def si_factor(written: str, group: str) -> float | None:
    """The SI factor of a unit as written for a role group (`f`, `t`, ...), or None."""
    if re.search(r"(?<![A-Za-z])M(?=[Nn])", written):  # MN is mega, not milli, newtons
        return None
    known = {_unit_key(unit): factor for unit, factor in VALUE_UNITS[group].items()}
    key = _unit_key(written)
    return known.get(_SPELLED.get(key, key))


def is_unit(written: str) -> bool:
    """Whether a bracket's text is a unit (known or not), rather than a label."""
    parts = re.sub(r"\^-?\d", "", _unit_key(written)).split("/")
    return all(_UNIT_ATOMS.match(part) or part in _WHOLE_UNITS for part in parts)


def value_scale(name: str, role: str, path: Path) -> tuple[str, float] | None:
    """The unit a value column's header gives and its SI factor; a unit not known is refused.

    Values are stored in SI (N, N m, m/s, rad/s, m); a header that says `Fx (kN)` or
    `Tz [N-mm]` is scaled, since reading its numbers as SI would be silently wrong.
    Brackets holding a label rather than a unit are passed over.
    """
    units = [b for b in bracketed(name) if b.lower() not in NO_UNIT and is_unit(b)]
    if not units:
        return None
    written, known = units[0], VALUE_UNITS[role[:-1]]
    if (scale := si_factor(written, role[:-1])) is not None:
        return written, scale
    hint = f"give the values in one of {', '.join(known)}" if known else "a quaternion has none"
    raise ConversionError(
        f"column {name!r} is in {written!r}, a unit dresslog does not convert; {hint}",
        path=path,
    )
