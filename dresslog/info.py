"""`dresslog info`: what a path holds, a trial, a model folder or a dataset folder.

Public API
----------
``describe(path, *, as_json=False) -> Description``
    The text `dresslog info` prints, and the problem that makes it exit non-zero: a
    model whose weights do not match its card is still described (the card says what it
    claims to be), with the mismatch as the problem; so is a dataset with trials missing
    or of another size than its manifest records (as JSON: the manifest, with the
    damaged trials under "damaged").
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import NamedTuple

from dresslog.errors import DresslogError, ModelError, TrialFormatError
from dresslog.folders import CARD_FILE, MANIFEST_FILE, MODEL_FILES, SWEEP_FILE


class Description(NamedTuple):
    text: str
    problem: DresslogError | None = None


def describe(path: str | Path, *, as_json: bool = False) -> Description:
    """Summarise `path` by what it is: a dataset (manifest), a model (card), a ROS bag (its
    topics and tf tree, for `convert`) or a trial file.

    Args:
        path: the file or folder.
        as_json: the description as JSON (``info --json``), not as text.

    Returns:
        The text (or JSON), and the problem found in what it describes, if any (a
        damaged dataset or model, which `info` reports and exits 1 on).

    Raises:
        DresslogError: `path` is none of these, or one that cannot be read.
    """

    path = Path(path)
    if path.name in {MANIFEST_FILE, *MODEL_FILES} and path.is_file():
        path = path.parent  # `info data/manifest.json` means the folder it describes
    if (path / MANIFEST_FILE).is_file():
        return _dataset(path, as_json)
    if (path / CARD_FILE).is_file():
        return _model(path, as_json)
    from dresslog.convert.bag_info import describe_bag, is_bag, is_ros2_log

    if is_bag(path):  # not a trial yet: what `convert` needs to make one
        return Description(describe_bag(path, as_json=as_json))
    if path.is_dir():
        raise DresslogError(
            f"neither a model folder (no {CARD_FILE}) nor a dataset folder (no {MANIFEST_FILE})"
            + _inside(path),
            path=path,
        )
    from dresslog.io.summary import format_summary, summarize

    try:
        summary = summarize(path)
    except TrialFormatError:
        if path.suffix.lower() == ".mcap" and path.is_file() and is_ros2_log(path):  # a bare bag
            return Description(describe_bag(path, as_json=as_json))
        raise
    return Description(summary.model_dump_json(indent=2) if as_json else format_summary(summary))


def _inside(path: Path) -> str:
    """What `info` takes in a folder of ours that is neither a model nor a dataset: a
    sweep's (a setting's folder), a dataset's split folder (the dataset), a folder of
    trials (one of them, as `samples/`) or of models (one, as `samples/models/`); else ""."""
    from dresslog.dataset.manifest import dataset_holding

    if (path / SWEEP_FILE).is_file():
        return (
            "; a sweep's folder: its table is sweep.csv, and `dresslog info` takes one "
            f"setting's folder, e.g. {path / 'in-range'}"
        )
    if (dataset := dataset_holding(path)) is not None:
        return f"; a dataset's {path.resolve().name} folder: give the dataset, {dataset}"
    if trials := sorted(path.glob("*.mcap")):
        return f"; a folder of trials: `dresslog info` takes one, e.g. {trials[0]}"
    if models := sorted(p.parent for p in path.glob(f"*/{CARD_FILE}")):
        return f"; a folder of models: `dresslog info` takes one, e.g. {models[0]}"
    return ""


def _dataset(path: Path, as_json: bool) -> Description:
    """The manifest's summary; trials missing or of another size than it records fail it."""
    from dresslog.dataset.manifest import (
        damaged_error,
        damaged_files,
        load_manifest,
        remaking,
        warn_if_incomplete,
    )
    from dresslog.model.conditions import DESCRIBED_FIELDS, folder_conditions

    manifest = load_manifest(path)
    warn_if_incomplete(path, manifest)
    damaged = list(damaged_files(path, manifest))  # sizes only: hashing every trial is slow
    problem = damaged_error(path, *damaged[0]) if damaged else None
    from dresslog.dataset.fidelity import folder_fidelity

    damaged_files_ = {file for file, _ in damaged}
    readable = [e.file for e in manifest.trials if e.file and e.file not in damaged_files_]
    figures, read = folder_fidelity(path, manifest.task, readable)
    if as_json:  # the manifest, and the damaged trials as a list beside it
        listed = json.loads(manifest.model_dump_json())
        listed["fidelity"] = figures.as_dict()
        # what a model's card and `eval --json` name the data by (manifest_sha256)
        listed["content_sha256"] = manifest.content_hash()
        listed["damaged"] = [{"file": file, "problem": how} for file, how in damaged]
        return Description(json.dumps(listed, indent=1), problem)
    held = folder_conditions(manifest.task, manifest.overrides, manifest.rotation_range)
    # the speeds and rotations in the words `info MODEL`'s `trained` line and `eval` use
    lines = [f"{path}: {manifest.describe()}", f"  trials    {held.describe()}"]
    others = {k: v for k, v in manifest.overrides.items() if k not in DESCRIBED_FIELDS}
    if others:  # what else sets this dataset apart (short trials)
        fixed = ", ".join(f"{k}={json.dumps(v)}" for k, v in others.items())
        lines.append(f"  fixed for every trial: {fixed}")
    if read:
        sample = f" (read {read} of {len(readable)})" if read < len(readable) else ""
        lines.append(f"  fidelity  against the paper's dressing{sample}")
        lines += figures.lines()
    if damaged:
        names = ", ".join(f"{file} ({how})" for file, how in damaged[:5])
        more = f" and {len(damaged) - 5} more" if len(damaged) > 5 else ""
        lines.append(f"  damaged: {names}{more}; {remaking(damaged[0][0])}")
    return Description("\n".join(lines), problem)


def _model(path: Path, as_json: bool) -> Description:
    from dresslog.model.files import load_model, read_card
    from dresslog.model.summary import format_card

    try:
        card, problem = load_model(path).card, None
    except ModelError as err:
        card, problem = read_card(path), err  # a card that is itself bad raises here
    text = card.model_dump_json(indent=2) if as_json else format_card(path, card, problem is None)
    return Description(text, problem)
