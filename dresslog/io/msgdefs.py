"""The `.msg` files in `schemas/` as the `ros2msg` schema texts an MCAP file registers.

`schemas/` is the single source of truth: the writer registers exactly these
texts (each message followed by its dependencies, in ROS 2's concatenated
form) and the tests check the numpy codec against them.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import resources

PRIMITIVES = frozenset(
    {
        "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16",
        "uint16", "int32", "uint32", "int64", "uint64", "string", "wstring",
    }
)  # fmt: skip
SEPARATOR = "=" * 80


def full_type_name(type_name: str, package: str) -> str:
    """`Vector3` inside geometry_msgs -> `geometry_msgs/msg/Vector3`."""
    parts = type_name.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{parts[0]}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return type_name


@cache
def msg_text(name: str) -> str:
    """The text of `schemas/<pkg>/msg/<Type>.msg` for `pkg/msg/Type`."""
    package, _, type_ = name.split("/")
    path = resources.files("dresslog.schemas").joinpath(package, "msg", f"{type_}.msg")
    return path.read_text(encoding="utf-8")


@cache
def fields(name: str) -> tuple[tuple[str, str], ...]:
    """(type, field name) pairs of a message, comments and constants removed."""
    out = []
    for line in msg_text(name).splitlines():
        line = line.split("#", 1)[0].strip()
        if not line or "=" in line:  # blank, or a constant
            continue
        type_, field_name = line.split()[:2]
        out.append((type_, field_name))
    return tuple(out)


def dependencies(name: str) -> list[str]:
    """Every message type `name` uses, depth first, each once."""
    package = name.split("/")[0]
    found: list[str] = []
    for type_, _ in fields(name):
        base = re.sub(r"\[.*\]$", "", type_)
        if base in PRIMITIVES:
            continue
        full = full_type_name(base, package)
        for dep in [full, *dependencies(full)]:
            if dep not in found:
                found.append(dep)
    return found


@cache
def schema_text(name: str) -> str:
    """The `ros2msg` schema data for `name`: its text, then each dependency's."""
    parts = [msg_text(name).rstrip("\n")]
    for dep in dependencies(name):
        package, _, type_ = dep.split("/")
        parts.append(f"{SEPARATOR}\nMSG: {package}/{type_}\n{msg_text(dep).rstrip(chr(10))}")
    return "\n".join(parts) + "\n"
