"""What every command shares: DresslogError as one line and exit 1, never a traceback."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

import click
from pydantic import ValidationError

from dresslog.errors import DresslogError, first_problem

P = ParamSpec("P")
R = TypeVar("R")


def reports_errors(command: Callable[P, R]) -> Callable[P, R]:
    """Turn a `DresslogError` (a user mistake or bad input) into `Error: <one line>`, exit 1."""

    @functools.wraps(command)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return command(*args, **kwargs)
        except DresslogError as err:
            raise click.ClickException(str(err)) from None
        except ValidationError as err:  # a spec built from options: name the bad value
            raise click.ClickException(f"invalid {first_problem(err)}") from None
        except OSError as err:  # the machine's side: disk full, read-only, permissions
            where = f"{err.filename}: " if err.filename else ""
            raise click.ClickException(f"{where}{err.strerror or err}") from None

    return wrapper
