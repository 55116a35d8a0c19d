"""`--executor ray`: the same generation as Ray tasks, on a local 2-CPU Ray instance, and
on a cluster `ray start` runs, which the CLI finds or is given with --address."""

from __future__ import annotations

import contextlib
import importlib.util
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="Ray is an optional extra: pip install 'dresslog[ray]'")

from dresslog.dataset import Execution, generate, load_manifest  # noqa: E402
from dresslog.errors import TrialWriteError  # noqa: E402
from dresslog.spec import TrialSpec  # noqa: E402

#: One trial per split is all a comparison with the process pool needs; that leaves `train`
#: fewer than it takes, which `generate` warns of, beside the point here.
ONE_PER_SPLIT = pytest.mark.filterwarnings(
    "ignore:.*2 trials at --test-fraction 0.5 leave 1 to train on:dresslog.errors.DresslogWarning"
)


#: Whether this Ray has token authentication (2.5x on), which `ray start` turns on by default.
TOKENS = importlib.util.find_spec("ray._private.authentication") is not None
ARGS = ["--task", "gown", "--trials", "2", "--test-fraction", "0.5", "--duration", "0.3"]
ENTRY = "import sys; from dresslog.cli.main import run; sys.argv[0] = 'dresslog'; run()"


def _dresslog(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    """`dresslog ARGS` in a process of its own, as a user runs it."""
    return subprocess.run([sys.executable, "-c", ENTRY, *args], env=env,
                          capture_output=True, text=True, timeout=300)  # fmt: skip


def _said(done: subprocess.CompletedProcess[str]) -> list[str]:
    """Its stderr but the warning of one trial to train on, which every run here gives."""
    return [line for line in done.stderr.splitlines() if "leave 1 to train on" not in line]


def _ray_env(ray_tmp: Path) -> dict[str, str]:
    """This environment without RAY_ADDRESS, Ray's temporary folder (where `ray start`
    records its cluster's address, which `ray.init` looks up) in `ray_tmp`: a cluster
    started elsewhere on the machine is not found, nor ours by others."""
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    return {**env, "RAY_TMPDIR": str(ray_tmp)}


@pytest.fixture
def ray_tmp() -> Iterator[Path]:
    """A short temporary folder for Ray: its socket paths must stay under 108 bytes."""
    with tempfile.TemporaryDirectory(prefix="ray", dir="/tmp") as folder:
        yield Path(folder)


def _local(tmp_path: Path) -> str:
    """The content hash of the two trials made by the process pool, to compare with Ray's."""
    local = generate("gown", 2, tmp_path / "local", test_fraction=0.5,
                     overrides={"duration": 0.3, "sim": {"simulator": 9}},
                     execution=Execution(workers=2), progress=False)  # fmt: skip
    return local.content_hash()


@ONE_PER_SPLIT
@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="reads Linux's /proc")
def test_the_cli_starts_its_own_ray_instance_and_stops_it(tmp_path: Path, ray_tmp: Path) -> None:
    """What a user without a cluster gets from `dresslog generate --executor ray`."""
    before = set(_raylets())  # another's cluster on this machine is not ours to count
    done = _dresslog("generate", *ARGS, "--workers", "2", "-q", "--out", str(tmp_path / "ray"),
                     "--executor", "ray", env=_ray_env(ray_tmp))  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    assert "Started a local Ray instance" in done.stderr
    assert load_manifest(tmp_path / "ray").content_hash() == _local(tmp_path)
    deadline = time.monotonic() + 30  # Ray's processes may take a moment to exit
    while set(_raylets()) - before and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not set(_raylets()) - before, "the instance it started was left running"


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextlib.contextmanager
def ray_cluster(ray_tmp: Path) -> Iterator[str]:
    """A real 2-CPU cluster of `ray start --head` (its GCS on a free port), as a user starts
    one; its address. Stopped at the end by its own process group, not by `ray stop`,
    which stops every Ray process on the machine."""
    port = _free_port()
    command = [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block",
               "--num-cpus", "2", "--port", str(port), "--node-ip-address", "127.0.0.1",
               "--include-dashboard", "false", "--disable-usage-stats"]  # fmt: skip
    log = (ray_tmp / "start.log").open("w")
    head = subprocess.Popen(command, env=_ray_env(ray_tmp), stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)  # fmt: skip
    try:
        address = ray_tmp / "ray" / "ray_current_cluster"  # written once the cluster is up
        deadline = time.monotonic() + 90
        while not address.exists() and head.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
        if not address.exists():
            pytest.fail(f"ray start failed: {(ray_tmp / 'start.log').read_text()[-2000:]}")
        yield address.read_text().strip()
    finally:
        head.terminate()  # --block: it stops the processes it started
        try:
            head.wait(timeout=30)
        except subprocess.TimeoutExpired:
            head.kill()
        with contextlib.suppress(ProcessLookupError):  # anything of its left in its group
            os.killpg(head.pid, signal.SIGKILL)
        log.close()


@ONE_PER_SPLIT
@pytest.mark.slow
def test_the_cli_joins_a_cluster_ray_start_runs(tmp_path: Path, ray_tmp: Path) -> None:
    """Issue 50: with `ray start --head --num-cpus 2` running and no RAY_ADDRESS, the CLI
    asked Ray for a new instance of --workers CPUs, which Ray refuses for a running cluster:
    a traceback and an empty dataset folder. It joins the cluster, found or given."""
    env = _ray_env(ray_tmp)
    with ray_cluster(ray_tmp) as address:
        found = _dresslog("generate", *ARGS, "--workers", "2", "-q", "--executor", "ray",
                          "--out", str(tmp_path / "found"), env=env)  # fmt: skip
        assert found.returncode == 0, found.stderr[-2000:]
        assert "Traceback" not in found.stderr
        assert f"Connecting to existing Ray cluster at address: {address}" in found.stderr
        (elsewhere := ray_tmp / "elsewhere").mkdir()  # where no cluster is recorded
        joining = ["generate", *ARGS, "-q", "--executor", "ray", "--address", address]
        if TOKENS:  # Ray sends its token only to the cluster it finds itself, unless told to
            refused = _dresslog(*joining, "--out", str(tmp_path / "refused"),
                                env=_ray_env(elsewhere))  # fmt: skip
            assert refused.returncode == 1
            assert _said(refused) == [
                f"Error: cannot join the Ray cluster at {address}: the cluster asks for a token "
                "(Ray's default for `ray start`); set RAY_AUTH_MODE=token, with the cluster's "
                "token in ~/.ray/auth_token or RAY_AUTH_TOKEN"
            ]
            assert not (tmp_path / "refused").exists()
        given = _dresslog(*joining, "--out", str(tmp_path / "given"),
                          env={**_ray_env(elsewhere), "RAY_AUTH_MODE": "token"})  # fmt: skip
        assert given.returncode == 0, given.stderr[-2000:]
        assert f"Connecting to existing Ray cluster at address: {address}" in given.stderr
    hashes = {load_manifest(tmp_path / name).content_hash() for name in ("found", "given")}
    assert hashes == {_local(tmp_path)}

    # the cluster gone: one line, exit 1, and no dataset folder left behind
    gone = _dresslog("generate", *ARGS, "-q", "--executor", "ray", "--address", address,
                     "--out", str(tmp_path / "new" / "gone"), env=env)  # fmt: skip
    assert gone.returncode == 1
    assert len(_said(gone)) == 1, gone.stderr
    assert _said(gone)[0].startswith(f"Error: cannot join the Ray cluster at {address}: ")
    assert not (tmp_path / "new").exists()


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
    options = {"test_fraction": 0.5, "overrides": {"duration": 0.3}, "progress": False}
    on_ray = generate(
        "gown", 2, tmp_path / "ray", execution=Execution(workers=2, executor="ray"), **options
    )
    assert on_ray.complete and not on_ray.failures
    assert [e.file for e in load_manifest(tmp_path / "ray").trials] == [
        "test/000000.mcap",
        "train/000000.mcap",
    ]
    local = generate("gown", 2, tmp_path / "local", execution=Execution(workers=2), **options)
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
        on_ray = Execution(executor="ray", workers=1, recorder=full_disk_record)
        generate("gown", 2, tmp_path, test_fraction=0, execution=on_ray, progress=False)
    file = caught.value.path  # whichever of the two trials Ray finished first
    assert file is not None and file.parent == tmp_path / "train"
    assert str(caught.value) == f"{file}: cannot write it: No space left on device"
    assert load_manifest(tmp_path).failures == []  # not retried with other seeds
