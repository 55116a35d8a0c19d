"""The dataset manifest: which trials a folder holds, how they were made, which split each is in.

A dataset folder is ``manifest.json`` plus ``train/*.mcap`` and ``test/*.mcap`` (a sweep
setting's: ``sweep/*.mcap``). The
manifest lists every completed trial (file, spec, outcome, steps, size, sha256) and every
failed attempt with its reason, so a folder can be checked, resumed and cited (its
`content_hash` goes into the model card). It is rewritten atomically; a crash never
leaves a half manifest.

Seeds are derived, never drawn: `trial_seed` puts the role (train, test, sweep) in the
low bits, so the test split cannot share a seed with training, and a failed slot's
replacement seed is fixed by (base seed, slot, attempt) whatever order workers finish in.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from collections import Counter
from collections.abc import Iterator
from datetime import UTC, datetime
from enum import IntEnum, StrEnum
from pathlib import Path
from typing import Any, Final, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictInt,
    ValidationError,
    ValidationInfo,
    model_validator,
)

from dresslog import __version__
from dresslog.errors import DatasetError, DresslogWarning, first_problem
from dresslog.folders import CARD_FILE, MANIFEST_FILE, SWEEP_FILE
from dresslog.io import jsontext
from dresslog.io.files import atomic_path, no_such, sha256_file
from dresslog.spec import (
    RECORDED,
    Outcome,
    RotationRange,
    Task,
    TrialSpec,
    simulator_fields,
    simulator_of,
)

FORMAT: Final = "dresslog-dataset"
FORMAT_VERSION = 1
#: The paper's proportion: 1,000 test sequences to 5,000 training ones.
TEST_FRACTION = 1 / 6
#: The fewest training trials `train` takes; `generate` warns of a folder with fewer.
MIN_TRAIN = 2


class Split(StrEnum):
    """Where a trial belongs; `sweep` trials are fresh sequences for generalisation tests."""

    TRAIN = "train"
    TEST = "test"
    SWEEP = "sweep"


def as_split(value: Split | str) -> Split:
    """`value` as a Split; a `DatasetError` naming the three for anything else."""
    if value not in set(Split):
        raise DatasetError(f"split {value!r} is not one of {', '.join(Split)}")
    return Split(value)


class _Role(IntEnum):
    TRAIN = 0
    TEST = 1
    SWEEP = 2


def trial_seed(base_seed: int, split: Split | str, slot: int, attempt: int = 0) -> int:
    """The seed of attempt `attempt` at `slot` of `split`; distinct for every argument tuple.

    Role in the low 2 bits, (slot, attempt) Cantor-paired above them, the base seed
    above bit 48: splits of one dataset are disjoint by construction, and so are
    datasets with different base seeds (for slot + attempt < ~10^7).
    """
    if base_seed < 0 or slot < 0 or attempt < 0:
        raise ValueError("seeds, slots and attempts are non-negative")
    pair = (slot + attempt) * (slot + attempt + 1) // 2 + attempt
    return (base_seed << 48) | (pair << 2) | _Role[Split(split).name].value


def slot_file(split: Split | str, slot: int) -> str:
    """Where a slot's trial lives, relative to the dataset folder."""
    return f"{Split(split).value}/{slot:06d}.mcap"


class Status(StrEnum):
    OK = "ok"
    FAILED = "failed"


class Entry(BaseModel):
    """One attempt at one slot: a recorded trial (`ok`) or a failure with its reason."""

    model_config = ConfigDict(extra="forbid")

    split: Split
    slot: int = Field(ge=0)
    attempt: int = Field(0, ge=0)
    status: Status
    file: str | None = Field(None, description="path relative to the dataset folder")
    spec: TrialSpec
    outcome: Outcome = Outcome.UNKNOWN
    steps: int = 0
    size: int = 0
    sha256: str | None = None
    failure: str | None = None
    seconds: float = 0.0


class Manifest(BaseModel):
    """A dataset folder's index: request, completed trials (by split) and failures."""

    model_config = ConfigDict(extra="forbid")

    format: Literal["dresslog-dataset"] = FORMAT
    format_version: StrictInt = FORMAT_VERSION  # "2" is no version: refused, not read as 2
    task: Task
    seed: int = 0
    n_train: int = Field(ge=0)
    n_test: int = Field(ge=0)
    n_sweep: int = Field(0, ge=0)
    overrides: dict[str, Any] = Field(
        default_factory=dict, description="spec fields fixed for every trial (e.g. duration)"
    )
    rotation_range: RotationRange | None = Field(
        None, description="limb rotation drawn per trial (`generate --rotation-range`)"
    )
    trials: list[Entry] = Field(default_factory=list)
    failures: list[Entry] = Field(default_factory=list)
    dresslog_version: str = __version__
    updated: str = ""

    @model_validator(mode="before")
    @classmethod
    def _simulator_said(cls, data: object, info: ValidationInfo) -> object:
        """A saved folder whose overrides name no simulator is of v8 or before (v7 said
        no wrench either): said here, so its seeds draw and simulate as they did, and a
        request for another version is refused as a change of its fixed fields."""
        if not (isinstance(data, dict) and isinstance(info.context, dict)):
            return data
        if info.context.get("recorded") is not True:
            return data
        overrides = data.get("overrides")
        if isinstance(overrides, dict):
            sim = overrides.get("sim")
            sim = sim if isinstance(sim, dict) else {}
            if "simulator" not in sim:
                said = simulator_fields(simulator_of(sim))
                data = {**data, "overrides": {**overrides, "sim": {**sim, **said}}}
        return data

    @model_validator(mode="after")
    def _trials_where_their_split_puts_them(self) -> Manifest:
        """Each trial once, in its split's folder under its slot's name, within the request.

        A hand-edited split or a duplicated slot would quietly move a training trial
        into the test set; the file names are what the splits are made of.
        """
        seen: set[tuple[str, int]] = set()
        for entry in self.trials:
            expected = slot_file(entry.split, entry.slot)
            where = expected.removesuffix(".mcap")
            if entry.status != Status.OK:
                raise ValueError(f"{where} is listed as a trial but its status is {entry.status}")
            if entry.file != expected:
                raise ValueError(f"trial {entry.file} is listed as {where}")
            if (entry.split.value, entry.slot) in seen:
                raise ValueError(f"{where} is listed twice")
            if entry.slot >= self.wanted(entry.split):
                raise ValueError(f"{where} is beyond the {self.wanted(entry.split)} asked for")
            seen.add((entry.split.value, entry.slot))
        return self

    # -- queries ---------------------------------------------------------------
    def split(self, split: Split | str) -> list[Entry]:
        """Completed trials of one split, in slot order."""
        split = Split(split)
        return sorted((e for e in self.trials if e.split == split), key=lambda e: e.slot)

    def wanted(self, split: Split | str) -> int:
        """How many trials of `split` were asked for."""
        return {Split.TRAIN: self.n_train, Split.TEST: self.n_test, Split.SWEEP: self.n_sweep}[
            Split(split)
        ]

    @property
    def complete(self) -> bool:
        """Whether every split holds the trials asked for (a stopped generation's does not)."""
        return all(len(self.split(s)) >= self.wanted(s) for s in Split)

    def counts(self) -> str:
        """Trials done per split out of those asked for: `900/1000 train, 200/200 test`."""
        return ", ".join(
            f"{len(self.split(s))}/{self.wanted(s)} {s}" for s in Split if self.wanted(s)
        )

    def describe(self) -> str:
        """One line for people: trials per split, outcomes, failures replaced."""
        counts = self.counts()
        outcomes = Counter(e.outcome.value for e in self.trials)
        seen = ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items())) or "none"
        filled = {(e.split, e.slot) for e in self.trials}
        open_slots = sum((f.split, f.slot) not in filled for f in self.failures)
        failed = f"{len(self.failures)} failed seed(s) replaced"
        if open_slots:
            failed = (
                f"{len(self.failures)} failed seed(s), {open_slots} of them on slots still "
                "empty (run generate again)"
            )
        hashed = self.content_hash()[:12]
        return f"{self.task} trials {counts}; outcomes {seen}; {failed}; content sha256 {hashed}"

    def content_hash(self) -> str:
        """sha256 of what the data is (task, and per trial its split, slot, file and hash).

        Timestamps, failures and software versions are left out: two folders holding the
        same recordings have the same hash, and any changed recording changes it.
        """
        rows = sorted(
            (e.split.value, e.slot, e.file, e.sha256) for e in self.trials if e.status == "ok"
        )
        blob = json.dumps({"task": self.task.value, "trials": rows}, separators=(",", ":"))
        return hashlib.sha256(blob.encode()).hexdigest()

    # -- files -----------------------------------------------------------------
    def save(self, root: str | Path) -> Path:
        """Write `root/manifest.json` atomically (temporary file, fsync, rename)."""
        path = Path(root) / MANIFEST_FILE
        self.updated = datetime.now(UTC).isoformat(timespec="seconds")
        self.trials.sort(key=lambda e: (e.split.value, e.slot))
        with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8") as stream:
            stream.write(self.model_dump_json(indent=1) + "\n")
            stream.flush()
            os.fsync(stream.fileno())
        return path


def dataset_holding(folder: Path) -> Path | None:
    """The dataset folder that `folder` lies directly in (a split's), if it is one."""
    named = folder.resolve() if folder.name in ("", "..") else folder  # `.` names no parent
    return named.parent if (named.parent / MANIFEST_FILE).is_file() else None


def load_manifest(root: str | Path) -> Manifest:
    """Read `root/manifest.json`.

    Args:
        root: the dataset folder.

    Returns:
        The manifest, validated as recorded (fields an older dresslog left out take
        that version's defaults).

    Raises:
        DatasetError: one line for a missing, unreadable, foreign, newer or invalid
            manifest, with a hint when `root` is a file, a split folder, a sweep's or a
            model's.
    """
    root = Path(root)
    path = root / MANIFEST_FILE
    if root.is_file():
        hint = "give a folder"
        if root.name == MANIFEST_FILE:
            hint = f"give its folder, {root.parent}"
        elif (dataset := dataset_holding(root.parent)) is not None:  # one of its trials
            hint = f"give its dataset, {dataset}"
        raise DatasetError(f"is a file; a dataset is a folder: {hint}", path=root)
    if not root.is_dir():
        raise DatasetError(no_such(root, "dataset folder"), path=root)
    if not path.is_file():
        hint = "not a dataset folder (make one with `dresslog generate`)"
        if (root / SWEEP_FILE).is_file():  # a sweep's settings each hold a dataset
            hint = "a sweep's folder: `dresslog sweep` scores its settings (table: sweep.csv)"
        elif (dataset := dataset_holding(root)) is not None:  # `data/gown/test`
            hint = f"a dataset's {root.resolve().name} folder: give the dataset, {dataset}"
        elif (root / CARD_FILE).is_file():  # `train MODEL`, or `eval` given the model twice
            hint = "a model folder, not a dataset (`eval MODEL DATA` takes the dataset second)"
        raise DatasetError(f"no {MANIFEST_FILE}; {hint}", path=root)
    try:
        raw = jsontext.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:  # unreadable, not UTF-8, not JSON, nested past reading
        raise DatasetError(f"{MANIFEST_FILE} is not readable JSON: {err}", path=root) from None
    if not isinstance(raw, dict) or raw.get("format") != FORMAT:
        raise DatasetError(f"{MANIFEST_FILE} is not a dresslog dataset manifest", path=root)
    version = raw.get("format_version")
    if isinstance(version, int) and version > FORMAT_VERSION:  # else pydantic names the type
        raise DatasetError(
            f"{MANIFEST_FILE} has format version {raw['format_version']}, newer than this "
            f"dresslog reads ({FORMAT_VERSION}); upgrade dresslog",
            path=root,
        )
    try:
        return Manifest.model_validate(raw, context=RECORDED)
    except ValidationError as err:
        problem = first_problem(err, "manifest")
        raise DatasetError(f"{MANIFEST_FILE}: {problem}", path=root) from None


#: What each kind of damage `damage` finds is called in an error.
_DAMAGE = {
    "missing": "listed in the manifest is missing",
    "resized": "is not the size the manifest records (truncated or modified)",
    "changed": "does not match its checksum in the manifest (corrupt or modified)",
}


def damage(root: str | Path, entry: Entry, *, checksum: bool = False) -> str | None:
    """ "missing", "resized" or (with `checksum`) "changed"; None for a trial as recorded."""
    path = Path(root) / str(entry.file)
    if not path.is_file():
        return "missing"
    if path.stat().st_size != entry.size:
        return "resized"
    if checksum and sha256_file(path) != entry.sha256:
        return "changed"
    return None


def warn_if_incomplete(root: Path, manifest: Manifest) -> None:
    """An interrupted generation's folder is usable, but say so, and how to finish it (a
    sweep setting's by its sweep: `generate` refuses the setting's fixed fields)."""
    if not manifest.complete:
        command = "sweep" if manifest.wanted(Split.SWEEP) else "generate"
        warnings.warn(
            f"{root}: the dataset is incomplete ({manifest.counts()}); run its "
            f"`dresslog {command}` command again to finish it",
            DresslogWarning,
            stacklevel=3,
        )


def remaking(file: str) -> str:
    """The cure for a damaged trial `file`: its folder's command run again (a sweep
    setting's folder is remade by its sweep: `generate` refuses the setting's fixed fields)."""
    swept = file.startswith(f"{Split.SWEEP.value}/")
    command = "sweep` that made it" if swept else "generate` on it"
    return f"run `dresslog {command} again"


def damaged_error(root: str | Path, file: str, how: str) -> DatasetError:
    """The one line for a damaged trial, naming the folder, the trial and the cure."""
    return DatasetError(f"trial {file} {_DAMAGE[how]}; {remaking(file)} to re-create it", path=root)


def damaged_files(
    root: str | Path, manifest: Manifest, *, checksums: bool = False
) -> Iterator[tuple[str, str]]:
    """(file, how) for each listed trial not as the manifest records it (see `damage`).

    Lazy, so a caller that stops at the first hashes no further.
    """
    root = Path(root)
    for entry in manifest.trials:
        if how := damage(root, entry, checksum=checksums):
            yield str(entry.file), how


def check_files(root: str | Path, manifest: Manifest, *, checksums: bool = False) -> None:
    """Every listed trial exists with its recorded size (and, if asked, its sha256)."""
    first = next(damaged_files(root, manifest, checksums=checksums), None)
    if first is not None:
        raise damaged_error(root, *first)
