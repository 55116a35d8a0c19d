"""`--executor ray`: the same generation as Ray tasks, on a local 2-CPU Ray instance."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="Ray is an optional extra: pip install 'dresslog[ray]'")

from dresslog.dataset import generate, load_manifest  # noqa: E402
from dresslog.errors import TrialWriteError  # noqa: E402
from dresslog.spec import TrialSpec  # noqa: E402

#: One trial per split is all a comparison with the process pool needs; that leaves `train`
#: fewer than it takes, which `generate` warns of, beside the point here.
ONE_PER_SPLIT = pytest.mark.filterwarnings(
    "ignore:.*2 trials at --test-fraction 0.5 leave 1 to train on:dresslog.errors.DresslogWarning"
)


@ONE_PER_SPLIT
@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="reads Linux's /proc")
def test_the_cli_starts_its_own_ray_instance_and_stops_it(tmp_path: Path) -> None:
    """What a user without a cluster gets from `dresslog generate --executor ray`."""
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    args = ["--task", "gown", "--trials", "2", "--test-fraction", "0.5", "--duration", "0.3"]
    entry = "import sys; from dresslog.cli.main import run; sys.argv[0] = 'dresslog'; run()"
    cli = [sys.executable, "-c", entry, "generate", *args, "--workers", "2", "-q"]
    done = subprocess.run(
        [*cli, "--out", str(tmp_path / "ray"), "--executor", "ray"],
        env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    local = generate("gown", 2, tmp_path / "local", workers=2, test_fraction=0.5,
                     overrides={"duration": 0.3, "sim": {"wrench_from": "momentum"}},
                     progress=False)  # fmt: skip
    assert load_manifest(tmp_path / "ray").content_hash() == local.content_hash()
    deadline = time.monotonic() + 30  # Ray's processes may take a moment to exit
    while _raylets() and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not _raylets(), "the instance it started was left running"


def _raylets() -> list[str]:
    """Running Ray node processes, by command line (Linux's /proc)."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if b"raylet" in cmdline.read_bytes():
                found.append(cmdline.parent.name)
        except OSError:  # exited meanwhile
            continue
    return found


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@ONE_PER_SPLIT
@pytest.mark.slow
def test_ray_generation_matches_the_process_pool(local_ray, tmp_path: Path) -> None:
    options = {"workers": 2, "test_fraction": 0.5, "overrides": {"duration": 0.3}}
    on_ray = generate("gown", 2, tmp_path / "ray", executor="ray", progress=False, **options)
    assert on_ray.complete and not on_ray.failures
    assert [e.file for e in load_manifest(tmp_path / "ray").trials] == [
        "test/000000.mcap",
        "train/000000.mcap",
    ]
    local = generate("gown", 2, tmp_path / "local", progress=False, **options)
    assert on_ray.content_hash() == local.content_hash()  # same seeds, same bytes
    assert ray.is_initialized()  # a cluster the caller started is left running


def full_disk_record(spec: TrialSpec, path: Path, overwrite: bool) -> None:
    """A recorder whose write the disk refuses, as `TrialWriter` reports a full disk."""
    try:
        raise OSError(28, "No space left on device")
    except OSError as err:
        raise TrialWriteError("cannot write it: No space left on device", path=path) from err


@pytest.mark.slow
def test_a_full_disk_on_ray_is_our_one_line_not_rays_traceback(local_ray, tmp_path: Path) -> None:
    """Ray raises a task's error wrapped, its str the task's traceback: the CLI printed that."""
    with pytest.raises(TrialWriteError) as caught:
        generate("gown", 2, tmp_path, executor="ray", workers=1, test_fraction=0,
                 recorder="tests.test_ray:full_disk_record", progress=False)  # fmt: skip
    file = caught.value.path  # whichever of the two trials Ray finished first
    assert file is not None and file.parent == tmp_path / "train"
    assert str(caught.value) == f"{file}: cannot write it: No space left on device"
    assert load_manifest(tmp_path).failures == []  # not retried with other seeds
