"""A dataset as training tensors: every trial decoded once, cached beside the data.

``load_dataset(root, *, workers=None, progress=True)`` returns `DatasetArrays`
(phi (S, T, 9) and force maps (S, T, N), float32, zero-padded to the longest trial, with
lengths, outcomes, split and files). The first call decodes the MCAP files (in parallel, each
checked against its sha256) and writes ``root/.cache/arrays-<HASH>.npz`` (the manifest
hash's first 16 hex digits); later calls only read that file, so no epoch ever waits on
MCAP decoding. The cache is keyed by the manifest's content hash (a regenerated trial
makes a new cache) and holds each trial file's modification time, so a trial rewritten
in place is decoded and checked against its sha256 again (a copied folder, its times
new, is decoded once more). It is read with ``allow_pickle=False``: a planted cache file
cannot run code.
"""

from __future__ import annotations

import contextlib
import functools
import os
import zipfile
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from tokenize import TokenError

import numpy as np

from dresslog.dataset.manifest import (
    Manifest,
    Split,
    as_split,
    check_files,
    damaged_error,
    load_manifest,
    remaking,
    warn_if_incomplete,
)
from dresslog.errors import DatasetError, TrialFormatError
from dresslog.io.files import atomic_path, sha256_file
from dresslog.spec import Outcome, Task
from dresslog.stops import deferred_in_children, leave_stops_to_the_parent
from dresslog.trial import STEP_HZ, padded

CACHE_DIR = ".cache"
CACHE_VERSION = 2
_FIELDS = ("phi", "forces", "lengths", "outcomes", "split", "files", "mtimes", "info")


@dataclass(frozen=True)
class DatasetArrays:
    """Every trial of a dataset, padded to a common length T; row i is manifest trial i."""

    task: Task
    manifest_sha256: str
    phi: np.ndarray  # (S, T, 9) float32
    forces: np.ndarray  # (S, T, N) float32
    lengths: np.ndarray  # (S,) int64
    outcomes: np.ndarray  # (S,) str
    split: np.ndarray  # (S,) str
    files: np.ndarray  # (S,) str, relative to the dataset folder

    def __len__(self) -> int:
        return len(self.lengths)

    @property
    def n_points(self) -> int:
        """N: the limb points of every force map, the model's output size."""
        return int(self.forces.shape[2])

    def rows(
        self, split: Split | str | None = None, outcome: Outcome | str | None = None
    ) -> np.ndarray:
        """Indices of the trials in `split` (all if None) with `outcome` (any if None);
        a `DatasetError` names the splits or outcomes for a value not among them."""
        keep = np.ones(len(self), bool)
        if split is not None:
            keep &= self.split == as_split(split).value
        if outcome is not None:
            if outcome not in set(Outcome):  # else a typo silently selects nothing
                raise DatasetError(f"outcome {outcome!r} is not one of {', '.join(Outcome)}")
            keep &= self.outcomes == Outcome(outcome).value
        return np.flatnonzero(keep)

    def sequences(self, rows: Sequence[int] | np.ndarray) -> list[np.ndarray]:
        """phi of each chosen trial, unpadded (views, no copies)."""
        return [self.phi[i, : self.lengths[i]] for i in rows]

    def force_maps(self, rows: Sequence[int] | np.ndarray) -> list[np.ndarray]:
        """Ground-truth force maps of each chosen trial, unpadded (views)."""
        return [self.forces[i, : self.lengths[i]] for i in rows]


def cache_path(root: str | Path, manifest: Manifest) -> Path:
    """Where the arrays of this manifest's content are cached."""
    return Path(root) / CACHE_DIR / f"arrays-{manifest.content_hash()[:16]}.npz"


def _decode(args: tuple[str, str, str, str]) -> tuple[np.ndarray, np.ndarray]:
    """One trial's (phi (T, 9), forces (T, N)) on the steps both have; runs in a worker."""
    from dresslog.io.reader import TrialReader

    path, name, sha256, task = args
    root = Path(path).parents[1]
    if sha256_file(path) != sha256:
        raise damaged_error(root, name, "changed")
    try:
        with TrialReader(path) as reader:
            recorded = reader.metadata.task.value
            phi = reader.measurements
            truth = reader.force_map
    except TrialFormatError as err:
        raise DatasetError(f"trial {name} is unreadable: {err.message}", path=root) from None
    if recorded != task:  # a model trained on it would carry the wrong task
        raise DatasetError(
            f"trial {name} is a {recorded} trial in a {task} dataset (manifest.json)", path=root
        )
    if truth is None:
        raise DatasetError(f"trial {name} has no ground-truth force map", path=root)
    _, pi, fi = np.intersect1d(phi.t_ns, truth.t_ns, return_indices=True)
    if len(pi) != len(phi):  # the steps either side of a hole would be read as consecutive
        lacking = np.setdiff1d(phi.t_ns, truth.t_ns)
        at = (lacking[0] - phi.t_ns[0]) / 1e9
        raise DatasetError(
            f"trial {name} has no ground-truth force map on {len(lacking)} of its {len(phi)} "
            f"steps (the first at {at:.3f} s); {remaking(name)} to re-create it",
            path=root,
        )
    return phi.phi[pi].astype(np.float32), truth.forces[fi].astype(np.float32)


def decoding_pool(workers: int) -> ProcessPoolExecutor:
    """Spawned workers that leave Ctrl-C and hang-up to this process, which stops them;
    start them under `deferred_in_children`."""
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    return ProcessPoolExecutor(workers, mp_context=context, initializer=leave_stops_to_the_parent)


def _build(root: Path, manifest: Manifest, workers: int, progress: bool) -> dict[str, np.ndarray]:
    from tqdm import tqdm

    entries = manifest.trials
    mtimes = _mtimes(root, manifest)  # before decoding: a file changed meanwhile is stale
    task = manifest.task.value
    jobs = [(str(root / str(e.file)), str(e.file), str(e.sha256), task) for e in entries]
    bar = functools.partial(
        tqdm, total=len(jobs), unit="trial", desc="decoding", disable=not progress
    )
    if workers > 1 and len(jobs) > 1:
        pool = decoding_pool(min(workers, len(jobs)))
        try:
            with deferred_in_children():  # the workers start as the jobs are submitted
                results = pool.map(_decode, jobs, chunksize=4)
            decoded = list(bar(results))
        finally:  # stopped: the trials not begun are dropped, not decoded first
            pool.shutdown(cancel_futures=True)
    else:
        decoded = list(bar(map(_decode, jobs)))
    widths = {f.shape[1] for _, f in decoded}
    if len(widths) != 1:
        raise DatasetError(f"trials have different limb point counts {sorted(widths)}", path=root)
    lengths = np.array([len(p) for p, _ in decoded], np.int64)
    phi = padded([p for p, _ in decoded])
    forces = padded([f for _, f in decoded])
    return {
        "phi": phi,
        "forces": forces,
        "lengths": lengths,
        "outcomes": np.array([e.outcome.value for e in entries]),
        "split": np.array([e.split.value for e in entries]),
        "files": np.array([str(e.file) for e in entries]),
        "mtimes": mtimes,
        "info": np.array(_key(manifest)),
    }


def _write(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Uncompressed (force maps are read at disk speed), written atomically."""
    path.parent.mkdir(exist_ok=True)
    with atomic_path(path) as tmp, tmp.open("wb") as stream:
        np.savez(stream, allow_pickle=False, **arrays)
    for old in path.parent.glob("arrays-*.npz"):
        if old != path:
            old.unlink(missing_ok=True)


def _read(path: Path, manifest: Manifest) -> dict[str, np.ndarray] | None:
    """The cached arrays if the file is whole and made from this manifest, else None."""
    try:  # opened here: numpy does not close a file it opened that is a broken zip
        with path.open("rb") as stream:
            loaded = np.load(stream, allow_pickle=False)
            if not isinstance(loaded, np.lib.npyio.NpzFile):
                return None  # one array (a .npy), not the archive written here
            with loaded as npz:
                arrays = {k: npz[k] for k in _FIELDS}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, SyntaxError, TokenError):
        return None  # numpy parses a damaged array header as Python: it may fail as such
    info = arrays["info"]
    if info.shape != (3,) or list(info) != _key(manifest):
        return None
    if not np.array_equal(arrays["mtimes"], _mtimes(path.parents[1], manifest)):
        return None  # a trial was rewritten in place since: decode (and check) it again
    return arrays


def _key(manifest: Manifest) -> list[str]:
    """What a cache file's `info` holds: the cache version, the task, the manifest hash."""
    return [str(CACHE_VERSION), manifest.task.value, manifest.content_hash()]


def _mtimes(root: Path, manifest: Manifest) -> np.ndarray:
    """Each trial file's modification time (ns), in manifest order."""
    return np.array([(root / str(e.file)).stat().st_mtime_ns for e in manifest.trials], np.int64)


def load_dataset(
    root: str | Path,
    *,
    workers: int | None = None,
    progress: bool = True,
) -> DatasetArrays:
    """All trials of the dataset at `root` as arrays, from the cache when it is current.

    Args:
        root: the dataset folder.
        workers: processes decoding the trials the cache lacks; None: one per core.
        progress: show a progress bar while decoding.

    Returns:
        Every trial's phi and force maps, padded, with lengths, outcomes, splits, files.

    Raises:
        DatasetError: one line naming the folder and the trial, for a folder without a
            manifest, a manifest with no trials, a trial recorded at another rate than
            the models' `STEP_HZ`, and a missing, truncated, modified or unreadable trial.
    """
    root = Path(root)
    manifest = load_manifest(root)
    if not manifest.trials:
        raise DatasetError("the manifest lists no completed trials", path=root)
    for entry in manifest.trials:  # models read STEP_HZ steps; generate makes no other
        if (hz := entry.spec.sim.record_hz) != STEP_HZ:
            raise DatasetError(
                f"trial {entry.file} is recorded at {hz} Hz; models read {STEP_HZ} Hz steps",
                path=root,
            )
    warn_if_incomplete(root, manifest)
    check_files(root, manifest)
    path = cache_path(root, manifest)
    arrays = _read(path, manifest) if path.exists() else None
    if arrays is None:
        arrays = _build(root, manifest, workers or os.cpu_count() or 1, progress)
        with contextlib.suppress(OSError):  # a read-only dataset loads, just uncached
            _write(path, arrays)
    return DatasetArrays(
        task=manifest.task,
        manifest_sha256=manifest.content_hash(),
        **{k: arrays[k] for k in _FIELDS if k not in ("info", "mtimes")},
    )
