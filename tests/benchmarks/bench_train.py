"""Training speed: dataset load from MCAP (cold) and from the cache, and one epoch.

Target (issue 5): one epoch of the paper's network over 1,000 sequences of 700 steps
on 2 CPU cores well under a minute; load times reported.

    python tests/benchmarks/bench_train.py [--task gown] [--sequences 1000] [--distinct 8]

Simulating 1,000 seven-second trials takes most of an hour on 2 cores, so the script
simulates `--distinct` real trials and lists each many times (hard links under
distinct names) in a dataset manifest: every file is a real recording decoded in
full, only the content repeats. "Cold" means decoded from MCAP (the files may be in
the OS page cache), "cache" means read from the `.npz` the cold load wrote.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from dresslog.dataset import Execution, Split, generate, load_dataset
from dresslog.dataset.manifest import Manifest


def replicate(src: Path, dst: Path, sequences: int) -> None:
    """A dataset at `dst` listing `sequences` hard links to the trials of `src`."""
    base = Manifest.model_validate_json((src / "manifest.json").read_text())
    originals = base.split(Split.TRAIN)
    (dst / "train").mkdir(parents=True)
    entries = []
    for slot in range(sequences):
        entry = originals[slot % len(originals)]
        name = f"train/{slot:06d}.mcap"
        os.link(src / str(entry.file), dst / name)
        entries.append(entry.model_copy(update={"slot": slot, "file": name}))
    manifest = base.model_copy(update={"n_train": sequences, "trials": entries})
    manifest.save(dst)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="gown", choices=["gown", "shorts"])
    parser.add_argument("--sequences", type=int, default=1000)
    parser.add_argument("--distinct", type=int, default=8, help="real trials to simulate")
    parser.add_argument("--threads", type=int, default=2, help="torch CPU threads")
    parser.add_argument("--workers", type=int, default=2, help="processes for decoding")
    args = parser.parse_args()

    import torch

    from dresslog.model.options import TrainOptions
    from dresslog.model.train import train

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        started = time.perf_counter()
        generate(
            args.task,
            args.distinct,
            root / "src",
            execution=Execution(workers=args.workers),
            test_fraction=0,
        )
        simulated = time.perf_counter() - started
        replicate(root / "src", root / "bench", args.sequences)

        started = time.perf_counter()
        arrays = load_dataset(root / "bench", workers=args.workers)
        cold = time.perf_counter() - started
        started = time.perf_counter()
        arrays = load_dataset(root / "bench", progress=False)
        cached = time.perf_counter() - started
        cache_mb = sum(p.stat().st_size for p in (root / "bench/.cache").glob("*.npz")) / 1e6

        rows = arrays.rows(Split.TRAIN)
        epoch = {}  # one epoch on each device there is: the CPU, and CUDA where torch sees it
        for device in ("cpu", "cuda") if torch.cuda.is_available() else ("cpu",):
            options = TrainOptions(epochs=1, threads=args.threads, val_fraction=0.0, device=device)
            _, history = train(arrays.sequences(rows), arrays.force_maps(rows), options)
            epoch[device] = history.epochs[0].seconds

    s, t, n = arrays.forces.shape
    print(f"task {args.task}: {s} sequences x {t} steps x {n} limb points")
    print(f"simulate {args.distinct} distinct trials ({args.workers} workers): {simulated:7.1f} s")
    print(f"load from MCAP, cold ({args.workers} workers):          {cold:7.1f} s")
    print(f"load from cache ({cache_mb:.0f} MB .npz):                {cached:7.1f} s")
    print(f"one epoch, paper's network, {args.threads} threads:        {epoch['cpu']:7.1f} s")
    if "cuda" in epoch:
        ratio = epoch["cpu"] / epoch["cuda"]
        print(f"one epoch on CUDA ({torch.cuda.get_device_name()}):  {epoch['cuda']:7.1f} s "
              f"({ratio:.1f}x the CPU's)")  # fmt: skip
    else:
        print("one epoch on CUDA: no CUDA device here (torch sees none)")


if __name__ == "__main__":
    main()
