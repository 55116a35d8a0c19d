"""Run generation jobs as Ray tasks: the same `run_job`, on a cluster (``dresslog[ray]``).

Ray is imported only here and only when asked for. The cluster is, in this order: the
one a script already joined (it called ``ray.init``); the one ``address`` names (the
CLI's ``--address``), else ``RAY_ADDRESS``; the one ``ray start`` runs on this machine;
else a new local instance of `workers` CPUs, stopped again at the end. Each job is one
task of one CPU; the dataset folder must be at the same path on every node (shared
storage, such as NFS).
"""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import tempfile
from collections.abc import Iterator
from typing import Any

from dresslog.dataset.executors import Job, run_job
from dresslog.dataset.manifest import Entry
from dresslog.errors import DatasetError, DresslogError

INSTALL_HINT = "pip install 'dresslog[ray]'"
#: Seconds to wait for a cluster's address to answer: Ray itself retries a dead one for
#: minutes, printing a line every few seconds.
ANSWER_S = 5.0


def import_ray() -> Any:
    """The `ray` module, or a `DatasetError` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise DatasetError(
            f"--executor ray needs Ray, which is not installed: {INSTALL_HINT}"
        ) from None
    return ray


class RayExecutor:
    """Submit jobs as Ray tasks and collect them as they finish, in any order."""

    def __init__(self, workers: int, address: str | None = None) -> None:
        self._ray = ray = import_ray()
        self._started = False
        if not ray.is_initialized():
            connect(ray, workers, address)
            self._started = True
        # Worker crashes (node lost, OOM) are retried by Ray; a raised error is not.
        self._remote = ray.remote(num_cpus=1, max_retries=2)(run_job)
        self._refs: list[Any] = []

    def submit(self, job: Job) -> None:
        """Queue `job` as a Ray task of one CPU."""
        self._refs.append(self._remote.remote(job))

    def done(self, timeout: float) -> list[Entry]:
        """The entries of the tasks finished within `timeout` seconds (one at most); a task's
        DresslogError (a full disk) is raised as itself, not as Ray's traceback."""
        ready, self._refs = self._ray.wait(self._refs, num_returns=1, timeout=timeout)
        try:
            return list(self._ray.get(ready))
        except self._ray.exceptions.RayTaskError as err:  # a full disk, say: its own line,
            if isinstance(err.cause, DresslogError):  # not Ray's of the task's traceback
                raise err.cause from None
            raise

    def pending(self) -> int:
        """How many submitted tasks `done` has not returned yet."""
        return len(self._refs)

    def shutdown(self) -> list[Entry]:
        """Collect the tasks already finished, cancel the rest."""
        ready: list[Any] = []
        if self._refs:
            ready, rest = self._ray.wait(self._refs, num_returns=len(self._refs), timeout=0)
            for ref in rest:
                self._ray.cancel(ref, force=True)
        finished = []
        for ref in ready:
            with contextlib.suppress(Exception):  # a task that raised left no trial
                finished.append(self._ray.get(ref))
        self._refs = []
        if self._started:
            self._ray.shutdown()
        return finished


def connect(ray: Any, workers: int, address: str | None = None) -> None:
    """Join the cluster at `address` (else ``RAY_ADDRESS``), else the one ``ray start``
    runs on this machine, else start a local instance of `workers` CPUs.

    Only a new instance takes `workers`: Ray refuses CPU counts for a running cluster,
    whose own ``--num-cpus`` decide. A cluster that does not answer, or refuses us, is a
    `DatasetError` of one line, before the dataset folder is written.
    """
    address = address or os.environ.get("RAY_ADDRESS") or None
    told = address is not None
    if address is None:
        address = running_cluster(ray)
    if address is None or address == "local":
        _init(ray, "cannot start a local Ray instance", address="local", num_cpus=workers)
        return
    where = f"the Ray cluster at {address}"
    if not told:
        where += " (run by `ray start` on this machine)"
    if (silent := _silent(address)) is not None:
        raise DatasetError(f"cannot join {where}: {silent}")
    # "auto" (the cluster found here) takes up its token, as Ray does for no address
    # given only: it never sends the token to an address given to it
    _init(ray, f"cannot join {where}", address=address if told else "auto")
    if not ray.cluster_resources().get("CPU"):
        ray.shutdown()
        raise DatasetError(f"{where} has no CPUs to run trials on")


def running_cluster(ray: Any) -> str | None:
    """The address of the cluster ``ray start`` last started on this machine (recorded in
    Ray's temporary folder, as ``ray.init(address="auto")`` finds it), if it answers.

    A cluster killed without ``ray stop`` leaves its address behind: it is passed over,
    and a local instance started, where Ray would wait minutes for it.
    """
    try:
        from ray._private.services import find_bootstrap_address
    except ImportError:  # Ray's own lookup moved: a local instance of our own
        return None
    try:
        found = find_bootstrap_address(None)
    except OSError:
        return None
    if not found or _silent(found) is not None:
        return None
    return str(found)


def _silent(address: str) -> str | None:
    """Why nothing answers at `address` (`host:port`, `ray://host:port`), or None if it
    answers, or is not an address to try (`auto`)."""
    host, _, port = address.rpartition("://")[2].rstrip("/").rpartition(":")
    if not host or not port.isdigit():
        return None if address == "auto" else "not an address (HOST:PORT, ray://HOST:PORT)"
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=ANSWER_S).close()
    except OSError as err:
        reason = "no answer" if isinstance(err, TimeoutError) else err.strerror or str(err)
        return f"{reason} (is its head running? `ray start --head` prints the address to join)"
    return None


#: What Ray says, every second for about 10 s, of a cluster that asks for a token.
_NO_TOKEN = ("Unauthenticated", "InvalidAuthToken")
_TOKEN_HINT = (
    "the cluster asks for a token (Ray's default for `ray start`); set RAY_AUTH_MODE=token, "
    "with the cluster's token in ~/.ray/auth_token or RAY_AUTH_TOKEN"
)


def _init(ray: Any, failing: str, **kwargs: Any) -> None:
    """`ray.init`, whose errors (a version mismatch, a refused connection) become one line,
    `failing` saying what could not be done.

    What Ray prints meanwhile is held back: on success it is shown (the cluster joined),
    on failure our line says it, not Ray's retries, one a second.
    """
    said: list[str] = []
    try:
        with _stderr_held(said):
            ray.init(log_to_driver=False, **kwargs)
    except Exception as err:  # Ray raises ValueError, RuntimeError, ConnectionError alike
        with contextlib.suppress(Exception):
            ray.shutdown()
        reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        if any(word in "".join(said) for word in _NO_TOKEN):
            reason = _TOKEN_HINT
        raise DatasetError(f"{failing}: {reason}") from None
    sys.stderr.write("".join(said))


@contextlib.contextmanager
def _stderr_held(said: list[str]) -> Iterator[None]:
    """Send this process's stderr (Python's and Ray's C++ core's, file descriptor 2) to a
    temporary file; what was written is appended to `said` at the end."""
    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no stderr to hold
        yield
        return
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)
        try:
            yield
        finally:
            with contextlib.suppress(Exception):
                sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            held.seek(0)
            said.append(held.read().decode(errors="replace"))
