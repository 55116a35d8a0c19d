"""Where a dataset's trials run: a local process pool, or Ray tasks on a cluster.

A `Job` (one attempt at one slot) is plain data and a `Recorder`, by default the
simulator's `record_trial`; `run_job` records it in a worker and returns its manifest
`Entry`, a failed one if the simulation went unstable. A recorder is a module-level
function, which pickles by reference (its module and name), so a job travels to a
process-pool worker or a Ray task as it did when it named the function as a string. Ctrl-C and
a kill reach every worker; `_Worker` stops the trial being written without leaving its
temporary file and keeps the pool whole.
"""

from __future__ import annotations

import ctypes
import operator
import os
import signal
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Final, Literal, Protocol, runtime_checkable

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from dresslog.dataset.manifest import Entry, Split, Status, slot_file
from dresslog.errors import DatasetError, DresslogError, SimulationError
from dresslog.io.files import discard_temporaries, sha256_file
from dresslog.sim import record_trial
from dresslog.spec import Outcome, TrialSpec
from dresslog.stops import deferred_in_children, hangup, unblock_stops

ExecutorName = Literal["process", "ray"]
#: Attempts per slot before generation gives up on it (each attempt is a fresh seed).
MAX_ATTEMPTS = 5


class Recorded(Protocol):
    """What a recorder says of the trial it wrote (the simulator's `SimResult` says more)."""

    @property
    def outcome(self) -> str:
        """How the trial went: an `Outcome` value (dressed, missed, caught)."""
        ...

    @property
    def steps(self) -> int:
        """The 100 Hz steps written."""
        ...


@runtime_checkable
class Recorder(Protocol):
    """Simulates `spec` and writes the trial to `path`, as `dresslog.sim.record_trial`
    does; raises a `DresslogError` for a trial that failed. A module-level function, so
    that a job carrying it pickles to a worker process or a Ray task."""

    def __call__(self, spec: TrialSpec, path: Path, *, overwrite: bool) -> Recorded: ...


class Execution(BaseModel):
    """Where and how a dataset's trials run: the one object `generate` and `sweep` take
    for it, built once (by the command from its options) and passed whole.

    Fields out of range are refused when it is built; whether the executor can run here
    (Ray installed, a cluster answering) is `check_executor`'s, when work starts.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", arbitrary_types_allowed=True)

    #: trials simulated at once (and trials decoded at once, by `sweep`); None or 0: one
    #: per core
    workers: int | None = None
    #: "process": a local process pool; "ray": Ray tasks on a cluster (`dresslog[ray]`)
    executor: ExecutorName = "process"
    #: the Ray cluster to join; None: `RAY_ADDRESS`'s, else one `ray start` runs here,
    #: else a new local one
    ray_address: str | None = None
    #: seeds tried per slot before generation gives up on it
    max_attempts: int = Field(MAX_ATTEMPTS, ge=1)
    #: what records a trial: the simulator's `record_trial`, or a test's stand-in
    recorder: Recorder = record_trial

    @field_validator("workers", mode="before")
    @classmethod
    def _whole_workers(cls, value: object) -> int | None:
        """A whole number of workers (numpy's too), 0 or more."""
        if value is None:
            return None
        try:
            whole = operator.index(value)  # type: ignore[arg-type]
        except TypeError:
            whole = -1
        if whole < 0:
            raise ValueError(f"--workers must be a whole number (0: all cores), not {value!r}")
        return whole

    @model_validator(mode="after")
    def _address_for_ray(self) -> Execution:
        if self.ray_address is not None and self.executor != "ray":
            raise ValueError(
                f"a Ray cluster's address is for the 'ray' executor, not {self.executor!r}"
            )
        return self

    def pool_size(self) -> int:
        """The workers to start: `workers`, or one per core."""
        return self.workers or os.cpu_count() or 1


#: Generation's default: a local process pool of one worker per core, the simulator.
LOCAL: Final = Execution()


@dataclass(frozen=True)
class Job:
    """One attempt at one slot; plain data, so it pickles to a process or a Ray worker."""

    root: str
    split: Split
    slot: int
    attempt: int
    spec: TrialSpec
    recorder: Recorder = record_trial

    @property
    def file(self) -> str:
        """The slot's file, relative to the dataset folder: `train/000003.mcap`."""
        return slot_file(self.split, self.slot)


class _Worker:
    """A pool worker's view of Ctrl-C, which the terminal sends to every process.

    The trial being recorded stops at once (its temporary file is removed) and queued
    trials are not started; an idle worker stays alive, so the pool never breaks and
    never has to kill a worker in the middle of a file. A generation stopped by a signal
    to it alone (``kill PID``) tells its workers through `stopping`, and they stop the
    same way; one killed outright (``kill -9``, out of memory) cannot, so its workers
    stop the same way when they see it gone, and exit: they would otherwise wait for
    work forever.
    """

    writing: Path | None = None  # the trial being recorded
    interrupted = False

    @classmethod
    def start(cls, stopping: ctypes.c_bool) -> None:
        signal.signal(signal.SIGINT, cls._on_interrupt)
        if (number := hangup()) is not None:  # a closed terminal: as Ctrl-C (unless nohup)
            signal.signal(number, cls._on_interrupt)
        signal.signal(signal.SIGTERM, cls._on_terminate)
        unblock_stops()  # one that came while this worker imported is taken now
        watch = threading.Thread(target=cls._watch, args=(os.getppid(), stopping), daemon=True)
        watch.start()

    @classmethod
    def _watch(cls, parent: int, stopping: ctypes.c_bool) -> None:
        """Interrupt as Ctrl-C when the generation stops (after a kill to it alone, the
        worker went on with its trial and the next queued) or is gone.

        `stopping` is a shared flag without a lock, polled: a worker killed while it
        waited on an Event left the parent's `set()` waiting for it forever.
        """
        told = False
        while os.getppid() == parent:
            time.sleep(0.1)
            if not told and stopping.value:
                told = True
                if not cls.interrupted:  # not by the terminal's Ctrl-C already
                    _interrupt_main_thread()
        _interrupt_main_thread()
        deadline = time.monotonic() + 5.0
        while cls.writing is not None and time.monotonic() < deadline:
            time.sleep(0.05)  # the trial stops and removes its temporary file
        cls._exit(1)  # the interrupt may have gone astray (into cleanup code)

    @classmethod
    def _on_terminate(cls, signum: int, frame: object) -> None:
        """Still the end (the pool terminates a broken worker so), minus the temporary."""
        cls._exit(128 + signum)

    @classmethod
    def _exit(cls, code: int) -> None:
        """Exit now, removing the temporary file of a trial still being recorded."""
        if cls.writing is not None:
            discard_temporaries(cls.writing)
        os._exit(code)

    @classmethod
    def _on_interrupt(cls, signum: int, frame: object) -> None:
        cls.interrupted = True
        if cls.writing is not None:
            raise KeyboardInterrupt


def _interrupt_main_thread() -> None:
    """Ctrl-C to this process's main thread, which it wakes from a sleep or a wait, as a
    terminal's does (`os.kill` would end the process on Windows, which has no pthreads)."""
    main = threading.main_thread().ident
    if hasattr(signal, "pthread_kill") and main is not None:
        signal.pthread_kill(main, signal.SIGINT)
    else:
        signal.raise_signal(signal.SIGINT)


def run_job(job: Job) -> Entry:
    """Simulate and record one trial; an unstable simulation becomes a failed entry.

    Runs in a worker. Only `DresslogError`s count as trial failures; any other
    exception is a bug and propagates, stopping the generation, as does a write the disk
    refused (full, read-only): every trial after it would fail alike, each after its
    simulation, and be retried with fresh seeds to no end.
    """
    if _Worker.interrupted:
        raise KeyboardInterrupt
    path = Path(job.root) / job.file
    started = time.perf_counter()
    base = {"split": job.split, "slot": job.slot, "attempt": job.attempt, "spec": job.spec}
    try:
        _Worker.writing = path
        result = job.recorder(job.spec, path, overwrite=True)
    except DresslogError as err:
        path.unlink(missing_ok=True)
        if isinstance(err.__cause__, OSError):  # the disk's, not the trial's
            raise
        reason = err.message if isinstance(err, SimulationError) else str(err)
        return Entry(
            **base,
            status=Status.FAILED,
            outcome=Outcome.FAILED,
            failure=f"{type(err).__name__}: {reason}",
            seconds=time.perf_counter() - started,
        )
    finally:
        _Worker.writing = None
    return Entry(
        **base,
        status=Status.OK,
        file=job.file,
        outcome=Outcome(result.outcome),
        steps=int(result.steps),
        size=path.stat().st_size,
        sha256=sha256_file(path),
        seconds=time.perf_counter() - started,
    )


class Executor(Protocol):
    """Runs jobs somewhere; `done(timeout)` returns the jobs finished by then, maybe none.

    `shutdown()` stops the work and returns the jobs that finished meanwhile (after an
    interrupt, workers may complete what they had started), so none goes unrecorded.
    """

    def submit(self, job: Job) -> None:
        """Queue `job`; it runs as soon as a worker is free."""
        ...

    def done(self, timeout: float) -> list[Entry]:
        """The entries of the jobs finished within `timeout` seconds, maybe none; a job that
        raised a bug raises it here."""
        ...

    def pending(self) -> int:
        """How many submitted jobs have not been returned by `done` yet."""
        ...

    def shutdown(self) -> list[Entry]:
        """Stop the work; returns the entries of the jobs that finished meanwhile."""
        ...


def _start_resource_tracker() -> None:
    """Start multiprocessing's resource tracker deaf to SIGHUP, as it is to Ctrl-C and kill.

    A closed terminal hangs up the whole process group: the tracker died of it, and its
    replacement printed a traceback for each of the pool's semaphores. It still ends when
    dresslog does (its pipe closes).
    """
    from multiprocessing import resource_tracker

    with deferred_in_children():  # inherited across the tracker's exec
        resource_tracker.ensure_running()


class ProcessExecutor:
    """A local process pool (spawned workers: no pybullet or torch state is forked)."""

    def __init__(self, workers: int) -> None:
        import multiprocessing

        _start_resource_tracker()
        context = multiprocessing.get_context("spawn")
        self._stopping = context.RawValue(ctypes.c_bool, False)
        self._pool = ProcessPoolExecutor(
            workers, mp_context=context, initializer=_Worker.start, initargs=(self._stopping,)
        )
        self._futures: set[Future[Entry]] = set()

    def submit(self, job: Job) -> None:
        """Queue `job` in the pool (which may start a worker, deaf to a stop while it starts)."""
        with deferred_in_children():  # a submission may start a worker
            self._futures.add(self._pool.submit(run_job, job))

    def done(self, timeout: float) -> list[Entry]:
        """Finished entries; a job that raised (a bug) raises once the others are out."""
        finished, _ = wait(self._futures, timeout, return_when=FIRST_COMPLETED)
        ok = {f for f in finished if f.exception() is None}
        if not ok:
            for f in finished:
                f.result()
        self._futures -= ok
        return [f.result() for f in ok]

    def pending(self) -> int:
        """How many submitted jobs `done` has not returned yet."""
        return len(self._futures)

    def shutdown(self) -> list[Entry]:
        """Stop the pool, telling busy workers to stop their trials; returns the entries of the
        jobs that finished meanwhile."""
        if any(not f.done() for f in self._futures):  # stopped: the workers stop too
            self._stopping.value = True
        self._pool.shutdown(wait=True, cancel_futures=True)
        finished = [f for f in self._futures if f.done() and not f.cancelled()]
        self._futures = set()
        return [f.result() for f in finished if f.exception() is None]


def make_executor(name: ExecutorName | str, workers: int, address: str | None = None) -> Executor:
    """The pool for `name`, which `check_executor` has passed; `address` is the Ray
    cluster's to join (else `RAY_ADDRESS`'s, else one running here, else a new one)."""
    if name == "ray":
        from dresslog.dataset.ray_executor import RayExecutor

        return RayExecutor(workers, address)
    return ProcessExecutor(workers)


def check_executor(name: ExecutorName | str, address: str | None = None) -> None:
    """Fail before anything is written when `name` cannot run here (Ray not installed), or
    is given a Ray cluster's `address` it would not use."""
    if address is not None and name != "ray":
        raise DatasetError(f"a Ray cluster's address is for the 'ray' executor, not {name!r}")
    if name == "ray":
        from dresslog.dataset.ray_executor import import_ray

        import_ray()
    elif name != "process":
        raise DatasetError(f"unknown executor {name!r}; use 'process' or 'ray'")
