"""Run generation jobs as Ray tasks: the same `run_job`, on a cluster (``dresslog[ray]``).

Ray is imported only here and only when asked for. If Ray is already initialised
(a script called ``ray.init``), its cluster is used; otherwise ``RAY_ADDRESS`` names
one to join, and without it a local instance with `workers` CPUs is started. Each
job is one task of one CPU; the dataset folder must be on storage every node sees.
"""

from __future__ import annotations

import contextlib
import os
from typing import Any

from dresslog.dataset.executors import Job, run_job
from dresslog.dataset.manifest import Entry
from dresslog.errors import DatasetError, DresslogError

INSTALL_HINT = "pip install 'dresslog[ray]'"


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

    def __init__(self, workers: int) -> None:
        self._ray = ray = import_ray()
        self._started = False
        if not ray.is_initialized():
            address = os.environ.get("RAY_ADDRESS")
            kwargs = {"address": address} if address else {"num_cpus": workers}
            ray.init(log_to_driver=False, **kwargs)
            self._started = True
        # Worker crashes (node lost, OOM) are retried by Ray; a raised error is not.
        self._remote = ray.remote(num_cpus=1, max_retries=2)(run_job)
        self._refs: list[Any] = []

    def submit(self, job: Job) -> None:
        self._refs.append(self._remote.remote(job))

    def done(self, timeout: float) -> list[Entry]:
        ready, self._refs = self._ray.wait(self._refs, num_returns=1, timeout=timeout)
        try:
            return list(self._ray.get(ready))
        except self._ray.exceptions.RayTaskError as err:  # a full disk, say: its own line,
            if isinstance(err.cause, DresslogError):  # not Ray's of the task's traceback
                raise err.cause from None
            raise

    def pending(self) -> int:
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
