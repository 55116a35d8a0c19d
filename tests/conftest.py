"""Shared fixtures: small trials written by the real `TrialWriter`, and the helpers that
tests in several folders use (tests/README.md maps them)."""

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
from mcap.writer import Writer

from dresslog.dataset import Split, trial_seed
from dresslog.errors import SimulationError
from dresslog.io import cdr
from dresslog.io import well_known as wk
from dresslog.io.msgdefs import schema_text
from dresslog.io.reader import TrialReader
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


# Helpers that tests in several folders share: a recorder without pybullet, MCAPs written
# by mcap's own writer (not ours), and a trial as a force/torque CSV.

#: The seed `fake_record` fails on: slot 1 of the train split, first attempt.
FAILING_SEED = trial_seed(0, Split.TRAIN, 1, 0)


class RecordResult:
    """What `generate` reads of a recorder's result: the outcome and the step count."""

    outcome = "dressed"
    steps = 20


def fake_record(spec: TrialSpec, path: Path, *, overwrite: bool = False) -> RecordResult:
    """A recorder without pybullet (for failure paths): fails on one seed, or on every one."""
    if spec.seed == FAILING_SEED or spec.speed == 0.99:
        raise SimulationError(f"garment exploded (seed {spec.seed})")
    write_synthetic_trial(Path(path), spec.task, steps=20)
    return RecordResult()


def raw_mcap(
    path: Path, channels: dict[str, tuple[str, list[bytes]]], metadata: bool | dict[str, str]
) -> None:
    """An MCAP written with mcap's own writer: topic -> (schema name, payloads); the
    metadata record a new trial's, none, or the one given."""
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="another tool")
        for topic, (schema, payloads) in channels.items():
            sid = writer.register_schema(schema, "ros2msg", schema_text(schema).encode())
            cid = writer.register_channel(topic, "cdr", sid)
            for i, payload in enumerate(payloads):
                writer.add_message(cid, i * 10_000_000, payload, i * 10_000_000, i)
        if metadata is True:
            metadata = {"task": "gown", "trial": TrialMetadata(task=Task.GOWN).model_dump_json()}
        if metadata:
            writer.add_metadata(wk.METADATA_NAME, metadata)
        writer.finish()


def vector_payloads(schema: str, fields: tuple[str, str], values: np.ndarray) -> list[bytes]:
    """CDR payloads of `schema` at 100 Hz, its two vector `fields` from `values` (N x 6)."""
    msgs = cdr.new_messages(schema, {"header.frame_id": 2}, len(values))
    cdr.set_stamp(msgs, np.arange(len(values)) * 10_000_000, "ee")
    msgs[fields[0]], msgs[fields[1]] = values[:, :3], values[:, 3:]
    return cdr.to_payloads(msgs)


WRENCH = ("geometry_msgs/msg/WrenchStamped", ("wrench.force", "wrench.torque"))


TWIST = ("geometry_msgs/msg/TwistStamped", ("twist.linear", "twist.angular"))


def missing_twist(tmp: Path, good: Path) -> Path:
    path = tmp / "no_twist.mcap"
    raw_mcap(path, {wk.WRENCH: (WRENCH[0], vector_payloads(*WRENCH, np.zeros((3, 6))))}, True)
    return path


def nan_wrench(tmp: Path, good: Path) -> Path:
    path = tmp / "nan.mcap"
    values = np.zeros((3, 6))
    values[1, 2] = np.nan
    channels = {
        wk.WRENCH: (WRENCH[0], vector_payloads(*WRENCH, values)),
        wk.TWIST: (TWIST[0], vector_payloads(*TWIST, np.zeros((3, 6)))),
    }
    raw_mcap(path, channels, True)
    return path


def csv_of(trial: Path, out: Path, fz_offset: float = 0.0, turn: np.ndarray | None = None) -> Path:
    """The trial's wrench and velocity as a force/torque CSV, fz shifted (a sensor not
    tared) and every vector turned by the rotation matrix `turn` (another robot's axes)."""
    with TrialReader(trial) as reader:
        m = reader.read().measurements
    phi = m.phi.astype(np.float64)
    phi[:, 2] += fz_offset
    if turn is not None:
        phi = (phi.reshape(-1, 3, 3) @ turn.T).reshape(-1, 9)
    header = "Time (s),Fx (N),Fy (N),Fz (N),Mx (Nm),My (Nm),Mz (Nm),vx (m/s),vy (m/s),vz (m/s)"
    rows = np.column_stack([(m.t_ns - m.t_ns[0]) / 1e9, phi])
    out.write_text(header + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in rows) + "\n")
    return out
