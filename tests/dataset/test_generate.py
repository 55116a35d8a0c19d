"""Datasets: parallel generation, manifest and split, resume, failures, cache, bad input."""

from __future__ import annotations

import gc
import json
import multiprocessing
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
import warnings
from contextlib import nullcontext
from ctypes import c_bool
from multiprocessing.synchronize import Event
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pydantic import ValidationError

from dresslog.cli.main import main
from dresslog.dataset import (
    DatasetArrays,
    Execution,
    Split,
    cache_path,
    generate,
    load_dataset,
    load_manifest,
    trial_seed,
)
from dresslog.dataset import cache as cache_module
from dresslog.dataset.manifest import check_files
from dresslog.errors import DatasetError, DresslogError, DresslogWarning
from dresslog.io.files import exclusive
from dresslog.io.reader import TrialReader
from dresslog.spec import Outcome, Task, TrialSpec
from tests.conftest import (
    SAMPLES,
    RecordResult,
    fake_record,
    prints_warnings,
)

FAKE = fake_record


def slow_record(spec: TrialSpec, path: Path, *, overwrite: bool = False) -> RecordResult:
    """The fake recorder at a pace a Ctrl-C can land in the middle of: the first slots
    quickly (slot 1's first seed fails), the rest as slowly as real trials, so that a stop
    that waits for one shows."""
    time.sleep(0.4 if int(Path(path).stem) < 3 else 10)
    return fake_record(spec, path, overwrite=overwrite)


#: The spec fields the `dataset` fixture's command fixed (the simulator: `generate`'s default).
MADE = {"duration": 0.5, "sim": {"simulator": 9}}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """4 real half-second gown trials (3 train, 1 test) made by the CLI with 2 workers."""
    out = tmp_path_factory.mktemp("data") / "gown"
    args = ["generate", "--task", "gown", "--trials", "4", "--out", str(out), "--workers", "2"]
    args += ["--test-fraction", "0.25", "--duration", "0.5", "--quiet"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert "3/3 train, 1/1 test" in result.output
    return out


@pytest.fixture
def copy(dataset: Path, tmp_path: Path) -> Path:
    """A private copy of the dataset for tests that damage or extend it."""
    return Path(shutil.copytree(dataset, tmp_path / "gown"))


@pytest.mark.slow
def test_generation_writes_trials_and_a_manifest_with_the_split(dataset: Path) -> None:
    manifest = load_manifest(dataset)
    assert manifest.complete and not manifest.failures
    assert [e.file for e in manifest.split("train")] == [f"train/00000{i}.mcap" for i in range(3)]
    assert [e.file for e in manifest.split("test")] == ["test/000000.mcap"]
    for entry in manifest.trials:
        with TrialReader(dataset / str(entry.file)) as reader:
            assert reader.metadata.spec == entry.spec
            assert reader.metadata.outcome == entry.outcome
            assert len(reader.measurements) == entry.steps == 50
        assert entry.spec.duration == 0.5 and entry.status == "ok" and len(entry.sha256) == 64
    train_seeds = {e.spec.seed for e in manifest.split("train")}
    test_seeds = {e.spec.seed for e in manifest.split("test")}
    assert train_seeds.isdisjoint(test_seeds)


def test_seeds_of_different_splits_slots_attempts_and_bases_never_collide() -> None:
    seeds = {
        trial_seed(base, split, slot, attempt)
        for base in range(3)
        for split in Split
        for slot in range(40)
        for attempt in range(5)
    }
    assert len(seeds) == 3 * 3 * 40 * 5


@pytest.mark.slow
def test_resume_recreates_a_deleted_trial_identically_and_keeps_the_rest(copy: Path) -> None:
    before = load_manifest(copy)
    (copy / "train/000001.mcap").unlink()
    (copy / "train/.000002.mcap.1234.partial").write_bytes(b"left by a killed run")
    mtimes = {p: p.stat().st_mtime_ns for p in copy.glob("*/*.mcap")}
    (copy / "test/000003.mcap").write_bytes(b"finished as a run stopped, never reported")
    (copy / "train/mine.mcap").write_bytes(b"the user's own file")
    after = generate(
        "gown", 4, copy, execution=Execution(workers=2), test_fraction=0.25, overrides=MADE
    )
    assert after.content_hash() == before.content_hash()  # same bytes: deterministic
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes  # the others were skipped
    on_disk = sorted(str(p.relative_to(copy)) for p in copy.glob("*/*mcap*"))
    listed = sorted(str(e.file) for e in after.trials)
    assert on_disk == sorted([*listed, "train/mine.mcap"])  # no stray slot file; theirs kept


@pytest.mark.slow
def test_an_interrupted_generation_is_extended_where_it_stopped(copy: Path) -> None:
    manifest = load_manifest(copy)
    manifest.trials = [e for e in manifest.trials if e.slot == 0]  # as if stopped after two
    manifest.save(copy)
    assert not manifest.complete
    resumed = generate(
        "gown",
        5,
        copy,
        execution=Execution(workers=2),
        splits={"train": 4, "test": 1},
        overrides=MADE,
    )
    assert resumed.complete and len(resumed.split("train")) == 4


def test_failed_trials_are_listed_with_reasons_and_replaced_by_fresh_seeds(tmp_path: Path) -> None:
    manifest = generate(
        "gown", 3, tmp_path, execution=Execution(workers=2, recorder=FAKE), test_fraction=0
    )
    assert manifest.complete and len(manifest.trials) == 3
    (failure,) = manifest.failures
    assert (failure.split, failure.slot, failure.attempt) == ("train", 1, 0)
    assert "garment exploded" in str(failure.failure) and failure.outcome == "failed"
    replacement = manifest.split("train")[1]
    assert replacement.attempt == 1 and replacement.spec.seed == trial_seed(0, "train", 1, 1)
    assert not list(tmp_path.glob("train/.*"))  # no half file of the failed attempt
    # Resuming does not retry the failed seed.
    again = generate(
        "gown", 3, tmp_path, execution=Execution(workers=1, recorder=FAKE), test_fraction=0
    )
    assert len(again.failures) == 1


def test_a_slot_failing_every_seed_stops_generation_with_one_line(tmp_path: Path) -> None:
    # the real simulator, with its instability guard set below any contact force
    unstable = {"sim": {"max_limb_force": 1e-3}, "limb_offset": (0, 0, 0), "duration": 1.5}
    with pytest.raises(
        DatasetError, match=r"1 slot\(s\) failed 2 seeds.*SimulationError: .*exceeds"
    ):
        generate(  # a test set of one: no training split too small to warn of
            "shorts",
            1,
            tmp_path,
            execution=Execution(workers=1, max_attempts=2),
            test_fraction=1,
            overrides=unstable,
        )
    failures = load_manifest(tmp_path).failures
    assert len(failures) == 2 and failures[0].spec.seed != failures[1].spec.seed


@pytest.mark.skipif(sys.platform == "win32", reason="a file size limit is POSIX's")
@pytest.mark.parametrize(
    ("limit", "named"), [(0, "manifest.json: File too large"), (16_000, "train/000000.mcap")]
)
def test_a_full_disk_stops_generation_at_once_naming_the_file(
    tmp_path: Path, limit: int, named: str
) -> None:
    """A trial the disk refused was a trial failure: each slot was simulated and retried
    with 5 seeds before generation gave up, and the manifest's write named no file. A file
    size limit refuses writes as a full disk does (the workers inherit it)."""
    code = (
        "import resource, signal, sys, tempfile\n"
        "tempfile.gettempdir()\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "hard = resource.getrlimit(resource.RLIMIT_FSIZE)[1]\n"
        f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, hard))\n"
        "from dresslog.cli.main import main\n"
        "if __name__ == '__main__':\n"
        "    main(sys.argv[1:])"
    )
    out = tmp_path / "data"
    out.mkdir()  # a folder generate did not make keeps its manifest (a new one is removed)
    args = ["generate", "--task", "gown", "--trials", "3", "--test-fraction", "0", "-q"]
    args += ["--duration", "1", "--workers", "1", "-o", str(out)]
    done = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 1, done.stderr
    assert done.stderr.splitlines()[-1].startswith(f"Error: {out / named}")
    if limit:  # the manifest, written before, lists no failure: the trial was not retried
        manifest = json.loads((out / "manifest.json").read_text())
        assert manifest["trials"] == [] and manifest["failures"] == []
    assert not [p for p in out.rglob(".*") if p.name != ".generate.lock"]  # no temporaries


def test_a_folder_holding_another_request_is_refused(tmp_path: Path) -> None:
    generate("gown", 2, tmp_path, execution=Execution(workers=1, recorder=FAKE), test_fraction=0)
    with pytest.raises(DatasetError, match="task gown, not shorts"):
        generate("shorts", 2, tmp_path, execution=Execution(workers=1, recorder=FAKE))
    with pytest.raises(
        DatasetError,
        match=r"fields sim=\{'simulator': 9\}, not duration=0\.5, sim=\{'simulator': 9\}",
    ):
        generate(
            "gown",
            2,
            tmp_path,
            execution=Execution(workers=1, recorder=FAKE),
            overrides={"duration": 0.5},
        )
    with pytest.raises(
        DatasetError,
        match=r"fields duration=0\.5, sim=\{'simulator': 9\}, not sim=\{'simulator': 9\}",
    ):
        short = {"test_fraction": 0, "execution": Execution(workers=1, recorder=FAKE)}
        generate("gown", 2, tmp_path / "short", overrides={"duration": 0.5}, **short)
        generate("gown", 2, tmp_path / "short", **short)
    fixed = tmp_path / "fixed"
    options = {"test_fraction": 0, "execution": Execution(workers=1, recorder=FAKE)}
    generate("gown", 2, fixed, overrides={"speed": 0.2, "duration": 1}, **options)
    same = {"duration": 1.0, "speed": 0.2}  # other order, 1.0 for 1: the same request
    assert len(generate("gown", 3, fixed, overrides=same, **options).trials) == 3
    with pytest.raises(DatasetError, match="more than the 1 asked for"):
        generate(
            "gown", 1, tmp_path, execution=Execution(workers=1, recorder=FAKE), test_fraction=0
        )


def test_rows_names_the_splits_or_outcomes_for_a_value_not_among_them() -> None:
    """A typo was a ValueError for a split and, worse, no rows at all for an outcome."""
    arrays = DatasetArrays(
        task=Task.GOWN, manifest_sha256="0" * 64, phi=np.zeros((2, 3, 9), np.float32),
        forces=np.zeros((2, 3, 4), np.float32), lengths=np.array([3, 3]),
        outcomes=np.array(["dressed", "missed"]), split=np.array(["train", "test"]),
        files=np.array(["train/000000.mcap", "test/000000.mcap"]),
    )  # fmt: skip
    assert list(arrays.rows("train", outcome="dressed")) == [0]
    assert list(arrays.rows(outcome=Outcome.MISSED)) == [1]
    with pytest.raises(DatasetError, match="split 'validation' is not one of train, test, sweep"):
        arrays.rows("validation")
    with pytest.raises(
        DatasetError, match="outcome 'dresed' is not one of dressed, missed, caught, failed"
    ):
        arrays.rows("train", outcome="dresed")


@pytest.mark.slow
def test_cache_round_trip_matches_the_recordings(copy: Path, monkeypatch) -> None:
    arrays = load_dataset(copy, workers=2, progress=False)
    manifest = load_manifest(copy)
    assert arrays.manifest_sha256 == manifest.content_hash()
    assert arrays.phi.dtype == arrays.forces.dtype == np.float32
    assert arrays.phi.shape == (4, 50, 9) and arrays.forces.shape == (4, 50, 300)
    assert list(arrays.split) == ["test", "train", "train", "train"]
    for i, entry in enumerate(manifest.trials):
        with TrialReader(copy / str(entry.file)) as reader:
            np.testing.assert_array_equal(arrays.sequences([i])[0], reader.measurements.phi)
            np.testing.assert_array_equal(arrays.force_maps([i])[0], reader.force_map.forces)
        assert arrays.outcomes[i] == entry.outcome and arrays.files[i] == entry.file
    assert list(arrays.rows("test")) == [0]

    def no_decoding(*args, **kwargs):
        raise AssertionError("decoded MCAP although the cache is current")

    monkeypatch.setattr(cache_module, "_build", no_decoding)
    cached = load_dataset(copy, progress=False)
    np.testing.assert_array_equal(cached.forces, arrays.forces)
    np.testing.assert_array_equal(cached.lengths, arrays.lengths)


@pytest.mark.slow
def test_a_planted_or_damaged_cache_is_rebuilt_never_unpickled(copy: Path) -> None:
    path = cache_path(copy, load_manifest(copy))
    path.parent.mkdir()
    np.savez(path, phi=np.array([object()], dtype=object))  # would need unpickling
    arrays = load_dataset(copy, workers=1, progress=False)
    assert arrays.phi.shape == (4, 50, 9)
    path.write_bytes(path.read_bytes()[:1000])  # truncated
    assert load_dataset(copy, workers=1, progress=False).forces.shape == (4, 50, 300)
    with path.open("r+b") as stream:  # an array's header, which numpy parses as Python
        stream.seek(100)
        stream.write(b"X" * 44)
    assert load_dataset(copy, workers=1, progress=False).forces.shape == (4, 50, 300)
    with path.open("wb") as stream:  # one array, not an archive: was a TypeError traceback
        np.save(stream, np.zeros(3))
    assert load_dataset(copy, workers=1, progress=False).forces.shape == (4, 50, 300)


def test_a_damaged_cache_is_not_left_open(copy: Path) -> None:
    """numpy's own open of a file that starts as a zip and is none was never closed: one
    file handle (and a ResourceWarning) lost per `train` or `eval` until it was rebuilt."""
    path = cache_path(copy, load_manifest(copy))
    path.parent.mkdir()
    path.write_bytes(b"PK\x03\x04" + bytes(1000))  # a zip's first bytes, then nothing
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResourceWarning)
        assert load_dataset(copy, workers=1, progress=False).phi.shape == (4, 50, 9)
        gc.collect()
    assert [str(w.message) for w in caught if w.category is ResourceWarning] == []


@pytest.mark.slow
def test_a_trial_rewritten_in_place_after_caching_is_caught(copy: Path) -> None:
    load_dataset(copy, workers=1, progress=False)  # now cached
    trial = copy / "train/000002.mcap"
    data = bytearray(trial.read_bytes())
    data[len(data) // 2] ^= 0xFF  # same size: only its checksum can tell
    trial.write_bytes(bytes(data))
    with pytest.raises(DatasetError, match=r"train/000002\.mcap does not match its checksum"):
        load_dataset(copy, workers=1, progress=False)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("edit", "message"),
    [
        ({"split": "test"}, "trial train/000001.mcap is listed as test/000001"),
        ({"slot": 0, "file": "train/000000.mcap"}, "train/000000 is listed twice"),
        ({"slot": 7, "file": "train/000007.mcap"}, "train/000007 is beyond the 3 asked for"),
    ],
)
def test_a_hand_edited_manifest_that_moves_a_trial_is_refused(
    copy: Path, edit: dict, message: str
) -> None:
    raw = json.loads((copy / "manifest.json").read_text())
    entry = next(e for e in raw["trials"] if e["file"] == "train/000001.mcap")
    entry.update(edit)
    (copy / "manifest.json").write_text(json.dumps(raw))
    with pytest.raises(DatasetError, match=message):
        load_dataset(copy, workers=1, progress=False)


def _generation_under_way(out: Path, trials: int) -> subprocess.Popen[bytes]:
    """A slow fake generation in its own session, once its three quick trials are on disk
    (slots 0-2): a stop then keeps two or more, the last placed perhaps not yet reported
    (its worker stopped between renaming and reporting it: tidied, as it is unlisted)."""
    script = (  # a terminal's signal handling, even when the tests run under nohup
        "import signal\n"
        "signal.signal(signal.SIGHUP, signal.SIG_DFL)\n"
        "from dresslog.dataset import Execution, generate\n"
        "from tests.dataset.test_generate import slow_record\n"
        "if __name__ == '__main__':\n"
        f"    generate('gown', {trials}, {str(out)!r}, progress=False,\n"
        "             execution=Execution(workers=2, recorder=slow_record))\n"
    )
    root = Path(__file__).resolve().parents[2]
    run = subprocess.Popen(
        [sys.executable, "-c", script], cwd=root, start_new_session=True, stderr=subprocess.PIPE
    )
    deadline = time.monotonic() + 60
    while len(list(out.glob("*/*.mcap"))) < 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    return run


@pytest.mark.skipif(sys.platform == "win32", reason="process groups and SIGINT are POSIX")
@pytest.mark.parametrize("stop", ["ctrl-c", "sigterm", "sigterm-group", "sighup-group"])
def test_ctrl_c_leaves_a_manifest_that_lists_every_trial_on_disk(tmp_path: Path, stop: str) -> None:
    """A terminal's Ctrl-C reaches the whole process group; `kill PID` the main process
    alone; a batch scheduler's timeout SIGTERMs every process of the job; a closed
    terminal hangs up every process (multiprocessing's resource tracker too)."""
    with _generation_under_way(tmp_path, 12) as run:  # then its stderr pipe is closed
        stopped = time.monotonic()
        if stop == "ctrl-c":
            os.killpg(run.pid, signal.SIGINT)
        elif stop == "sigterm":
            os.kill(run.pid, signal.SIGTERM)
        else:
            os.killpg(run.pid, signal.SIGTERM if stop == "sigterm-group" else signal.SIGHUP)
        assert run.wait(timeout=60) != 0
        # the trials under way stop too: a kill to the main process alone used to wait for
        # them and start the next queued one (a scheduler's grace period may be 10 s)
        assert time.monotonic() - stopped < 5
        assert run.stderr is not None
        said = run.stderr.read().decode()
        assert "KeyboardInterrupt" in said and "BrokenProcessPool" not in said, said[-3000:]
        assert "resource_tracker" not in said and "KeyError" not in said, said[-3000:]
        manifest = load_manifest(tmp_path)
        on_disk = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.glob("*/*.mcap"))
        assert sorted(str(e.file) for e in manifest.trials) == on_disk
        assert 2 <= len(on_disk) < 12 and not list(tmp_path.glob("*/.*.partial"))
        check_files(tmp_path, manifest, checksums=True)


@pytest.mark.skipif(sys.platform == "win32", reason="process groups and SIGKILL are POSIX")
def test_workers_of_a_killed_generation_stop_and_leave_no_temporary(tmp_path: Path) -> None:
    """`kill -9` (or the out-of-memory killer) on the main process alone."""
    with _generation_under_way(tmp_path, 40) as run:  # then its stderr pipe is closed
        os.kill(run.pid, signal.SIGKILL)
        run.wait(timeout=10)
        deadline = time.monotonic() + 20
        while _session_alive(run.pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not _session_alive(run.pid), "workers outlived their generation"
        assert not list(tmp_path.glob("*/.*.partial"))


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds workers in Linux's /proc")
def test_a_worker_killed_alone_is_one_line_and_the_folder_resumable(tmp_path: Path) -> None:
    """The out-of-memory killer takes one worker: say so, keep what is done."""
    with _generation_under_way(tmp_path, 12) as run:  # then its stderr pipe is closed
        workers = [
            int(p.parent.name)
            for p in Path("/proc").glob("[0-9]*/cmdline")
            if _parent(p.parent) == run.pid and b"spawn_main" in _read(p)
        ]
        assert workers
        os.kill(workers[0], signal.SIGKILL)
        assert run.wait(timeout=60) != 0
        assert run.stderr is not None
        said = run.stderr.read().decode()
        assert "a worker process died" in said and "BrokenProcessPool" not in said, said[-3000:]
        manifest = load_manifest(tmp_path)
        assert manifest.trials and not list(tmp_path.glob("*/.*.partial"))
        check_files(tmp_path, manifest, checksums=True)


def _read(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError:
        return b""


def _parent(proc: Path) -> int:
    stat = _read(proc / "stat").decode()
    return int(stat.rsplit(")", 1)[1].split()[1]) if ")" in stat else -1


def _session_alive(session: int) -> bool:
    """Whether any process of the session is left (a zombie is gone: it only awaits reaping)."""
    states = [p / "stat" for p in Path("/proc").iterdir() if p.name.isdigit()]
    for stat in states:
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == session and fields[0] != "Z":
            return True
    return False


def test_a_folder_without_a_manifest_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match=r"no manifest\.json; not a dataset folder"):
        load_dataset(tmp_path)
    (tmp_path / "manifest.json").write_text(json.dumps({"format": "something else"}))
    with pytest.raises(DatasetError, match="not a dresslog dataset manifest"):
        load_dataset(tmp_path)
    (tmp_path / "manifest.json").write_text("{not json")
    with pytest.raises(DatasetError, match="not readable JSON"):
        load_dataset(tmp_path)
    for version, message in ((2, "format version 2, newer than"), ("2", "format_version")):
        manifest = {"format": "dresslog-dataset", "format_version": version}
        (tmp_path / "manifest.json").write_text(json.dumps(manifest))
        with pytest.raises(DatasetError, match=message):
            load_dataset(tmp_path)


@pytest.mark.slow
def test_missing_or_corrupt_trials_are_named(copy: Path) -> None:
    trial = copy / "train/000002.mcap"
    data = bytearray(trial.read_bytes())
    data[len(data) // 2] ^= 0xFF  # same size, different bytes
    trial.write_bytes(bytes(data))
    with pytest.raises(DatasetError, match=r"train/000002\.mcap does not match its checksum"):
        load_dataset(copy, workers=1, progress=False)
    trial.unlink()
    shown = CliRunner().invoke(main, ["info", str(copy)])
    assert shown.exit_code == 1 and "damaged: train/000002.mcap (missing)" in shown.stdout
    assert "train/000002.mcap listed in the manifest is missing" in shown.stderr
    as_json = CliRunner().invoke(main, ["info", str(copy), "--json"])
    listed = json.loads(as_json.stdout)
    assert as_json.exit_code == 1 and len(listed["trials"]) == len(load_manifest(copy).trials)
    assert listed["damaged"] == [{"file": "train/000002.mcap", "problem": "missing"}]
    assert listed["content_sha256"] == load_manifest(copy).content_hash()  # as cards name it
    with pytest.raises(DatasetError, match=r"train/000002\.mcap listed in the manifest is missing"):
        load_dataset(copy, workers=1, progress=False)


@pytest.mark.parametrize("command", ["train", "eval"])
def test_cli_bad_data_folder_is_one_line_and_exit_1(tmp_path: Path, command: str) -> None:
    args = [command, str(tmp_path), "-o", str(tmp_path / "m")] if command == "train" else []
    if command == "eval":
        args = ["eval", str(SAMPLES / "models" / "gown"), str(tmp_path)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1
    assert result.output == (
        f"Error: {tmp_path}: no manifest.json; not a dataset folder "
        "(make one with `dresslog generate`)\n"
    )


def test_cli_generate_seed_reaches_every_trial(tmp_path: Path) -> None:
    args = ["generate", "--task", "shorts", "--trials", "3", "--test-fraction", "0.34"]
    args += ["--seed", "5", "--duration", "0.1", "--workers", "1", "-q", "-o", str(tmp_path / "d")]
    result = CliRunner().invoke(main, args)  # 2 to train on, as `train` needs, and 1 to test
    assert result.exit_code == 0, result.output
    manifest = load_manifest(tmp_path / "d")
    assert manifest.seed == 5
    assert {(e.split, e.spec.seed) for e in manifest.trials} == {
        (split, trial_seed(5, split, slot))
        for split, slot in ((Split.TRAIN, 0), (Split.TRAIN, 1), (Split.TEST, 0))
    }


def test_cli_generate_speed_and_rotation_make_every_trial_of_that_condition(
    tmp_path: Path,
) -> None:
    """A dataset of a forearm turned aside, to fine-tune or score a model on: every trial is
    simulated at the speed and rotation asked, with its own offset and path, and a folder
    of one condition is not extended with another."""
    out = tmp_path / "d"
    args = ["generate", "--task", "gown", "--trials", "3", "--test-fraction", "0.34"]
    args += ["--duration", "0.1", "--workers", "1", "-q", "-o", str(out)]
    result = CliRunner().invoke(main, [*args, "--speed", "0.18", "--rotation", "z", "-15"])
    assert result.exit_code == 0, result.output
    entries = load_manifest(out).trials
    with TrialReader(out / entries[0].file) as trial:  # the simulator got it, not just the card
        recorded = trial.metadata.spec
    assert recorded is not None and recorded.speed == 0.18
    assert recorded.limb_rotation is not None
    assert (recorded.limb_rotation.axis, recorded.limb_rotation.degrees) == ("z", -15.0)
    assert {e.spec.speed for e in entries} == {0.18}
    assert len({e.spec.limb_offset for e in entries}) == 3  # each trial draws its own
    result = CliRunner().invoke(main, [*args, "--rotation", "z", "15"])
    assert result.exit_code == 1
    assert result.output == (
        f"Error: {out}: folder holds a dataset with fixed spec fields duration=0.1, speed=0.18, "
        "limb_rotation={'axis': 'z', 'degrees': -15.0}, sim={'simulator': 9}, not "
        "duration=0.1, limb_rotation={'axis': 'z', 'degrees': 15.0}, sim={'simulator': 9}; "
        "use another folder or the same options\n"
    )


def test_cli_generate_rotation_range_draws_each_trials_rotation_within_it(tmp_path: Path) -> None:
    """A dataset across a span of conditions, to train one model for all of them: each
    trial's rotation is drawn within the range and reaches the simulator, the rest of its
    spec is the one its seed draws without a range, and `info` names the range."""
    out, plain = tmp_path / "d", tmp_path / "plain"
    args = ["generate", "--task", "gown", "--trials", "4", "--test-fraction", "0.25"]
    args += ["--duration", "0.1", "--workers", "1", "-q"]
    result = CliRunner().invoke(main, [*args, "--rotation-range", "z", "-15", "15", "-o", out])
    assert result.exit_code == 0, result.output
    assert CliRunner().invoke(main, [*args, "-o", plain]).exit_code == 0
    drawn, unturned = load_manifest(out).trials, load_manifest(plain).trials
    degrees = [e.spec.limb_rotation.degrees for e in drawn]
    assert all(-15 <= d <= 15 for d in degrees) and len(set(degrees)) == 4, degrees
    assert {e.spec.limb_rotation.axis for e in drawn} == {"z"}
    for turned, same in zip(drawn, unturned, strict=True):  # only the rotation differs
        assert (
            turned.spec.model_copy(update={"limb_rotation": same.spec.limb_rotation}) == same.spec
        )
    with TrialReader(out / drawn[0].file) as trial:
        assert trial.metadata.spec == drawn[0].spec
    shown = CliRunner().invoke(main, ["info", str(out)])
    assert shown.output.splitlines()[1:4] == [
        "  trials    speeds 0.1-0.15 m/s; the limb turned about z -15...+15 deg",
        '  fixed for every trial: duration=0.1, sim={"simulator": 9}',
        "  fidelity  against the paper's dressing",
    ]
    result = CliRunner().invoke(main, [*args, "-o", out])  # not extended with fixed trials
    assert result.exit_code == 1
    assert result.output == (
        f"Error: {out}: folder holds a dataset with rotation drawn per trial z -15...+15 deg, "
        "not none (no --rotation-range); use another folder or the same options\n"
    )


@pytest.mark.parametrize(
    ("options", "code", "message"),
    [
        (["--rotation", "z", "5", "--rotation-range", "z", "-5", "5"], 2,
         "Error: --rotation fixes every trial's rotation, --rotation-range draws it; give one"),
        (["--rotation-range", "y", "5", "-5"], 1,
         "Error: invalid rotation range: low 5 must be below high -5"),
        (["--rotation-range", "y", "5", "95"], 2,
         "Error: Invalid value for '--rotation-range': 95.0 is not in the range -90<=x<=90."),
    ],
    ids=["both", "empty", "beyond"],
)  # fmt: skip
def test_a_rotation_range_no_trial_could_have_is_refused_in_one_line(
    tmp_path: Path, options: list[str], code: int, message: str
) -> None:
    args = ["generate", "--task", "gown", "--trials", "2", "-o", str(tmp_path / "d"), *options]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == code
    assert result.output.splitlines()[-1] == message
    assert not (tmp_path / "d").exists()


@prints_warnings
def test_a_split_rounded_to_no_trials_is_warned_about(tmp_path: Path) -> None:
    """3 trials at the default 1/6 made no test trials, found only when `eval` failed."""
    out = tmp_path / "d"
    args = ["generate", "--task", "gown", "--trials", "3", "--duration", "0.1", "--workers", "1"]
    result = CliRunner().invoke(main, [*args, "-q", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.stderr == (
        f"Warning: {out}: 3 trials at --test-fraction 0.167 leave none to test on; "
        "eval needs some (more --trials or a larger --test-fraction)\n"
    )
    with pytest.warns(
        DresslogWarning,
        match="2 trials at --test-fraction 0.5 leave 1 to train on; train needs 2 or more "
        r"\(more --trials or a smaller --test-fraction\)",
    ):  # `train` refuses one, as it does none
        generate(
            "gown",
            2,
            tmp_path / "t",
            execution=Execution(workers=1, recorder=FAKE),
            test_fraction=0.5,
        )
    with pytest.warns(
        DresslogWarning, match=r"1 trial at .* leaves 1 to train on; .*\(more --trials\)$"
    ):
        generate(
            "gown", 1, tmp_path / "u", execution=Execution(workers=1, recorder=FAKE)
        )  # no fraction helps
    with warnings.catch_warnings():  # none asked for, or none but the sweep's: no warning
        warnings.simplefilter("error")
        generate(
            "gown",
            3,
            tmp_path / "a",
            execution=Execution(workers=1, recorder=FAKE),
            test_fraction=0,
        )
        generate("gown", 6, tmp_path / "b", execution=Execution(workers=1, recorder=FAKE))
        generate(
            "gown",
            0,
            tmp_path / "s",
            execution=Execution(workers=1, recorder=FAKE),
            splits={"sweep": 1},
        )


def test_info_on_a_dataset_names_its_conditions_and_the_spec_fields_fixed_for_every_trial(
    tmp_path: Path,
) -> None:
    """Two folders of 0.3 s and 7 s trials, or of two sweep speeds, read alike in `info`;
    the speeds and rotations in the words of `info MODEL`'s `trained` line, so a folder
    can be read against a model's training at a glance."""
    fixed = {"duration": 0.3, "limb_rotation": {"axis": "z", "degrees": 10.0}, "speed": 0.2}
    options = {
        "test_fraction": 1 / 3,
        "execution": Execution(workers=1, recorder=FAKE),
    }  # 2 train, 1 test
    generate("gown", 3, tmp_path / "d", overrides=fixed, **options)
    generate("gown", 3, tmp_path / "e", **options)
    shown = CliRunner().invoke(main, ["info", str(tmp_path / "d")])
    assert shown.exit_code == 0 and shown.output.splitlines()[1:4] == [
        "  trials    speeds 0.2 m/s; the limb turned about z +10 deg",
        '  fixed for every trial: duration=0.3, sim={"simulator": 9}',
        "  fidelity  against the paper's dressing",
    ], shown.output
    shown = CliRunner().invoke(main, ["info", str(tmp_path / "e")])  # the simulator only
    assert shown.exit_code == 0 and shown.output.splitlines()[1:3] == [
        "  trials    speeds 0.1-0.15 m/s, the limb never turned",
        '  fixed for every trial: sim={"simulator": 9}',
    ], shown.output


def test_cli_ray_executor_without_ray_says_how_to_install(tmp_path: Path, monkeypatch) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed
    args = ["generate", "--task", "gown", "--trials", "2", "-o", str(tmp_path / "d")]
    result = CliRunner().invoke(main, [*args, "--executor", "ray", "--duration", "0.2", "-q"])
    assert result.exit_code == 1
    assert "pip install 'dresslog[ray]'" in result.output
    assert not (tmp_path / "d").exists()  # refused before anything was written


def test_an_executor_that_cannot_start_leaves_no_folder_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 50: a Ray cluster that refused `generate` left an empty dataset folder (its
    manifest, lock and split folders). A folder it made and made no trial in is removed,
    the folders made above it too; one that was there stays, with what it held."""
    generate_module = sys.modules["dresslog.dataset.generate"]  # the package names the function

    def refused(*args: object) -> None:
        raise DatasetError("cannot join the Ray cluster at 10.0.0.1:6379: no answer")

    monkeypatch.setattr(generate_module, "make_executor", refused)
    args = ["generate", "--task", "gown", "--trials", "4", "-q"]
    result = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "runs" / "d")])
    assert result.exit_code == 1
    assert result.output.splitlines() == [
        "Error: cannot join the Ray cluster at 10.0.0.1:6379: no answer"
    ]
    assert list(tmp_path.iterdir()) == []
    (kept := tmp_path / "kept").mkdir()
    (kept / "notes.txt").write_text("mine")
    with pytest.raises(DatasetError, match="cannot join"):
        generate("gown", 4, kept / "d", execution=Execution(recorder=FAKE), progress=False)
    assert [p.name for p in kept.iterdir()] == ["notes.txt"]


def test_an_override_no_trial_could_have_is_refused_before_the_folder_is_made(
    tmp_path: Path,
) -> None:
    args = ["generate", "--task", "gown", "--trials", "2", "--duration", "0.004"]  # one step
    result = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "d")])
    assert result.exit_code == 1 and "invalid duration: at least two" in result.output
    assert not (tmp_path / "d").exists()  # no manifest that would pin the bad value
    with pytest.raises(DatasetError, match="invalid duration: Input should be a finite number"):
        generate("gown", 2, tmp_path / "d", overrides={"duration": float("inf")})  # click's 2
    assert not (tmp_path / "d").exists()
    for field, value in (("record_hz", 0), ("physics_hz", 0), ("garment_mass", -1)):
        # a ZeroDivisionError, a traceback from the first worker, a garment that falls up
        with pytest.raises(DatasetError, match=f"invalid sim.{field}: .* greater than 0"):
            generate("gown", 2, tmp_path / "d", overrides={"sim": {field: value}})
        assert not (tmp_path / "d").exists()


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"overrides": {"seed": 5}}, "not seed: each trial's seed is drawn from `seed`"),
        ({"overrides": {"task": "shorts"}}, "not task: .* generate's own argument"),
        ({"splits": {"train": -2}}, "train trials must be a whole number >= 0, not -2"),
        ({"splits": {"val": 2}}, "split 'val' is not one of train, test, sweep"),
        ({"trials": 2.5}, "--trials must be a whole number from 1 to 1,000,000, not 2.5"),
        ({"trials": 10**9}, "--trials must be a whole number from 1 to 1,000,000, not 1000000000"),
        ({"splits": {"train": 10**6, "test": 1}}, "1,000,001 trials: at most 1,000,000 are made"),
        ({"task": "hat"}, "task 'hat' is not one of gown, shorts"),
        (
            {
                "overrides": {"limb_rotation": {"axis": "z", "degrees": 5}},
                "rotation_range": {"axis": "z", "low": -5, "high": 5},
            },
            r"a rotation is fixed for every trial or drawn per trial \(--rotation or "
            r"--rotation-range\), not both",
        ),
        ({"rotation_range": {"axis": "w", "low": -5, "high": 5}}, "invalid rotation range: axis"),
    ],
)
def test_generate_called_from_a_script_says_what_is_wrong_with_its_arguments(
    tmp_path: Path, arguments: dict, message: str
) -> None:
    """Each was a TypeError, a pydantic or a ValueError traceback, some after making the
    folder."""
    call = {"task": "gown", "trials": 2, "execution": Execution(workers=1, recorder=FAKE)}
    call |= arguments
    with pytest.raises(DatasetError, match=message):
        generate(out=tmp_path / "d", **call)
    assert not (tmp_path / "d").exists()
    generate(
        "gown",
        1,
        tmp_path / "numpy",
        splits={"train": np.int64(1)},
        execution=Execution(recorder=FAKE),
    )


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"workers": -1}, r"--workers must be a whole number \(0: all cores\), not -1"),
        ({"workers": 2.5}, "--workers must be a whole number"),
        ({"ray_address": "head:6379"}, "address is for the 'ray' executor, not 'process'"),
        ({"executor": "dask"}, "Input should be 'process' or 'ray'"),
        ({"max_attempts": 0}, "greater than or equal to 1"),
        ({"recorder": "dresslog.sim:record_trial"}, "recorder"),  # a name is no recorder
    ],
)
def test_an_execution_is_refused_when_it_is_built(fields: dict, message: str) -> None:
    """Checked once, before any folder is made, as `generate` checked its own arguments."""
    with pytest.raises(ValidationError, match=message):
        Execution(**fields)
    assert Execution(workers=np.int64(2)).pool_size() == 2  # numpy's whole numbers too


@pytest.mark.parametrize("holds", ["card.json", "notes.txt", "train/000000.mcap"])
def test_a_folder_holding_something_else_is_refused_and_left_as_it_was(
    tmp_path: Path, holds: str
) -> None:
    (tmp_path / holds).parent.mkdir(parents=True, exist_ok=True)
    (tmp_path / holds).write_text("mine")
    before = sorted(tmp_path.rglob("*"))
    args = ["generate", "--task", "gown", "--trials", "1", "-o", str(tmp_path)]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1 and "holds no dataset (manifest.json)" in result.output
    assert sorted(tmp_path.rglob("*")) == before
    options = {
        "test_fraction": 0,
        "execution": Execution(workers=1, recorder=FAKE),
    }  # 2 to train on, no warning
    generate("gown", 2, tmp_path / "new", **options)  # an empty folder is fine
    killed = tmp_path / "killed"  # a first run killed while saving its manifest
    (killed / "train").mkdir(parents=True)
    (killed / ".manifest.json.4242.partial").write_text("{")
    generate("gown", 2, killed, **options)


def test_a_second_generate_into_the_same_folder_is_refused_while_the_first_runs(
    tmp_path: Path,
) -> None:
    tmp_path.joinpath("d").mkdir()
    lock = exclusive(tmp_path / "d" / ".generate.lock", "dresslog generate")
    options = {
        "test_fraction": 0,
        "execution": Execution(workers=1, recorder=FAKE),
    }  # 2 to train on, no warning
    with lock, pytest.raises(DresslogError, match=r"another `dresslog generate` .* is writing it"):
        generate("gown", 2, tmp_path / "d", **options)
    generate("gown", 2, tmp_path / "d", **options)  # free again
    assert len(load_manifest(tmp_path / "d").trials) == 2
    tmp_path.joinpath("s").mkdir()  # a sweep's setting: the message names the sweep
    lock = exclusive(tmp_path / "s" / ".generate.lock", "dresslog sweep")
    with lock, pytest.raises(DresslogError, match=r"another `dresslog sweep` .* is writing it"):
        generate(
            "gown",
            0,
            tmp_path / "s",
            execution=Execution(workers=1, recorder=FAKE),
            splits={"sweep": 1},
        )


def test_generate_names_its_folder_as_given_not_as_its_absolute_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As every other command does: generate had named /the/whole/resolved/path."""
    monkeypatch.chdir(tmp_path)
    generate(
        "gown",
        2,
        tmp_path / "data" / "gown",
        execution=Execution(workers=1, recorder=FAKE),
        test_fraction=0,
    )
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine")
    lock = tmp_path / "data" / "gown" / ".generate.lock"
    runs = [
        (
            ["-o", "data/gown", "--seed", "3"],
            "data/gown: folder holds a dataset with seed 0, not 3",
        ),
        (["-o", "./full"], "full: folder is not empty and holds no dataset"),
        (["-o", "data/gown"], "data/gown: another `dresslog generate` ("),
    ]
    for options, message in runs:
        held = "another" in message
        with exclusive(lock, "dresslog generate") if held else nullcontext():
            args = ["generate", "--task", "gown", "--trials", "1", *options]
            result = CliRunner().invoke(main, args)
        assert result.exit_code == 1 and f"Error: {message}" in result.output, result.output
        assert str(tmp_path) not in result.output


@pytest.mark.slow
def test_a_manifest_edited_to_the_other_task_is_refused(copy: Path) -> None:
    """Trained on, it would make a gown model labelled shorts."""
    raw = json.loads((copy / "manifest.json").read_text())
    raw["task"] = "shorts"
    for entry in raw["trials"]:
        entry["spec"]["task"] = "shorts"
    (copy / "manifest.json").write_text(json.dumps(raw))
    with pytest.raises(DatasetError, match=r"/000000\.mcap is a gown trial in a shorts dataset"):
        load_dataset(copy, workers=1, progress=False)


def test_a_dataset_at_another_rate_than_the_models_read_is_refused(
    copy: Path, tmp_path: Path
) -> None:
    """A 50 Hz dataset would train a model that `infer` then refuses on its own data."""
    with pytest.raises(DatasetError, match=r"sim.record_hz 50: a dataset is recorded at 100 Hz"):
        generate(
            "gown",
            2,
            tmp_path / "d",
            execution=Execution(workers=1),
            overrides={"sim": {"record_hz": 50}},
        )
    assert not (tmp_path / "d").exists()  # refused before the folder is made
    raw = json.loads((copy / "manifest.json").read_text())
    raw["trials"][1]["spec"]["sim"] = {"record_hz": 50}  # made by another version, say
    (copy / "manifest.json").write_text(json.dumps(raw))
    name = re.escape(raw["trials"][1]["file"])
    with pytest.raises(DatasetError, match=rf"trial {name} is recorded at 50 Hz; "):
        load_dataset(copy, workers=1, progress=False)
    assert not (copy / ".cache").exists()  # refused from the manifest, before any decoding


def _worker_starting(queue: multiprocessing.Queue, imported: Event, stopping: c_bool) -> None:
    """A generate worker whose Ctrl-C comes before its imports are done."""
    from dresslog.dataset.executors import _Worker

    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    queue.put(sorted(int(s) for s in blocked))
    imported.wait(timeout=60)  # the parent signals meanwhile
    _Worker.start(stopping)
    queue.put(_Worker.interrupted)


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signal masks")
def test_a_stop_while_workers_start_is_deferred_not_printed_nor_lost() -> None:
    """A Ctrl-C to the group while workers were still importing printed one
    KeyboardInterrupt traceback per worker. Started under `deferred_in_children`, a
    worker holds it until it can handle it (a generate worker then starts no trial), and
    the parent takes its own as the block ends; ignoring it instead lost both."""
    from multiprocessing import resource_tracker

    from dresslog.stops import deferred_in_children

    context = multiprocessing.get_context("spawn")
    queue, imported, stopping = context.Queue(), context.Event(), context.RawValue(c_bool)
    # what this test does not test, held still: Python's own Ctrl-C handler (one an
    # earlier test left would not raise), the tracker that spawn starts once (started in
    # the block, it unblocks SIGINT as it goes), and which thread the kernel hands a
    # process's signal to (the main thread, which blocks it, is the one that must wait)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    resource_tracker.ensure_running()
    try:
        with pytest.raises(KeyboardInterrupt), deferred_in_children():
            worker = context.Process(target=_worker_starting, args=(queue, imported, stopping))
            worker.start()
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)  # the Ctrl-C
            time.sleep(0.1)  # nothing raised here: it waits for the block's end
    finally:
        signal.signal(signal.SIGINT, previous)
    stops = sorted(int(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP))
    assert queue.get(timeout=60) == stops  # the worker was started with them blocked
    os.kill(worker.pid, signal.SIGINT)  # ... and to the worker, still importing
    imported.set()
    assert queue.get(timeout=60) is True  # taken once it handles it: no trial starts
    worker.join(timeout=60)
    assert worker.exitcode == 0


def _sleep(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="kill -9 is POSIX")
def test_a_decoding_worker_killed_alone_lets_the_others_end() -> None:
    """One killed (out of memory) breaks the pool, which terminates the others: started
    deaf to every stop, they outlived it, and its shutdown waited for them forever."""
    from concurrent.futures.process import BrokenProcessPool

    from dresslog.dataset.cache import decoding_pool
    from dresslog.stops import deferred_in_children

    pool = decoding_pool(2)
    with deferred_in_children():
        results = pool.map(_sleep, [30.0] * 4)
    deadline = time.monotonic() + 60
    while len(pool._processes) < 2 and time.monotonic() < deadline:  # both started
        time.sleep(0.05)
    time.sleep(2.0)  # and past their imports
    os.kill(next(iter(pool._processes)), signal.SIGKILL)
    started = time.monotonic()
    with pytest.raises(BrokenProcessPool):
        list(results)
    pool.shutdown(cancel_futures=True)
    assert time.monotonic() - started < 20  # not the survivor's 30 s sleep


def test_a_damaged_trial_names_the_command_that_remakes_its_folder(tmp_path: Path) -> None:
    """A sweep setting's folder is remade by its sweep: `generate` refuses the setting's
    fixed fields, yet it was the cure named for every damaged trial."""
    from dresslog.dataset.manifest import damaged_error

    swept = str(damaged_error(tmp_path, "sweep/000003.mcap", "missing"))
    assert swept.endswith("run `dresslog sweep` that made it again to re-create it"), swept
    trained = str(damaged_error(tmp_path, "train/000003.mcap", "changed"))
    assert trained.endswith("run `dresslog generate` on it again to re-create it"), trained


def test_generate_on_a_sweep_setting_folder_names_the_sweep_not_its_fields(tmp_path: Path) -> None:
    """generate told to "use another folder or the same options" of a setting's folder for
    its speed, an option generate does not have; the folder is the sweep's, and so said."""
    setting = tmp_path / "speed_0.2"
    fixed = {"speed": 0.2, "duration": 0.5}
    generate(
        "gown",
        0,
        setting,
        splits={"sweep": 1},
        overrides=fixed,
        execution=Execution(recorder=FAKE),
        progress=False,
    )
    with pytest.raises(DatasetError, match=r"holds 1 sweep trials, made by `dresslog sweep`; use"):
        generate(
            "gown",
            2,
            setting,
            overrides={"duration": 0.5},
            execution=Execution(recorder=FAKE),
            progress=False,
        )


@prints_warnings
def test_an_unfinished_sweep_setting_is_finished_by_its_sweep(tmp_path: Path) -> None:
    """An interrupted sweep's setting folder was to be finished by its `generate` command,
    which refuses the folder (and had never made it)."""
    setting = tmp_path / "in-range"
    generate(
        "gown", 0, setting, splits={"sweep": 1}, execution=Execution(recorder=FAKE), progress=False
    )
    manifest = load_manifest(setting)
    manifest.n_sweep = 2  # as a sweep stopped after its first sequence leaves it
    manifest.save(setting)
    shown = CliRunner().invoke(main, ["info", str(setting)])
    assert shown.exit_code == 0
    assert "(1/2 sweep); run its `dresslog sweep` command again to finish it" in shown.stderr


def test_info_on_a_sweep_folder_or_a_split_folder_names_the_folder_it_takes(
    tmp_path: Path,
) -> None:
    """Both said only what they were not (neither a model nor a dataset folder)."""
    sweep = tmp_path / "sweep"
    generate(
        "gown",
        0,
        sweep / "in-range",
        splits={"sweep": 1},
        execution=Execution(recorder=FAKE),
        progress=False,
    )
    (sweep / "sweep.json").write_text("{}")  # beside sweep.csv and sweep.png
    shown = CliRunner().invoke(main, ["info", str(sweep)])
    assert shown.exit_code == 1 and shown.output.count("\n") == 1
    said = "a sweep's folder: its table is sweep.csv, and `dresslog info` takes one setting's"
    assert f"{said} folder, e.g. {sweep / 'in-range'}" in shown.output, shown.output
    data = tmp_path / "data"
    generate(
        "gown", 3, data, test_fraction=1 / 3, execution=Execution(recorder=FAKE), progress=False
    )
    shown = CliRunner().invoke(main, ["info", str(data / "test")])
    assert shown.exit_code == 1 and shown.output.count("\n") == 1
    assert f"; a dataset's test folder: give the dataset, {data}" in shown.output, shown.output


def test_a_split_folder_or_a_trial_given_as_the_dataset_names_the_dataset(tmp_path: Path) -> None:
    """`train data/gown/train` was told to make a dataset with `dresslog generate`."""
    data = tmp_path / "data"
    generate(
        "gown", 3, data, test_fraction=1 / 3, execution=Execution(recorder=FAKE), progress=False
    )
    result = CliRunner().invoke(main, ["train", str(data / "train"), "-o", str(tmp_path / "m")])
    said = f"no manifest.json; a dataset's train folder: give the dataset, {data}"
    assert result.exit_code == 1 and said in result.output, result.output
    with pytest.raises(DatasetError, match=f"a dataset is a folder: give its dataset, {data}$"):
        load_dataset(data / "test" / "000000.mcap")


def test_info_names_the_sweep_as_the_cure_of_a_damaged_sweep_setting(tmp_path: Path) -> None:
    """`info` on a sweep setting's folder with a trial missing named `generate` (which
    refuses the folder) in its damaged line, above the error naming `sweep`."""
    setting = tmp_path / "speed_0.2"
    generate(
        "gown",
        0,
        setting,
        execution=Execution(workers=1, recorder=FAKE),
        splits={"sweep": 2},
        progress=False,
    )
    (setting / "sweep/000001.mcap").unlink()
    shown = CliRunner().invoke(main, ["info", str(setting)])
    assert shown.exit_code == 1
    assert "damaged: sweep/000001.mcap (missing); run `dresslog sweep` that made it again" in (
        shown.stdout
    ), shown.stdout
    assert "generate" not in shown.output, shown.output
