"""Generate a dataset: many simulated trials in parallel, resumable, with a manifest.

``generate(task, trials, out, ...)`` plans slots per split (``train/000000.mcap`` ...),
skips every slot the manifest already lists with a file of the right checksum, runs
the rest on an executor (a local process pool by default, Ray tasks with
``executor="ray"``) and records each result in the manifest as it arrives. A trial
that goes unstable is listed under ``failures`` with its reason and its slot is
retried with the next derived seed (`trial_seed`), so the same command on the same
folder always produces the same data, however often it was interrupted.
"""

from __future__ import annotations

import contextlib
import operator
import os
import re
import signal
import threading
import time
import warnings
from collections.abc import Iterator, Mapping
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from dresslog.dataset.executors import (
    LOCAL,
    Execution,
    Job,
    Recorder,
    check_executor,
    make_executor,
)
from dresslog.dataset.manifest import (
    MIN_TRAIN,
    TEST_FRACTION,
    Entry,
    Manifest,
    Split,
    Status,
    as_split,
    damage,
    load_manifest,
    trial_seed,
)
from dresslog.errors import DatasetError, DresslogError, DresslogWarning, first_problem
from dresslog.folders import MANIFEST_FILE
from dresslog.io.files import (
    exclusive,
    is_temporary,
    named_as_recording,
    remove_folders,
    resolved,
)
from dresslog.sim import random_spec, record_trial
from dresslog.spec import (
    RotationRange,
    SimParams,
    Task,
    TrialSpec,
    simulator_fields,
    simulator_name,
    simulator_of,
    task_of,
)
from dresslog.stops import stop_signals
from dresslog.trial import STEP_HZ

#: Seconds between manifest rewrites while trials arrive (always rewritten at the end).
SAVE_EVERY_S = 2.0
#: Seconds between checks for Ctrl-C while waiting on the workers.
POLL_S = 0.2
LOCK_FILE = ".generate.lock"


def _check_folder(root: Path) -> None:
    """Refuse a folder that holds something other than a dataset (a model, say).

    Only a dataset's manifest makes a folder resumable; a first run killed before its
    manifest was written leaves at most the lock, empty split folders and a temporary.
    """
    if not root.exists():
        return
    if not root.is_dir():
        raise DatasetError("exists and is not a folder", path=root)
    if (root / MANIFEST_FILE).exists():
        return
    ours = {LOCK_FILE, *(split.value for split in Split)}

    def foreign(p: Path) -> bool:
        return not is_temporary(p.name) and (  # a killed save's temporary is ours
            p.name not in ours or (p.is_dir() and any(p.iterdir()))
        )

    if any(foreign(p) for p in root.iterdir()):
        raise DatasetError(
            f"folder is not empty and holds no dataset ({MANIFEST_FILE}); "
            "give a new or empty folder",
            path=root,
        )


#: A million trials is months of simulation on a cluster; more is a typo (whose job
#: list alone would fill the memory).
MAX_TRIALS = 1_000_000


def _split_counts(trials: int, test_fraction: float) -> dict[Split, int]:
    if _whole(trials) is None or not 1 <= trials <= MAX_TRIALS:
        raise DatasetError(
            f"--trials must be a whole number from 1 to {MAX_TRIALS:,}, not {trials!r}"
        )
    if not 0 <= test_fraction <= 1:
        raise DatasetError(f"test fraction must be in [0, 1], not {test_fraction}")
    n_test = round(trials * test_fraction) if trials > 1 or test_fraction == 1 else 0
    return {Split.TRAIN: trials - n_test, Split.TEST: n_test}


def _warn_if_a_split_is_empty(
    root: Path, trials: int, test_fraction: float, counts: Mapping[Split, int]
) -> None:
    """Rounding can leave `train` or `eval` too little to read, found only once they run:
    say so while the trials are still to be made. A fraction of 0 asks for no test trials,
    one of 1 for no training trials (a test set to score models on)."""
    asked = f"{trials} trial{'s' * (trials != 1)} at --test-fraction {test_fraction:.3g}"
    n_train = counts[Split.TRAIN]
    if n_train < MIN_TRAIN and test_fraction < 1:  # what `train` refuses
        smaller = " or a smaller --test-fraction" if trials >= MIN_TRAIN else ""
        problem = f"{asked} leave{'s' * (trials == 1)} {n_train or 'none'} to train on"
        need = f"train needs {MIN_TRAIN} or more (more --trials{smaller})"
    elif not counts[Split.TEST] and test_fraction > 0:
        problem = f"{asked} leave none to test on"
        need = "eval needs some (more --trials or a larger --test-fraction)"
    else:
        return
    warnings.warn(f"{root}: {problem}; {need}", DresslogWarning, stacklevel=3)


def _given_counts(splits: Mapping[Split | str, int]) -> dict[Split, int]:
    """Explicit trial counts per split (a sweep's), each a known split and a count >= 0."""
    counts = {}
    for split, count in splits.items():
        known = as_split(split)
        if (whole := _whole(count)) is None or whole < 0:
            raise DatasetError(f"{known} trials must be a whole number >= 0, not {count!r}")
        counts[known] = whole
    if sum(counts.values()) > MAX_TRIALS:
        raise DatasetError(f"{sum(counts.values()):,} trials: at most {MAX_TRIALS:,} are made")
    return counts


def _checked_overrides(task: Task, overrides: Mapping[str, Any] | None) -> dict[str, Any]:
    """`overrides` as a dict, if every trial can have them: no seed or task (each trial's
    own), a valid spec, recorded at `STEP_HZ`. A bad one stops here, before a manifest
    records it."""
    overrides = dict(overrides or {})
    if fixed_per_trial := sorted({"seed", "task"} & overrides.keys()):
        raise DatasetError(
            f"overrides fix spec fields for every trial, not {fixed_per_trial[0]}: each "
            "trial's seed is drawn from `seed`, and the task is generate's own argument"
        )
    try:
        fixed = TrialSpec.model_validate({"task": task, **overrides})
    except ValidationError as err:
        raise DatasetError(f"invalid {first_problem(err)}") from None
    if fixed.sim.record_hz != STEP_HZ:  # no model could train on it
        raise DatasetError(
            f"sim.record_hz {fixed.sim.record_hz}: a dataset is recorded at {STEP_HZ} Hz, "
            "the rate every model reads"
        )
    sim = overrides.get("sim")
    sim = sim.model_dump(exclude_defaults=True) if isinstance(sim, SimParams) else dict(sim or {})
    # the version said, so a folder read back draws and simulates as it was made
    overrides["sim"] = {**simulator_fields(simulator_name(fixed.sim)), **sim}
    return overrides


def _checked_range(
    drawn: RotationRange | Mapping[str, Any] | None, overrides: Mapping[str, Any]
) -> RotationRange | None:
    """`drawn` as a `RotationRange` if a valid one that no fixed rotation contradicts."""
    if drawn is None:
        return None
    if "limb_rotation" in overrides:
        raise DatasetError(
            "a rotation is fixed for every trial or drawn per trial (--rotation or "
            "--rotation-range), not both"
        )
    try:
        return RotationRange.model_validate(drawn)
    except ValidationError as err:
        raise DatasetError(f"invalid rotation range: {first_problem(err)}") from None


def _whole(value: object) -> int | None:
    """`value` as an int if it is a whole number type (numpy's too), else None."""
    try:
        return operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        return None


def _shown(value: object) -> str:
    """A request's value for a message; spec fields fixed for every trial as an option-like
    list: duration=1.0, or "none fixed (no --duration, --speed or --rotation)"."""
    if isinstance(value, Mapping):
        return (
            ", ".join(f"{k}={v}" for k, v in value.items())
            or "none fixed (no --duration, --speed or --rotation)"
        )
    return "none (no --rotation-range)" if value is None else str(value)


def _open_manifest(
    root: Path,
    task: Task,
    seed: int,
    counts: Mapping[Split, int],
    overrides: dict[str, Any],
    rotation_range: RotationRange | None,
) -> Manifest:
    """The folder's manifest if it has one (checked to be the same request), else a new one;
    either asks for `counts` (n_train, n_test, n_sweep)."""
    asked = {f"n_{split}": counts.get(split, 0) for split in Split}
    if not (root / MANIFEST_FILE).exists():
        return Manifest(
            task=task, seed=seed, overrides=overrides, rotation_range=rotation_range, **asked
        )
    manifest = load_manifest(root)
    # the other command's folder before its fields, which no option of this one sets (a
    # sweep setting's speed); a split not asked for must be empty, else its trials are lost
    for split in Split:
        made = len(manifest.split(split))
        if made and split not in counts:
            maker = "dresslog sweep" if split == Split.SWEEP else "dresslog generate"
            raise DatasetError(
                f"folder holds {made} {split} trials, made by `{maker}`; use another folder",
                path=root,
            )
    for what, have, want in (
        ("task", manifest.task, task),
        ("seed", manifest.seed, seed),
        ("fixed spec fields", manifest.overrides, overrides),
        ("rotation drawn per trial", manifest.rotation_range, rotation_range),
    ):
        if have != want:
            # a folder of another simulator version: name the option that extends it
            made_by = simulator_of(manifest.overrides.get("sim"))
            other = what == "fixed spec fields" and made_by != simulator_of(overrides.get("sim"))
            hint = f" (a folder of simulator {made_by}: --simulator {made_by})" if other else ""
            raise DatasetError(
                f"folder holds a dataset with {what} {_shown(have)}, not {_shown(want)}; "
                f"use another folder or the same options{hint}",
                path=root,
            )
    for split in Split:
        wanted, made = counts.get(split, 0), len(manifest.split(split))
        if wanted < made:
            options = "-n sets it" if split == Split.SWEEP else "--trials, --test-fraction set both"
            raise DatasetError(
                f"folder already has {made} {split} trials, more than "
                f"the {wanted} asked for ({options}); "
                "ask for at least as many or use another folder",
                path=root,
            )
    return manifest.model_copy(update=asked)


def _plan(root: Path, manifest: Manifest, recorder: Recorder, workers: int) -> list[Job]:
    """Keep the listed trials whose files check out; the next attempt at every other slot."""
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max(1, workers)) as pool:  # hashing releases the GIL
        valid = list(pool.map(lambda e: not damage(root, e, checksum=True), manifest.trials))
    manifest.trials = [e for e, ok in zip(manifest.trials, valid, strict=True) if ok]
    done = {(e.split, e.slot) for e in manifest.trials}
    tried: dict[tuple[Split, int], int] = {}
    for failure in manifest.failures:
        key = (failure.split, failure.slot)
        tried[key] = max(tried.get(key, 0), failure.attempt + 1)
    return [
        _job(root, manifest, split, slot, tried.get((split, slot), 0), recorder)
        for split in Split
        for slot in range(manifest.wanted(split))
        if (split, slot) not in done
    ]


def _job(
    root: Path, manifest: Manifest, split: Split, slot: int, attempt: int, recorder: Recorder
) -> Job:
    """The attempt's spec is the simulator's `random_spec` for the simulator's recorder; for
    another (a test's), the seed and the fixed fields on the spec's defaults."""
    seed = trial_seed(manifest.seed, split, slot, attempt)
    fixed = manifest.overrides
    if manifest.rotation_range is not None:
        fixed = {**fixed, "limb_rotation": manifest.rotation_range.draw(seed).model_dump()}
    if recorder is record_trial:
        spec = random_spec(manifest.task, seed, **fixed)
    else:
        spec = TrialSpec.model_validate({"task": manifest.task, "seed": seed, **fixed})
    return Job(str(root), split, slot, attempt, spec, recorder)


#: The names generation writes in a split folder: slot files and their temporaries.
_SLOT_NAME = re.compile(r"\.?\d{6}\.mcap((\.\d+){1,2}\.partial)?")


def _tidy(root: Path, manifest: Manifest) -> None:
    """Delete the slot files no manifest entry accounts for: a killed worker's temporary,
    a trial finished as the run was killed (we hold the folder's lock). Other files are
    the user's and stay.
    """
    listed = {root / str(e.file) for e in manifest.trials}
    for split in Split:
        for path in (root / split.value).glob("*.mcap*"):
            if _SLOT_NAME.fullmatch(path.name) and path not in listed:
                path.unlink(missing_ok=True)


def generate(
    task: Task | str,
    trials: int,
    out: str | Path,
    *,
    seed: int = 0,
    test_fraction: float = TEST_FRACTION,
    splits: Mapping[Split | str, int] | None = None,
    overrides: Mapping[str, Any] | None = None,
    rotation_range: RotationRange | Mapping[str, Any] | None = None,
    execution: Execution = LOCAL,
    progress: bool = True,
    label: str | None = None,
) -> Manifest:
    """Fill `out` with `trials` simulated trials of `task`; resume whatever is missing.

    A folder this call made is removed again if it fails before any trial is made or
    tried (a Ray cluster that does not answer).

    Args:
        task: "gown" or "shorts".
        trials: how many, split into train and test by `test_fraction`.
        out: the dataset folder, new or one to resume or extend.
        seed: the dataset's seed, from which every trial's is drawn.
        test_fraction: the share of `trials` in the test split.
        splits: explicit counts per split instead (the sweeps use ``{"sweep": 128}``).
        overrides: spec fields fixed for every trial (``duration``, ``speed``,
            ``limb_rotation``).
        rotation_range: each trial's ``limb_rotation`` drawn from it
            (``{"axis": "z", "low": -15, "high": 15}``).
        execution: where and how the trials run (workers, process pool or Ray, attempts
            per slot, the recorder); by default a local pool, one worker per core.
        progress: show a progress bar.
        label: the progress bar's name (the task by default).

    Returns:
        The folder's manifest, every trial and failure listed.

    Raises:
        DatasetError: bad arguments, a folder that is not a dataset of these settings,
            or a slot still failing after ``execution.max_attempts`` seeds (the manifest
            written up to then lists every failure).
    """
    task = task_of(task, DatasetError)
    if (misnamed := named_as_recording(out, "a dataset")) is not None:
        raise DatasetError(misnamed, path=out)
    given = Path(out)
    root = resolved(given)  # absolute: a Ray worker's working folder is not ours
    if seed < 0:
        raise DatasetError(f"--seed must be non-negative, not {seed}")
    counts = _split_counts(trials, test_fraction) if splits is None else _given_counts(splits)
    workers = execution.pool_size()
    overrides = _checked_overrides(task, overrides)
    drawn = _checked_range(rotation_range, overrides)
    with _named_as_given(root, given):  # the folder's errors, every one of them
        _check_folder(root)
        check_executor(execution.executor, execution.ray_address)
        made = [f for f in (root, *root.parents) if not os.path.lexists(f)][::-1]
        root.mkdir(parents=True, exist_ok=True)
        manifest: Manifest | None = None
        command = "dresslog sweep" if Split.SWEEP in counts else "dresslog generate"  # its folders
        try:
            with exclusive(root / LOCK_FILE, command):
                manifest = _open_manifest(root, task, seed, counts, overrides, drawn)
                for split in Split:
                    if manifest.wanted(split):
                        (root / split.value).mkdir(exist_ok=True)
                jobs = _plan(root, manifest, execution.recorder, workers)
                _tidy(root, manifest)
                manifest.save(root)
                if splits is None:  # a sweep asks for its one split by count
                    _warn_if_a_split_is_empty(given, trials, test_fraction, counts)
                if jobs:
                    label = (label or manifest.task.value) if progress else None
                    _run(root, manifest, jobs, execution, label)
        except BaseException:
            if made and (manifest is None or not (manifest.trials or manifest.failures)):
                _remove_new_folder(root, made)
            raise
    return manifest


def _remove_new_folder(root: Path, made: list[Path]) -> None:
    """Remove a dataset folder this run made, which holds no trial: its manifest, lock and
    empty split folders, then the folders made for it. Anything else in it stays."""
    for name in (MANIFEST_FILE, LOCK_FILE):
        (root / name).unlink(missing_ok=True)
    for split in Split:
        with contextlib.suppress(OSError):
            (root / split.value).rmdir()
    remove_folders(made)


@contextmanager
def _named_as_given(root: Path, given: Path) -> Iterator[None]:
    """Errors about the folder name it as the user wrote it (`given`), as every other
    command does, not as its absolute path (`root`), which generate works on."""
    try:
        yield
    except DresslogError as err:
        if err.path is not None and err.path.is_relative_to(root):  # a trial's file too
            err.path = given / err.path.relative_to(root)
        raise
    except OSError as err:  # a full disk, a read-only folder: the file inside it
        if isinstance(err.filename, str) and Path(err.filename).is_relative_to(root):
            err.filename = str(given / Path(err.filename).relative_to(root))
        raise


@contextmanager
def _stop_at_safe_points() -> Iterator[threading.Event]:
    """Ctrl-C, SIGTERM or SIGHUP in the main process sets the event the loop checks;
    KeyboardInterrupt is raised on leaving, after the bookkeeping. Raised mid-loop, it
    dropped a trial a worker had just reported (its file was then removed as unaccounted
    for).
    """
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():  # signals need the main one
        yield stop
        return
    stops = (signal.SIGINT, *stop_signals())
    previous = {s: signal.signal(s, lambda signum, frame: stop.set()) for s in stops}
    try:
        yield stop
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
    if stop.is_set():
        raise KeyboardInterrupt


def _run(
    root: Path,
    manifest: Manifest,
    jobs: list[Job],
    execution: Execution,
    label: str | None,
) -> None:
    """Run the jobs, retrying failed slots with fresh seeds; a progress bar named `label`."""
    from tqdm import tqdm

    max_attempts = execution.max_attempts
    workers = min(execution.pool_size(), len(jobs))
    executor = make_executor(execution.executor, workers, execution.ray_address)
    given_up: list[Entry] = []
    bar = tqdm(total=len(jobs), unit="trial", desc=label, disable=label is None)
    saved = time.monotonic()
    with _stop_at_safe_points() as stop:
        try:
            for job in jobs:
                executor.submit(job)
            while executor.pending() and not stop.is_set():
                for entry in executor.done(timeout=POLL_S):
                    if entry.status == Status.OK:
                        manifest.trials.append(entry)
                        bar.update()
                        continue
                    manifest.failures.append(entry)
                    if entry.attempt + 1 >= max_attempts:
                        given_up.append(entry)
                        bar.update()
                    else:
                        retry = entry.attempt + 1
                        job = _job(root, manifest, entry.split, entry.slot, retry, jobs[0].recorder)
                        executor.submit(job)
                    bar.set_postfix(failed=len(manifest.failures))
                if time.monotonic() - saved > SAVE_EVERY_S:
                    manifest.save(root)
                    saved = time.monotonic()
        except BrokenProcessPool:  # a worker was killed: by the same signal as us, or alone
            if not stop.wait(timeout=1.0):
                raise DatasetError(
                    "a worker process died (killed, or out of memory?); run the same "
                    "command again to resume",
                    path=root,
                ) from None
        finally:
            bar.close()
            try:  # trials finished while stopping (after an interrupt) are kept, not redone
                for entry in executor.shutdown():
                    (manifest.trials if entry.status == Status.OK else manifest.failures).append(
                        entry
                    )
            finally:
                manifest.save(root)
                _tidy(root, manifest)
    if given_up:
        last = given_up[-1]
        raise DatasetError(
            f"{len(given_up)} slot(s) failed {max_attempts} seeds in a row "
            f"(last: {last.split}/{last.slot:06d}: {last.failure}); "
            f"every failure is listed in {MANIFEST_FILE}",
            path=root,
        )
