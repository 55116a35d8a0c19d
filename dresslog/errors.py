"""One error family: every user-facing failure is a `DresslogError` naming what and where.

The CLI turns these into one line and exit code 1; anything else is a bug.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pydantic import ValidationError


class DresslogError(Exception):
    """Root of dresslog's errors; `path` names the file concerned, when there is one."""

    def __init__(self, message: str, *, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self.message = message
        super().__init__(message)

    def __str__(self) -> str:  # from `path` as it stands: a caller may name it otherwise
        return f"{self.path}: {self.message}" if self.path is not None else self.message


class TrialFormatError(DresslogError):
    """A file is not a readable dresslog trial (missing, truncated, foreign, wrong schema)."""

    def __init__(
        self, message: str, *, path: str | Path | None = None, channel: str | None = None
    ) -> None:
        self.channel = channel
        super().__init__(f"channel {channel}: {message}" if channel else message, path=path)


class TrialWriteError(DresslogError):
    """A trial could not be written (exists, a file where its folder goes, bad values)."""


class SimulationError(DresslogError):
    """A simulation went unstable or was given an impossible spec."""


class ModelError(DresslogError):
    """A model file is missing, foreign, tampered with, or for another task."""


class ConversionError(DresslogError):
    """An external log cannot be converted (no topics, ambiguous topics, bad timestamps)."""


class LiveError(DresslogError):
    """A live session cannot go on: no ROS 2, a silent or mistyped topic, a clock reset."""


class DatasetError(DresslogError):
    """A dataset folder has no manifest, or missing or corrupt trials."""


class DresslogWarning(UserWarning):
    """Something the user should know that does not stop the command; the CLI prints
    `Warning: <message>`."""


def first_problem(err: ValidationError, whole: str = "value") -> str:
    """The first problem pydantic found, as `field.path: message`, for a one-line error."""
    first = err.errors()[0]
    message = first["msg"].removeprefix("Value error, ")  # our own validators' words
    if not first["loc"] and first["type"] == "value_error":
        return message
    where = ".".join(str(part) for part in first["loc"]) or whole
    return f"{where}: {message}"
