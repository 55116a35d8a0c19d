"""`dresslog export DATA --format lerobot`: a dataset folder as a LeRobot v3.0 dataset,
read back with pyarrow against LeRobot's documented layout and with Rerun's own loader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from dresslog.cli.main import main
from dresslog.dataset.executors import Execution, Recorder
from dresslog.dataset.generate import generate
from dresslog.io import TrialReader, TrialWriter
from dresslog.model.postprocess import CONTACT_LEVEL
from dresslog.spec import TrialSpec
from tests.conftest import write_synthetic_trial

#: What LeRobot v3.0's files hold, by its documentation and its reader.
LAYOUT = [
    "data/chunk-000/file-000.parquet",
    "meta/episodes/chunk-000/file-000.parquet",
    "meta/info.json",
    "meta/stats.json",
    "meta/tasks.parquet",
]


class _Result:
    outcome = "dressed"

    def __init__(self, steps: int) -> None:
        self.steps = steps


def _steps(spec: TrialSpec) -> int:
    return 20 + spec.seed % 7  # episodes of different lengths


def synthetic_record(spec: TrialSpec, path: Path, *, overwrite: bool = False) -> _Result:
    """A recorder without pybullet: every channel, from a seeded generator."""
    write_synthetic_trial(Path(path), spec.task, steps=_steps(spec))
    return _Result(_steps(spec))


def record_with_estimate(spec: TrialSpec, path: Path, *, overwrite: bool = False) -> _Result:
    """A synthetic trial with a model's estimate, as `infer --mcap-out` leaves one."""
    from dresslog.replay.mcap_sink import copy_trial

    tmp = Path(path).with_suffix(".raw.mcap")
    write_synthetic_trial(tmp, spec.task, steps=_steps(spec))
    with TrialReader(tmp) as reader:
        trial = reader.read()
    tmp.unlink()
    fm = trial.force_map
    assert fm is not None
    with TrialWriter(path, trial.metadata, overwrite=overwrite) as writer:
        copy_trial(writer, trial)
        writer.write_force_map(fm.t_ns, fm.forces * 0.5, fm.forces - 0.1, estimate=True)
    return _Result(_steps(spec))


def record_without_pose(spec: TrialSpec, path: Path, *, overwrite: bool = False) -> _Result:
    """The second trial has no pose channel, which an episode needs."""
    if spec.seed % 2:
        return synthetic_record(spec, path, overwrite=overwrite)
    tmp = Path(path).with_suffix(".raw.mcap")
    write_synthetic_trial(tmp, spec.task, steps=_steps(spec))
    with TrialReader(tmp) as reader:
        trial = reader.read()
    tmp.unlink()
    with TrialWriter(path, trial.metadata, overwrite=overwrite) as writer:
        writer.write_wrench(trial.wrench.t_ns, trial.wrench.values)
        writer.write_twist(trial.twist.t_ns, trial.twist.values)
    return _Result(_steps(spec))


def _dataset(folder: Path, recorder: Recorder, trials: int = 3) -> Path:
    generate("gown", trials, folder, execution=Execution(workers=1, recorder=recorder),
             test_fraction=0.34, progress=False)  # fmt: skip
    return folder


def _export(data: Path, out: Path, *more: str) -> tuple[int, str]:
    args = ["export", str(data), "--format", "lerobot", "-o", str(out), *more]
    result = CliRunner().invoke(main, args)
    return result.exit_code, result.output


def test_export_writes_lerobot_v3_as_documented(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    data, out = _dataset(tmp_path / "data", synthetic_record), tmp_path / "lerobot"
    code, output = _export(data, out)
    assert code == 0, output
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()) == LAYOUT
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 100
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["chunks_size"] == 1000 and info["total_tasks"] == 1
    frames = pq.read_table(out / LAYOUT[0])
    # every column is a feature, of the dtype and shape info.json gives it
    assert frames.schema.names == list(info["features"])
    for name, feature in info["features"].items():
        arrow = frames.schema.field(name).type
        width = getattr(arrow, "list_size", 1)
        kind = str(getattr(arrow, "value_type", arrow)).replace("float", "float32")
        assert [width] == feature["shape"], name
        assert kind.replace("float3232", "float32") == feature["dtype"], name
    assert "force_map.estimate" not in info["features"]  # no trial has one
    episodes = pq.read_table(out / LAYOUT[1]).to_pylist()
    assert info["total_episodes"] == len(episodes) == 3
    assert info["total_frames"] == frames.num_rows == sum(e["length"] for e in episodes)
    assert info["splits"] == {"train": "0:2", "test": "2:3"}
    assert [e["split"] for e in episodes] == ["train", "train", "test"]
    columns = frames.to_pydict()
    np.testing.assert_array_equal(columns["index"], np.arange(frames.num_rows))
    for episode in episodes:
        rows = slice(episode["dataset_from_index"], episode["dataset_to_index"])
        assert set(columns["episode_index"][rows]) == {episode["episode_index"]}
        np.testing.assert_array_equal(columns["frame_index"][rows], np.arange(episode["length"]))
        np.testing.assert_allclose(
            columns["timestamp"][rows], np.arange(episode["length"]) / 100, rtol=1e-6
        )
        with TrialReader(data / episode["source"]) as reader:
            wrench, truth, pose = reader.wrench, reader.force_map, reader.pose
            outcome = reader.metadata.outcome.value
        np.testing.assert_array_equal(
            columns["observation.wrench"][rows], wrench.values.astype(np.float32)
        )
        np.testing.assert_array_equal(
            columns["observation.pose"][rows], pose.values.astype(np.float32)
        )
        np.testing.assert_array_equal(columns["force_map"][rows], truth.forces)
        contact = np.where(truth.forces > 0, CONTACT_LEVEL, -CONTACT_LEVEL).astype(np.float32)
        np.testing.assert_array_equal(np.array(columns["contact_map"][rows], np.float32), contact)
        assert set(columns["outcome"][rows]) == {outcome} == {episode["outcome"]}
        assert episode["tasks"] == [pq.read_table(out / LAYOUT[4]).to_pydict()["task"][0]]
    stats = json.loads((out / "meta/stats.json").read_text())
    wrench_all = np.array(columns["observation.wrench"], np.float64)
    np.testing.assert_allclose(stats["observation.wrench"]["mean"], wrench_all.mean(axis=0))
    np.testing.assert_allclose(stats["observation.wrench"]["std"], wrench_all.std(axis=0))
    np.testing.assert_allclose(stats["force_map"]["max"], np.max(columns["force_map"], axis=0))
    assert stats["observation.wrench"]["count"] == [frames.num_rows]


def test_rerun_reads_the_export_with_its_own_lerobot_loader(tmp_path: Path) -> None:
    import pyarrow.parquet as pq
    from rerun.experimental import LeRobotReader

    data, out = _dataset(tmp_path / "data", record_with_estimate), tmp_path / "lerobot"
    code, output = _export(data, out)
    assert code == 0, output
    info = json.loads((out / "meta/info.json").read_text())
    assert {"force_map.estimate", "contact_map.estimate"} <= set(info["features"])
    sources = pq.read_table(out / LAYOUT[1]).to_pydict()["source"]  # each episode's trial
    reader = LeRobotReader(out)
    assert reader.version == "v3" and reader.episodes() == [0, 1, 2]
    for episode in reader.episodes():
        values: dict[str, list] = {}
        for chunk in reader.stream(episode):
            batch = chunk.to_record_batch()
            for name in ("Scalars:scalars", "TextDocument:text"):
                if name in batch.schema.names:
                    rows = [v for v in batch.column(name).to_pylist() if v is not None]
                    values.setdefault(chunk.entity_path, []).extend(rows)
        with TrialReader(data / sources[episode]) as trial:
            wrench, estimate = trial.wrench.values, trial.estimate.forces
        np.testing.assert_allclose(values["/observation.wrench"], wrench, rtol=1e-6)
        np.testing.assert_allclose(values["/force_map.estimate"], estimate, rtol=1e-6)
        assert values["/outcome"][0] == ["dressed"]


def test_export_is_atomic_and_refuses_what_it_would_destroy(tmp_path: Path) -> None:
    bad, out = _dataset(tmp_path / "bad", record_without_pose), tmp_path / "lerobot"
    code, output = _export(bad, out)
    assert code == 1 and output.startswith("Error: ") and output.count("\n") == 1, output
    assert "has no /ee/pose" in output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad"]  # no half dataset, no temporary
    good = _dataset(tmp_path / "good", synthetic_record)
    assert _export(good, out)[0] == 0
    code, output = _export(good, out)
    assert code == 1 and "exists; pass --overwrite" in output
    assert _export(good, out, "--overwrite")[0] == 0
    other = tmp_path / "notes"
    other.mkdir()
    (other / "keep.txt").write_text("mine")
    code, output = _export(good, other, "--overwrite")
    assert code == 1 and "not a LeRobot dataset" in output and (other / "keep.txt").exists()
    code, output = _export(tmp_path / "missing", tmp_path / "x")
    assert code == 1 and "no such dataset folder" in output
    code, output = _export(good, good / "inside")
    assert code == 1 and "inside the dataset" in output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad", "good", "lerobot", "notes"]


@pytest.mark.parametrize("name", ["x.mcap", "x.rrd"])
def test_export_refuses_a_recording_name(tmp_path: Path, name: str) -> None:
    good = _dataset(tmp_path / "good", synthetic_record)
    code, output = _export(good, tmp_path / name)
    assert code == 1 and "is a folder, not a" in output
