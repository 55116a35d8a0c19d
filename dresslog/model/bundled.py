"""The models a user need not name: bundled with dresslog, or in $DRESSLOG_MODELS.

`infer`, `view` and `record --live` take the model for the trial's task from here when
none is given, and check that a given one fits the trial.

Public API
----------
``bundled_model(task) -> Path | None``: the model folder for `task` ($DRESSLOG_MODELS, the
    checkout's samples, then the installed package's), None if there is none.
``resolve_model(model, task, n_points, *, required=True, loaded=None) -> LoadedModel | None``:
    `model`, or the bundled one, loaded (or taken from `loaded`, a folder -> model dict it
    adds to) and checked against the trial's task and limb points; ``ModelError`` if it does
    not fit, or if none is found and `required`.
"""

from __future__ import annotations

import os
from pathlib import Path

from dresslog.errors import ModelError
from dresslog.folders import CARD_FILE
from dresslog.model.files import LoadedModel, check_task, load_model
from dresslog.spec import Task, task_of

#: Set to a folder holding `<task>/` model folders to override the bundled models.
MODELS_ENV = "DRESSLOG_MODELS"


def bundled_model_candidates(task: Task | str) -> list[Path]:
    """Where the model for `task` may be: $DRESSLOG_MODELS, the checkout's samples, the package."""
    task = task_of(task, ModelError).value
    package = Path(__file__).resolve().parents[1]
    places = [package.parent / "samples" / "models", package / "samples" / "models"]
    if os.environ.get(MODELS_ENV):
        places.insert(0, Path(os.environ[MODELS_ENV]))
    return [place / task for place in places]


def bundled_model(task: Task | str) -> Path | None:
    """The bundled model folder for `task`, or None if this installation has none."""
    for path in bundled_model_candidates(task):
        if (path / CARD_FILE).is_file():
            return path
    return None


def resolve_model(
    model: str | Path | None,
    task: Task | str,
    n_points: int | None,
    *,
    required: bool = True,
    loaded: dict[Path, LoadedModel] | None = None,
) -> LoadedModel | None:
    """Load `model` (or the bundled one for `task`) and check it fits the trial.

    Args:
        model: the model folder; None: the bundled one for `task`.
        task: the trial's task.
        n_points: the trial's limb points; None: not checked.
        required: without a model given or bundled, raise; else return None.
        loaded: the models already loaded, by folder, which gets this one: a batch of
            trials reads and verifies each model once, however many trials it runs on.

    Returns:
        The model, or None when none is given or bundled and none is `required`.

    Raises:
        ModelError: no model where one is required, one that does not load, or one of
            another task or limb-point count, with what to give instead.
    """
    task = task_of(task, ModelError)
    bundled = bundled_model(task)
    hint = "pass --model with a {task} model folder"
    if model is not None and bundled is not None:
        hint = f"leave out --model to use the bundled one ({bundled})"
    elif model is None:
        if bundled is None and not required:
            return None
        if bundled is None:
            looked = ", ".join(str(p) for p in bundled_model_candidates(task))
            raise ModelError(
                f"no bundled {task.value} model (looked in {looked}); "
                f"pass --model with a {task.value} model folder"
            )
        model = bundled
    cache = {} if loaded is None else loaded
    if (found := cache.get(Path(model))) is None:
        found = cache[Path(model)] = load_model(model)
    check_task(found, task, n_points, hint=hint)
    return found
