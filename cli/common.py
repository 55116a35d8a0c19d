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
        except DresslogError as err:
            raise click.ClickException(str(err)) from None
        except ValidationError as err:  # a spec built from options: name the bad value
            raise click.ClickException(f"invalid {first_problem(err)}") from None
        except OSError as err:  # the machine's side: disk full, read-only, permissions
            where = f"{err.filename}: " if err.filename else ""
            raise click.ClickException(f"{where}{err.strerror or err}") from None

    return wrapper


def _show_warning(python: Callable[..., None]) -> Callable[..., None]:
    """Print a `DresslogWarning` as `Warning: <message>` on stderr; leave others to Python."""

    def show(message: Warning | str, category: type[Warning], *args: object, **kw: object) -> None:
        if issubclass(category, DresslogWarning):
            click.echo(f"Warning: {message}", err=True)
        else:
            python(message, category, *args, **kw)

    return show
