"""Shared fixtures: small trials written by the real `TrialWriter`."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dresslog.io.writer import TrialWriter
from dresslog.limb import build_limb
from dresslog.spec import Outcome, Task, TrialMetadata, TrialSpec
from dresslog.trial import CONTACT_DTYPE, LimbPoints

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "samples"

#: torch's OpenMP threads sleep between parallel regions instead of spinning (its numbers do
#: not change). Spinning, an idle thread held a core from the thread with the work whenever
#: another process wanted one: test_model.py took 64-81 s beside a 2-worker generation on
#: 2 cores, 5-6 s so. Set before torch is first imported, by a test or a spawned worker.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

N_POINTS = {Task.GOWN: 300, Task.SHORTS: 400}

#: For a test of the `Warning: ...` line a command prints: the suite makes a DresslogWarning
#: an error (pyproject.toml), which would end the command; this lets it reach the CLI's
#: printer as in a user's shell, so the test can assert the line.
prints_warnings = pytest.mark.filterwarnings("default::dresslog.errors.DresslogWarning")


def write_synthetic_trial(path: Path, task: Task = Task.GOWN, steps: int = 50) -> dict:
    """A trial with every channel filled from a seeded generator; returns what was written."""
    rng = np.random.default_rng(7)
    n = N_POINTS[task]
    t_ns = np.arange(steps, dtype=np.int64) * 10_000_000 + 1_500_000_000
    wrench = rng.normal(size=(steps, 6))
    twist = rng.normal(size=(steps, 6))
    pose = np.concatenate([rng.normal(size=(steps, 3)), np.tile([0, 0, 0, 1.0], (steps, 1))], 1)
    forces = np.where(rng.random((steps, n)) < 0.1, rng.random((steps, n)), 0).astype(np.float32)
    contacts = []
    for i in range(steps):
        c = np.zeros(i % 4, CONTACT_DTYPE)
        c["position"] = rng.normal(size=(len(c), 3))
        c["normal"] = [0, 0, 1]
        c["friction"] = rng.normal(size=(len(c), 3))
        c["normal_force"] = rng.random(len(c))
        c["segment"] = 1
        c["vertex"] = np.arange(len(c))
        contacts.append(c)
    limb = LimbPoints(
        build_limb(task).name,
        rng.normal(size=(n, 3)),
        (np.arange(n) % 3).astype(np.uint32),
        ("a", "bb", "ccc"),
    )
    vertices = rng.normal(size=(6, 3)).astype(np.float32)
    triangles = np.array([[0, 1, 2], [3, 4, 5]])
    spec = TrialSpec(task=task, seed=11, speed=0.12, limb_offset=(0.01, -0.1, 0.05))
    with TrialWriter(path, TrialMetadata(task=task, spec=spec)) as writer:
        writer.write_limb_points(int(t_ns[0]), limb)
        for i in range(steps):
            writer.write_wrench(t_ns[i], wrench[i])
            writer.write_twist(t_ns[i], twist[i])
            writer.write_pose(t_ns[i], pose[i])
            writer.write_force_map(t_ns[i], forces[i])
            writer.write_contacts(int(t_ns[i]), contacts[i])
            if i % 10 == 0:
                writer.write_garment(int(t_ns[i]), vertices + i, triangles if i == 0 else None)
        writer.metadata = writer.metadata.model_copy(update={"outcome": Outcome.DRESSED})
    return {
        "t_ns": t_ns, "wrench": wrench, "twist": twist, "pose": pose, "forces": forces,
        "contacts": contacts, "limb": limb, "vertices": vertices, "triangles": triangles,
        "spec": spec,
    }  # fmt: skip


#: One message as `write_mcap` writes it: its channel's key (one channel per key), the
#: mcap Schema, the topic, log time, payload and publish time.
McapRow = tuple[object, Any, str, int, bytes, int]


def mcap_records(path: Path) -> tuple[list[tuple[Any, Any, Any]], list[tuple[str, dict]]]:
    """Every (schema, channel, message) of an MCAP file in file order, and its metadata
    records as (name, values): what a test rewrites with a hostile or merging tool."""
    from mcap.reader import make_reader

    with path.open("rb") as stream:
        reader = make_reader(stream)
        messages = list(reader.iter_messages())
        metadata = [(m.name, m.metadata) for m in reader.iter_metadata()]
    return messages, metadata


def write_mcap(
    out: Path, library: str, rows: Iterable[McapRow], metadata: list[tuple[str, dict]]
) -> Path:
    """`rows` and `metadata` written by mcap's own writer (profile ros2, cdr), which
    writes what dresslog's writer refuses to."""
    from mcap.writer import Writer

    with out.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library=library)
        channels: dict[object, int] = {}
        for key, schema, topic, log_time, data, publish_time in rows:
            if key not in channels:
                sid = writer.register_schema(schema.name, schema.encoding, schema.data)
                channels[key] = writer.register_channel(topic, "cdr", sid)
            writer.add_message(channels[key], log_time, data, publish_time)
        for name, values in metadata:
            writer.add_metadata(name, values)
        writer.finish()
    return out


@pytest.fixture
def make_trial(tmp_path: Path) -> Callable[..., tuple[Path, dict]]:
    def make(task: Task = Task.GOWN, steps: int = 50, name: str = "trial.mcap"):
        path = tmp_path / name
        return path, write_synthetic_trial(path, task, steps)

    return make


#: The run of mypy that `tests/test_lint.py::test_mypy_is_clean` reads.
mypy_run = pytest.StashKey[subprocess.Popen[str]]()


def mypy_cache() -> Path:
    """mypy's incremental cache, kept across runs and checkouts of this environment.

    The checkout's own `.mypy_cache` is new in every fresh clone (CI's), where mypy spent
    20-50 s reading torch's and numpy's hints again. mypy checks each cached module against
    its source, so a cache shared by checkouts re-checks only what differs; one per Python
    environment and user keeps venvs of other packages from overwriting each other's.
    """
    user = os.getuid() if hasattr(os, "getuid") else 0  # a shared /tmp; Windows' is the user's
    key = hashlib.sha256(f"{sys.prefix}\0{user}".encode()).hexdigest()[:16]
    return Path(tempfile.gettempdir()) / f"dresslog-mypy-{key}"


def start_mypy() -> subprocess.Popen[str]:
    """mypy on the package (files and settings: pyproject.toml), running; output on stdout."""
    return subprocess.Popen(
        [sys.executable, "-m", "mypy", "--cache-dir", str(mypy_cache())],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,  # no test's signal to its own process group reaches it
    )


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start mypy, the suite's slowest check from a cold cache, when the run includes it:
    it type-checks on the second core while the tests before `test_lint.py` run."""
    if session.config.option.collectonly:
        return
    if any(item.nodeid.endswith("test_lint.py::test_mypy_is_clean") for item in session.items):
        session.config.stash[mypy_run] = start_mypy()


def pytest_sessionfinish(session: pytest.Session) -> None:
    """A run stopped before the mypy test (-x, Ctrl-C) leaves no mypy behind."""
    process = session.config.stash.get(mypy_run, None)
    if process is not None and process.poll() is None:
        process.kill()
        process.communicate()
