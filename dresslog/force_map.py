"""The ground-truth force map: each contact's magnitude shared among its k nearest limb points.

Point l of the k nearest gets (1/(k-1)) (1 - d_l / sum_p d_p) |f_j|, so the
shares of one contact sum to |f_j| and nearer points get more (Sec. IV-B).
"""

from __future__ import annotations

import numpy as np


class ForceDistributor:
    """`distribute` onto fixed limb points (N, 3), with their squared norms computed once."""

    def __init__(self, limb_points: np.ndarray, k: int = 5) -> None:
        self.limb_points = limb_points
        self.k = min(k, len(limb_points))
        self._sq = np.sum(limb_points**2, axis=1)[None, :]
        self._points_t = limb_points.T

    def __call__(self, positions: np.ndarray, magnitudes: np.ndarray) -> np.ndarray:
        """Force map (N,) float32 from contacts at `positions` (C, 3) with `magnitudes` (C,)."""
        n, k = len(self.limb_points), self.k
        if len(positions) == 0:
            return np.zeros(n, dtype=np.float32)
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        magnitudes = np.asarray(magnitudes, dtype=np.float64).reshape(-1)
        d2 = (positions**2).sum(axis=1)[:, None] - 2.0 * positions @ self._points_t + self._sq
        idx = (
            np.argpartition(d2, k - 1, axis=1)[:, :k]
            if k < n
            else np.tile(np.arange(n), (len(d2), 1))
        )
        d = np.sqrt(np.maximum(d2[np.arange(len(d2))[:, None], idx], 0.0))
        if k == 1:
            w = np.ones_like(d)
        else:
            total = d.sum(axis=1, keepdims=True)
            touching = total > 0
            safe = np.where(touching, total, 1.0)
            w = np.where(touching, (1.0 - d / safe) / (k - 1), 1.0 / k)
        # bincount adds the shares in index order starting from 0.0, as np.add.at into zeros does
        out = np.bincount(idx.ravel(), (w * magnitudes[:, None]).ravel(), minlength=n)
        return out.astype(np.float32)


def distribute(
    positions: np.ndarray, magnitudes: np.ndarray, limb_points: np.ndarray, k: int = 5
) -> np.ndarray:
    """Force map (N,) float32 from contacts at `positions` (C, 3) with `magnitudes` (C,)."""
    return ForceDistributor(limb_points, k)(positions, magnitudes)
