"""The ground-truth force map: each contact's magnitude shared among its k nearest limb points.

Point l of the k nearest gets (1/(k-1)) (1 - d_l / sum_p d_p) |f_j|, so the
shares of one contact sum to |f_j| and nearer points get more (Sec. IV-B).
`ClothSpreader` first spreads a coarse cloth node's contact force over the cloth
it stands for, so that the contacts are as dense as on the paper's meshes.
"""

from __future__ import annotations

import numpy as np

from dresslog.limb import Limb, limb_sdf, surface_points


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


class ClothSpreader:
    """Each contacting cloth node's force spread over the cloth around it that touches the limb.

    A node of a mass-spring cloth stands for the patch of cloth around it: the
    contact force the solver puts on the node is the resultant of the pressure over
    the part of that patch lying on the limb. Our garments have about 200 nodes (the
    paper's 4,400-10,400), so a node's force at its own place makes a force map of a
    few sharp peaks. Here each triangle is sampled on a barycentric grid (`subdivisions`
    intervals per edge, 1-1.5 cm on our meshes); a node's force goes to the samples of
    its triangles that lie within `reach` of the limb, in proportion to the node's
    linear shape function (its barycentric weight, 1 at the node, 0 at the far edge),
    and each sample is projected onto the limb surface. The shares of a node sum to its
    force; the node itself is always a sample, so a force is never lost.
    """

    def __init__(
        self, triangles: np.ndarray, n_vertices: int, subdivisions: int, reach: float
    ) -> None:
        self.reach = reach
        s = max(1, subdivisions)
        grid = [(i, j, s - i - j) for i in range(s + 1) for j in range(s + 1 - i)]
        samples: dict[tuple[tuple[int, int], ...], int] = {}  # {(vertex, count)} -> id
        parents, weights = [], []
        for tri in np.asarray(triangles, dtype=np.int64):
            for counts in grid:
                key = tuple(sorted((int(v), c) for v, c in zip(tri, counts, strict=True) if c))
                if key not in samples:
                    samples[key] = len(parents)
                    parents.append([v for v, _ in key] + [key[0][0]] * (3 - len(key)))
                    weights.append([c / s for _, c in key] + [0.0] * (3 - len(key)))
        self.parents = np.array(parents, dtype=np.int64)  # (S, 3) vertex ids
        self.weights = np.array(weights)  # (S, 3) barycentric weights, 0 where padded
        self._at_node = self.weights.max(axis=1) == 1.0  # the samples that are nodes
        rows, slots = np.nonzero(self.weights > 0)
        owner = self.parents[rows, slots]
        order = np.argsort(owner, kind="stable")
        self._samples = rows[order]  # the samples of each vertex, grouped by vertex
        self._start = np.searchsorted(owner[order], np.arange(n_vertices + 1))
        self.n_vertices = n_vertices

    def __call__(
        self, limb: Limb, vertices: np.ndarray, nodes: np.ndarray, magnitudes: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Contact positions on the limb surface (S, 3) and their force magnitudes (S,).

        `vertices`: the cloth's node positions now (V, 3); `nodes`: the contacting
        nodes (C,), each once; `magnitudes`: their contact force magnitudes (C,).
        """
        if len(nodes) == 0:
            return np.zeros((0, 3)), np.zeros(0)
        nodes = np.asarray(nodes, dtype=np.int64)
        ids = np.unique(
            np.concatenate([self._samples[self._start[v] : self._start[v + 1]] for v in nodes])
        )
        parents, w = self.parents[ids], self.weights[ids]
        pos = np.einsum("sk,skd->sd", w, vertices[parents])
        # a node's own sample always counts: its contact says it touches the limb
        near = (limb_sdf(limb, pos) < self.reach) | self._at_node[ids]
        slot = np.full(self.n_vertices, -1)
        slot[nodes] = np.arange(len(nodes))
        which = slot[parents]  # (S, 3) index of a parent among `nodes`, -1 if not in contact
        inside = which >= 0
        share = np.where(inside & near[:, None], w, 0.0)
        sums = np.bincount(which[inside], share[inside], len(nodes))  # > 0: own sample
        owner = np.maximum(which, 0)
        mags = np.asarray(magnitudes, dtype=np.float64)
        f = (share / sums[owner] * mags[owner]).sum(axis=1)  # share is 0 where not inside
        keep = f > 0
        surface, _ = surface_points(limb, pos[keep])
        return surface, f[keep]


def distribute(
    positions: np.ndarray, magnitudes: np.ndarray, limb_points: np.ndarray, k: int = 5
) -> np.ndarray:
    """Force map (N,) float32 from contacts at `positions` (C, 3) with `magnitudes` (C,)."""
    return ForceDistributor(limb_points, k)(positions, magnitudes)
