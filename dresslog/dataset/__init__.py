"""Datasets: many trials in a folder with a manifest, generated in parallel, cached as tensors.

`generate` fills a folder (resumably), `load_manifest` reads its index, `load_dataset`
returns every trial decoded into padded arrays, cached beside the data. `generate` runs
the trials as its `Execution` says (``LOCAL``: a process pool, one worker per core) and
records each with its `Recorder`, the simulator's `record_trial` unless told otherwise.
"""

from dresslog.dataset.cache import DatasetArrays, cache_path, load_dataset
from dresslog.dataset.executors import LOCAL, Execution, Recorder
from dresslog.dataset.generate import generate
from dresslog.dataset.manifest import (
    Entry,
    Manifest,
    Split,
    Status,
    check_files,
    load_manifest,
    trial_seed,
)

__all__ = [
    "LOCAL",
    "DatasetArrays",
    "Entry",
    "Execution",
    "Manifest",
    "Recorder",
    "Split",
    "Status",
    "cache_path",
    "check_files",
    "generate",
    "load_dataset",
    "load_manifest",
    "trial_seed",
]
