"""The documented API is the API: docstrings name the parameters the code takes.

Two places drift as code changes: the signatures a module's docstring lists under
"Public API" (``train_dataset(data, out, *, epochs=10, ...)``), and a function's own
``Args:`` section. Both are read here and held against `inspect.signature`.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from pydantic import BaseModel

import dresslog

PACKAGE = Path(dresslog.__file__).parent
#: A name in double backticks followed by its arguments: ``name(``, ``Class.method(``.
_CALL = re.compile(r"``([A-Za-z_][\w.]*)\(")
_IDENTIFIER = re.compile(r"\*{0,2}[A-Za-z_]\w*")
#: Public functions and methods that have no docstring: lower it as docstrings are
#: written, never raise it.
UNDOCUMENTED_AT_MOST = 32


def _modules() -> Iterator[ModuleType]:
    """Every module of dresslog whose name has no leading underscore, imported."""
    yield dresslog
    for info in pkgutil.walk_packages([str(PACKAGE)], "dresslog."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            yield importlib.import_module(info.name)


MODULES = list(_modules())


@dataclass
class Documented:
    """One ``name(a, b=1, *, c=...)`` a docstring shows: where, and what it says."""

    where: str
    name: str
    arguments: list[str]


def _closing(text: str, start: int) -> int:
    """The index of the bracket that closes the one opened just before `start`."""
    depth = 1
    for k in range(start, len(text)):
        depth += {"(": 1, "[": 1, "{": 1, ")": -1, "]": -1, "}": -1}.get(text[k], 0)
        if depth == 0:
            return k
    return len(text)


def _top_level_split(text: str) -> list[str]:
    """`text` split at the commas outside brackets and quotes."""
    parts, depth, quote, current = [], 0, "", []
    for char in text:
        if quote:
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char in "([{":
            depth += 1
        elif char in ")]}":
            depth -= 1
        elif char == "," and depth == 0:
            parts.append("".join(current).strip())
            current = []
            continue
        current.append(char)
    if "".join(current).strip():
        parts.append("".join(current).strip())
    return parts


def documented_calls(module: ModuleType) -> Iterator[Documented]:
    """The signatures `module`'s docstring shows, each of a name the module holds."""
    text = " ".join((module.__doc__ or "").split())
    for match in _CALL.finditer(text):
        end = _closing(text, match.end())
        if (
            not text[end + 1 :].startswith(("``", " ->", " -&gt;"))
            and "->" not in text[end : end + 4]
        ):
            continue  # an expression in prose (``f(x)[0]``), not a signature
        yield Documented(module.__name__, match.group(1), _top_level_split(text[match.end() : end]))


def _resolve(module: ModuleType, dotted: str) -> Any:
    target: Any = module
    for part in dotted.split("."):
        target = getattr(target, part, None)
        if target is None:
            return None
    return target


def _problems(documented: Documented, target: Any, namespace: dict[str, Any]) -> list[str]:
    """What the documented signature says that `target`'s real one does not."""
    try:
        real = inspect.signature(target)
    except (TypeError, ValueError):  # a builtin or a C extension's
        return []
    params = {n: p for n, p in real.parameters.items() if n not in ("self", "cls")}
    if any(_IDENTIFIER.match(item) is None and item not in ("*", "...", "…") for item in
           documented.arguments):  # fmt: skip
        return []  # an example call (``parse_speed("0.2")``), not the signature
    # a pydantic model takes its fields by keyword; its docstring lists them in order
    by_keyword = isinstance(target, type) and issubclass(target, BaseModel)
    order, keyword_only, open_ended, problems = [], False, False, []
    for item in documented.arguments:
        if item in ("...", "…"):
            open_ended = True
            continue
        if item == "*":
            keyword_only = True
            continue
        name_match = _IDENTIFIER.match(item)
        assert name_match is not None  # checked above
        name = name_match.group().lstrip("*")
        param = params.get(name)
        if param is None:
            problems.append(f"documents `{name}`, which it does not take")
            continue
        order.append(name)
        is_keyword_only = param.kind is inspect.Parameter.KEYWORD_ONLY
        if (
            not by_keyword
            and keyword_only != is_keyword_only
            and param.kind
            not in (
                inspect.Parameter.VAR_POSITIONAL,
                inspect.Parameter.VAR_KEYWORD,
            )
        ):
            where = "after" if keyword_only else "before"
            problems.append(f"shows `{name}` {where} `*`, but it is {param.kind.description}")
        default = item[name_match.end() :].strip()
        if default.startswith("="):
            problems += _default_problems(name, default[1:].strip(), param, namespace)
    if order != [n for n in params if n in order]:
        problems.append(f"lists {order} out of the order {list(params)}")
    if not open_ended:  # ``f()`` may be a call of defaults (``TrainOptions()``)
        left_out = [
            n
            for n, p in params.items()
            if n not in order
            and p.kind not in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
            and (documented.arguments or p.default is inspect.Parameter.empty)
        ]
        if left_out:
            problems.append(f"leaves out {left_out} (write `...` where that is meant)")
    return problems


def _default_problems(
    name: str, shown: str, param: inspect.Parameter, namespace: dict[str, Any]
) -> list[str]:
    if param.default is inspect.Parameter.empty:
        return [f"shows `{name}={shown}`, but `{name}` has no default"]
    if shown in ("...", "…"):
        return []
    try:
        value = eval(shown, dict(namespace))
    except Exception:  # a description, not an expression (`workers=all cores`)
        return []
    try:
        same = bool(value == param.default)
    except Exception:  # arrays and the like: compared by what they print
        same = repr(value) == repr(param.default)
    return [] if same else [f"shows `{name}={shown}`, but its default is {param.default!r}"]


def _all_documented() -> list[tuple[Documented, Any]]:
    found = []
    for module in MODULES:
        for documented in documented_calls(module):
            target = _resolve(module, documented.name)
            if callable(target):
                found.append((documented, target))
    return found


DOCUMENTED = _all_documented()


def test_the_docstrings_show_signatures_to_check() -> None:
    """The walk finds what it is to check (a regex that matched nothing would pass)."""
    names = {d.name for d, _ in DOCUMENTED}
    assert {"train_dataset", "train", "save_model", "evaluate_dataset", "sweep"} <= names
    assert len(DOCUMENTED) > 40


@pytest.mark.parametrize(
    ("documented", "target"), DOCUMENTED, ids=[f"{d.where}:{d.name}" for d, _ in DOCUMENTED]
)
def test_a_module_docstrings_signatures_match_the_code(documented: Documented, target: Any) -> None:
    module = importlib.import_module(documented.where)
    problems = _problems(documented, target, vars(module))
    assert not problems, f"{documented.where}'s docstring: {documented.name}() " + "; ".join(
        problems
    )


def _public_functions() -> Iterator[tuple[str, Any]]:
    """Every public function and method defined in dresslog, by qualified name."""
    seen: set[int] = set()
    for module in MODULES:
        for name, value in vars(module).items():
            if name.startswith("_") or getattr(value, "__module__", None) != module.__name__:
                continue
            members: list[tuple[str, Any]] = [(name, value)]
            if inspect.isclass(value):
                members = [
                    (f"{name}.{attr}", member)
                    for attr, member in vars(value).items()
                    if not attr.startswith("_")
                ]
            for qualified, member in members:
                function = member.fget if isinstance(member, property) else member
                function = getattr(function, "__func__", function)  # class/static methods
                if inspect.isfunction(function) and id(function) not in seen:
                    seen.add(id(function))
                    yield f"{module.__name__}.{qualified}", function


PUBLIC = list(_public_functions())


def _args_section(doc: str) -> list[str] | None:
    """The names an ``Args:`` section lists, in order; None without one."""
    lines = doc.splitlines()
    try:
        start = next(k for k, line in enumerate(lines) if line.strip() == "Args:")
    except StopIteration:
        return None
    indent = len(lines[start]) - len(lines[start].lstrip())
    names, item_indent = [], None
    for line in lines[start + 1 :]:
        if not line.strip():
            continue
        depth = len(line) - len(line.lstrip())
        if depth <= indent:
            break
        item_indent = item_indent or depth
        if depth == item_indent and (match := re.match(r"\s*(\*{0,2}\w+)[^:]*:", line)):
            names.append(match.group(1).lstrip("*"))
    return names


def test_args_sections_name_every_parameter_in_order() -> None:
    with_args = [(q, f, names) for q, f in PUBLIC if (names := _args_section(f.__doc__ or ""))]
    assert len(with_args) >= 3  # the ones this test was written beside
    wrong = []
    for qualified, function, names in with_args:
        params = [n for n in inspect.signature(function).parameters if n not in ("self", "cls")]
        if names != params:
            wrong.append(f"{qualified}: Args {names}, signature {params}")
    assert not wrong, "\n".join(wrong)


def test_public_functions_without_a_docstring_do_not_grow() -> None:
    missing = [q for q, f in PUBLIC if not (f.__doc__ or "").strip()]
    assert len(PUBLIC) > 300
    assert len(missing) <= UNDOCUMENTED_AT_MOST, "\n".join(missing)
