"""What every command shares: DresslogError as one line and exit 1, never a traceback."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import ParamSpec, TypeVar

import click
from pydantic import ValidationError

from dresslog.errors import DresslogError, DresslogWarning, first_problem

P = ParamSpec("P")
R = TypeVar("R")


def reports_errors(command: Callable[P, R]) -> Callable[P, R]:
    """Turn a `DresslogError` (a user mistake or bad input) into `Error: <one line>`, exit 1."""

    @functools.wraps(command)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            with warnings.catch_warnings():  # restores Python's own printer afterwards
                warnings.showwarning = _show_warning(warnings.showwarning)
                return command(*args, **kwargs)
        except (DresslogError, ValidationError, OSError) as err:
            raise click.ClickException(error_line(err)) from None

    return wrapper


def error_line(err: DresslogError | ValidationError | OSError) -> str:
    """The one line that says what went wrong (what `Error: ` is followed by)."""
    if isinstance(err, ValidationError):  # a spec built from options: name the bad value
        return f"invalid {first_problem(err)}"
    if isinstance(err, OSError):  # the machine's side: disk full, read-only, permissions
        where = f"{err.filename}: " if err.filename else ""
        return f"{where}{err.strerror or err}"
    return str(err)


def _show_warning(python: Callable[..., None]) -> Callable[..., None]:
    """Print a `DresslogWarning` as `Warning: <message>` on stderr; leave others to Python."""

    def show(message: Warning | str, category: type[Warning], *args: object, **kw: object) -> None:
        if issubclass(category, DresslogWarning):
            click.echo(f"Warning: {message}", err=True)
        else:
            python(message, category, *args, **kw)

    return show
