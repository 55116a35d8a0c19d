"""What spreading a node's force over its cloth (simulator v7) does to the score, on one dataset.

A v7 recording holds both ground truths: `/limb/force_map` (each node's contact force
spread over the cloth around it before the k = 5 sharing) and `/limb/contacts`, whose
positions and forces give back the map of simulator v6 and before (each node's force
shared from its own place). This script trains the same recipe on each, on the same
trials with the same seed, and scores each on the test split against its own truth:

    python scripts/node_maps.py data/gown [--epochs 60] [--json runs/node_maps-gown.json]
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np


def node_map(path: str) -> np.ndarray:
    """The force map (T, N) of simulator v6 and before, rebuilt from the trial's contacts."""
    from dresslog.force_map import ForceDistributor
    from dresslog.io.reader import TrialReader
    from dresslog.trial import contact_magnitudes

    with TrialReader(path) as trial:
        share = ForceDistributor(trial.limb_points.points)
        return np.stack([share(c["position"], contact_magnitudes(c)) for c in trial.contacts.items])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path)
    parser.add_argument("--epochs", type=int, default=60)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    from dresslog.dataset import load_dataset
    from dresslog.dataset.manifest import Split
    from dresslog.model.evaluate import score_sequences
    from dresslog.model.numpy_lstm import NumpyEstimator
    from dresslog.model.options import TrainOptions
    from dresslog.model.train import train

    arrays = load_dataset(args.data)
    train_rows, test_rows = arrays.rows(Split.TRAIN), arrays.rows(Split.TEST)
    rows = [*train_rows, *test_rows]
    with ProcessPoolExecutor(2) as pool:
        files = [str(args.data / arrays.files[r]) for r in rows]
        nodes = {
            r: m[: arrays.lengths[r]] for r, m in zip(rows, pool.map(node_map, files), strict=True)
        }
    truths = {
        "spread (v7)": dict(zip(rows, arrays.force_maps(rows), strict=True)),
        "at the node (v6)": nodes,
    }
    phi = dict(zip(rows, arrays.sequences(rows), strict=True))
    report: dict[str, dict[str, float]] = {}
    for name, maps in truths.items():
        weights, history = train(
            [phi[r] for r in train_rows],
            [maps[r] for r in train_rows],
            TrainOptions(
                epochs=args.epochs,
                normalise=True,
                balance_loss=True,
                keep_best=True,
                lr_schedule="cosine",
            ),
        )
        test_maps = [maps[r] for r in test_rows]
        scores = score_sequences(
            NumpyEstimator(weights), [phi[r] for r in test_rows], test_maps
        ).scores()
        report[name] = {
            "ratio": scores.ratio,
            "rmse": scores.rmse,
            "zero_rmse": scores.zero_rmse,
            "kept_epoch": history.kept.epoch,
        }
        print(
            f"{name}: ratio {scores.ratio:.3f} (RMSE {scores.rmse:.5f} N, all-zero "
            f"{scores.zero_rmse:.5f} N, epoch {history.kept.epoch} kept)",
            flush=True,
        )
    if args.json:
        args.json.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()
