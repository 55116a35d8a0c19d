"""A dataset folder as a LeRobot dataset (format v3.0), written with pyarrow alone.

LeRobot pins torch and rerun-sdk below the versions dresslog runs on, so it cannot be a
dependency; its format is plain Parquet and JSON, documented by the project:

- `meta/info.json`: `codebase_version` "v3.0", `fps`, `features` (dtype, shape, names of
  every column), totals, `splits`, `chunks_size`, the `data_path` template;
- `meta/stats.json`: min, max, mean, std and count of every numeric feature;
- `meta/tasks.parquet`: `task_index` and its `task` text;
- `meta/episodes/chunk-000/file-000.parquet`: one row per episode: its length, its data
  file (`data/chunk_index`, `data/file_index`) and its rows there (`dataset_from_index`,
  `dataset_to_index`, over the whole dataset), and its own stats (`stats/<feature>/...`);
- `data/chunk-CCC/file-FFF.parquet`: one row per frame, every episode's frames in turn,
  with `timestamp`, `frame_index`, `episode_index`, `index` and `task_index`.

One episode per trial, at the trials' 100 Hz: the wrench, twist and pose the gripper
measured (`observation.*`), the ground-truth force map and its contact map (Eq. 1), a
model's estimate when every trial has one, and the trial's outcome. Episodes follow the
manifest's splits (train, then test, then sweep), which `splits` names.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.dataset.manifest import Entry, Split, check_files, load_manifest
from dresslog.errors import DatasetError
from dresslog.io.files import check_output_folder, named_as_recording, temporary_path
from dresslog.io.reader import TrialReader
from dresslog.model.postprocess import contact_targets
from dresslog.spec import Outcome, Task
from dresslog.trial import STEP_HZ

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000
#: A data file is closed once it holds this much (LeRobot's default), and the next begun.
DATA_FILE_MB = 100
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_FILE = "meta/episodes/chunk-000/file-000.parquet"
#: The task text of each dresslog task, in `meta/tasks.parquet`.
TASKS = {
    Task.GOWN: "pull the gown's sleeve up the arm",
    Task.SHORTS: "pull the shorts up the leg",
}
_AXES = ["x", "y", "z"]
_WRENCH = [f"force.{a}" for a in _AXES] + [f"torque.{a}" for a in _AXES]
_TWIST = [f"linear.{a}" for a in _AXES] + [f"angular.{a}" for a in _AXES]
_POSE = [f"position.{a}" for a in _AXES] + [f"orientation.{a}" for a in [*_AXES, "w"]]


@dataclass(frozen=True)
class Episode:
    """One trial's frames: feature name -> (T, D) array, and its outcome."""

    frames: dict[str, np.ndarray]
    outcome: Outcome
    file: str
    split: Split

    def __len__(self) -> int:
        return len(self.frames["observation.wrench"])


def features(n_points: int, estimate: bool) -> dict[str, dict[str, Any]]:
    """`info.json`'s features: every column of the data files."""

    def vector(names: list[str] | None, width: int) -> dict[str, Any]:
        return {"dtype": "float32", "shape": [width], "names": names}

    def index() -> dict[str, Any]:
        return {"dtype": "int64", "shape": [1], "names": None}

    out = {
        "observation.wrench": vector(_WRENCH, 6),
        "observation.twist": vector(_TWIST, 6),
        "observation.pose": vector(_POSE, 7),
        "force_map": vector(None, n_points),
        "contact_map": vector(None, n_points),
    }
    if estimate:
        out |= {"force_map.estimate": vector(None, n_points)}
        out |= {"contact_map.estimate": vector(None, n_points)}
    out["outcome"] = {"dtype": "string", "shape": [1], "names": None}
    out["timestamp"] = {"dtype": "float32", "shape": [1], "names": None}
    out |= {name: index() for name in ("frame_index", "episode_index", "index", "task_index")}
    return out


def read_episode(root: Path, entry: Entry, estimate: bool) -> Episode:
    """A trial's frames at its model steps (where wrench and twist are both sampled)."""
    path = root / str(entry.file)
    with TrialReader(path) as reader:
        wrench, twist, pose, truth = reader.wrench, reader.twist, reader.pose, reader.force_map
        guess = reader.estimate if estimate else None
        outcome = reader.metadata.outcome
    if pose is None or truth is None:
        missing = "/ee/pose" if pose is None else "/limb/force_map"
        raise DatasetError(f"{entry.file} has no {missing}; an episode needs it", path=root)
    t_ns = np.intersect1d(wrench.t_ns, twist.t_ns)

    def at(times: np.ndarray, values: np.ndarray, what: str) -> np.ndarray:
        where = np.searchsorted(times, t_ns).clip(max=len(times) - 1)
        if not np.array_equal(times[where], t_ns):
            raise DatasetError(f"{entry.file}: {what} is not sampled at every step", path=root)
        return np.asarray(values, np.float32)[where]

    frames = {
        "observation.wrench": at(wrench.t_ns, wrench.values, "/ee/wrench"),
        "observation.twist": at(twist.t_ns, twist.values, "/ee/twist"),
        "observation.pose": at(pose.t_ns, pose.values, "/ee/pose"),
        "force_map": at(truth.t_ns, truth.forces, "/limb/force_map"),
    }
    frames["contact_map"] = contact_targets(frames["force_map"])
    if guess is not None:
        frames["force_map.estimate"] = at(guess.t_ns, guess.forces, "the estimate")
        frames["contact_map.estimate"] = at(guess.t_ns, guess.contact, "the estimate's contact")
    return Episode(frames, outcome, str(entry.file), entry.split)


def _stats(values: np.ndarray) -> dict[str, list[float] | list[int]]:
    """LeRobot's per-feature statistics, over frames (axis 0)."""
    v = values.astype(np.float64)
    return {
        "min": v.min(axis=0).tolist(),
        "max": v.max(axis=0).tolist(),
        "mean": v.mean(axis=0).tolist(),
        "std": v.std(axis=0).tolist(),
        "count": [len(v)],
    }


def _merged(parts: list[dict[str, list]]) -> dict[str, list]:
    """Whole-dataset statistics from per-episode ones (pooled mean and variance)."""
    counts = np.array([p["count"][0] for p in parts], np.float64)[:, None]
    means = np.array([p["mean"] for p in parts])
    mean = (means * counts).sum(axis=0) / counts.sum()
    var = ((np.array([p["std"] for p in parts]) ** 2 + (means - mean) ** 2) * counts).sum(
        axis=0
    ) / counts.sum()
    return {
        "min": np.min([p["min"] for p in parts], axis=0).tolist(),
        "max": np.max([p["max"] for p in parts], axis=0).tolist(),
        "mean": mean.tolist(),
        "std": np.sqrt(var).tolist(),
        "count": [int(counts.sum())],
    }


def _ordered(entries: list[Entry]) -> list[Entry]:
    order = {split: i for i, split in enumerate(Split)}
    return sorted(entries, key=lambda e: (order[e.split], e.slot))


class _DataFiles:
    """Frames appended episode by episode, a new file begun past `DATA_FILE_MB`."""

    def __init__(self, root: Path, schema: Any) -> None:
        self.root, self.schema = root, schema
        self.number = 0  # files begun
        self._writer: Any = None
        self._path: Path | None = None

    def where(self) -> tuple[int, int]:
        """(chunk index, file index) of the file the next episode goes to."""
        if self._path is not None and self._path.stat().st_size > DATA_FILE_MB * 2**20:
            self.close()
            self.number += 1
        return divmod(self.number, CHUNKS_SIZE)

    def append(self, table: Any) -> None:
        import pyarrow.parquet as pq

        if self._writer is None:
            chunk, file = divmod(self.number, CHUNKS_SIZE)
            self._path = self.root / DATA_PATH.format(chunk_index=chunk, file_index=file)
            self._path.parent.mkdir(parents=True, exist_ok=True)
            self._writer = pq.ParquetWriter(self._path, self.schema, compression="zstd")
        self._writer.write_table(table)

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
        self._writer = None


def _frame_table(episode: Episode, names: dict[str, dict], first: int, number: int,
                 task: int) -> Any:  # fmt: skip
    import pyarrow as pa

    n = len(episode)
    columns: dict[str, Any] = {}
    for name, feature in names.items():
        if name in episode.frames:
            values = episode.frames[name]
            columns[name] = pa.FixedSizeListArray.from_arrays(
                pa.array(values.ravel(), pa.float32()), feature["shape"][0]
            )
    columns["outcome"] = pa.array([episode.outcome.value] * n, pa.string())
    columns["timestamp"] = pa.array(np.arange(n, dtype=np.float32) / np.float32(STEP_HZ))
    columns["frame_index"] = pa.array(np.arange(n, dtype=np.int64))
    columns["episode_index"] = pa.array(np.full(n, number, np.int64))
    columns["index"] = pa.array(np.arange(first, first + n, dtype=np.int64))
    columns["task_index"] = pa.array(np.full(n, task, np.int64))
    return pa.table(columns)


def export_lerobot(data: str | Path, out: str | Path, *, overwrite: bool = False) -> dict:
    """Write dataset folder `data` as a LeRobot v3.0 dataset at `out`; returns its info.

    The dataset is written into a hidden folder beside `out` and renamed into place
    whole, so an interrupted export leaves no half dataset under the name.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    root, out = Path(data), Path(out)
    manifest = load_manifest(root)
    check_files(root, manifest)
    _check_out(out, root, overwrite)
    entries = _ordered(manifest.trials)
    if not entries:
        raise DatasetError("holds no trials to export", path=root)
    estimate = all(_has_estimate(root / str(e.file)) for e in entries)
    tmp = temporary_path(out)
    try:
        first = read_episode(root, entries[0], estimate)
        n_points = first.frames["force_map"].shape[1]
        feats = features(n_points, estimate)
        schema = _schema(feats)
        files = _DataFiles(tmp, schema)
        rows, stats, total = [], [], 0
        task = TASKS[manifest.task]
        for number, entry in enumerate(entries):
            episode = first if number == 0 else read_episode(root, entry, estimate)
            if episode.frames["force_map"].shape[1] != n_points:
                raise DatasetError(f"{entry.file}: force maps of another size", path=root)
            chunk, file = files.where()
            files.append(_frame_table(episode, feats, total, number, 0).select(schema.names))
            own = {k: _stats(v) for k, v in episode.frames.items()}
            stats.append(own)
            rows.append(_episode_row(episode, number, (chunk, file), total, own, task))
            total += len(episode)
        files.close()
        (tmp / "meta/episodes/chunk-000").mkdir(parents=True)
        pq.write_table(pa.Table.from_pylist(rows), tmp / EPISODES_FILE, compression="zstd")
        tasks = pa.table({"task_index": pa.array([0], pa.int64()), "task": [task]})
        pq.write_table(tasks, tmp / "meta/tasks.parquet")
        merged = {k: _merged([s[k] for s in stats]) for k in stats[0]}
        merged |= _index_stats(rows, total)
        info = _info(manifest.task, feats, entries, total, files.number + 1)
        _write_json(tmp / "meta/stats.json", merged)
        _write_json(tmp / "meta/info.json", info)
        _put_in_place(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return info


def _has_estimate(path: Path) -> bool:
    with TrialReader(path) as reader:
        return reader.has("/limb/force_map/estimate")


def _schema(feats: dict[str, dict[str, Any]]) -> Any:
    import pyarrow as pa

    fields = []
    for name, f in feats.items():
        if f["dtype"] == "float32" and name != "timestamp":
            fields.append(pa.field(name, pa.list_(pa.float32(), f["shape"][0])))
        elif f["dtype"] == "string":
            fields.append(pa.field(name, pa.string()))
        else:
            fields.append(pa.field(name, pa.float32() if name == "timestamp" else pa.int64()))
    return pa.schema(fields)


def _episode_row(episode: Episode, number: int, where: tuple[int, int], first: int,
                 stats: dict[str, dict[str, list]], task: str) -> dict[str, Any]:  # fmt: skip
    chunk, file = where
    row: dict[str, Any] = {
        "episode_index": number,
        "tasks": [task],
        "length": len(episode),
        "data/chunk_index": chunk,
        "data/file_index": file,
        "dataset_from_index": first,
        "dataset_to_index": first + len(episode),
        "meta/episodes/chunk_index": 0,
        "meta/episodes/file_index": 0,
        "outcome": episode.outcome.value,
        "split": episode.split.value,
        "source": episode.file,
    }
    for name, values in stats.items():
        for stat, value in values.items():
            row[f"stats/{name}/{stat}"] = value
    return row


def _index_stats(rows: list[dict[str, Any]], total: int) -> dict[str, dict[str, list]]:
    """Statistics of the index columns, as LeRobot keeps them too."""
    frame = np.concatenate([np.arange(r["length"]) for r in rows])
    episode = np.concatenate([np.full(r["length"], r["episode_index"]) for r in rows])
    return {
        "timestamp": _stats(frame[:, None] / STEP_HZ),
        "frame_index": _stats(frame[:, None]),
        "episode_index": _stats(episode[:, None]),
        "index": _stats(np.arange(total)[:, None]),
        "task_index": _stats(np.zeros((total, 1))),
    }


def _splits(entries: list[Entry]) -> dict[str, str]:
    out: dict[str, str] = {}
    for i, entry in enumerate(entries):
        start = out.get(entry.split.value, f"{i}:").split(":")[0]
        out[entry.split.value] = f"{start}:{i + 1}"
    return out


def _info(task: Task, feats: dict, entries: list[Entry], total: int, files: int) -> dict:
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": "dresslog-simulated-gripper",
        "total_episodes": len(entries),
        "total_frames": total,
        "total_tasks": 1,
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILE_MB,
        "video_files_size_in_mb": 200,
        "fps": STEP_HZ,
        "splits": _splits(entries),
        "data_path": DATA_PATH,
        "video_path": None,
        "features": feats,
        "dresslog": {"task": task.value, "data_files": files},
    }


def _write_json(path: Path, value: object) -> None:
    path.write_text(json.dumps(value, indent=2) + "\n", encoding="utf-8")


def _check_out(out: Path, root: Path, overwrite: bool) -> None:
    """Fail before any work if `out` cannot take the dataset."""
    if problem := named_as_recording(out, "a LeRobot dataset"):
        raise DatasetError(problem, path=out)
    check_output_folder(out.parent if not out.exists() else out, "the LeRobot dataset")
    if out.resolve().is_relative_to(root.resolve()):
        raise DatasetError("is inside the dataset being exported; write it elsewhere", path=out)
    if out.exists() or out.is_symlink():
        if not (out / "meta" / "info.json").is_file():
            raise DatasetError("exists and is not a LeRobot dataset; give a new folder", path=out)
        if not overwrite:
            raise DatasetError("exists; pass --overwrite to replace it", path=out)


def _put_in_place(tmp: Path, out: Path) -> None:
    """Rename the finished folder to `out`, the earlier export (if any) removed after."""
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists():
        tmp.rename(out)
        return
    old = out.with_name(f".{out.name}.{os.getpid()}.old")
    out.rename(old)
    tmp.rename(out)
    shutil.rmtree(old, ignore_errors=True)
