"""The ground-truth force map: each contact's magnitude shared among its k nearest limb points.

Point l of the k nearest gets (1/(k-1)) (1 - d_l / sum_p d_p) |f_j|, so the
shares of one contact sum to |f_j| and nearer points get more (Sec. IV-B).
`ClothSpreader` first spreads a coarse cloth node's contact force over the cloth
it stands for, so that the contacts are as dense as on the paper's meshes.
"""

from __future__ import annotations

import numpy as np

from dresslog.limb import Limb, limb_sdf, surface_points

#: numpy's argpartition of a float64 row longer than this first splits it about a pivot;
#: a part this long or shorter it sorts whole (x86-simd-sort's argselect).
_SORTED_WHOLE = 256


def nearest(d2: np.ndarray, k: int) -> np.ndarray:
    """`np.argpartition(d2, k - 1, axis=1)[:, :k]` (R, k), same points in the same order
    (`d2` is worked on in place and left as it was).

    The order matters: a contact's k distances are summed in it. numpy (x86-simd-sort's
    argselect, which it uses on x86-64 with AVX-512) sorts a row of at most
    `_SORTED_WHOLE` values whole; a longer row it first splits about the median of 8
    samples, and when at least k values lie below that pivot and at most
    `_SORTED_WHOLE`, it sorts that part whole. Its k first are then the k smallest in
    ascending order, which k + 1 passes of argmin find at a fifth of the cost. Rows
    where that cannot be told (an equal value either side of the k-th, a NaN, a pivot
    elsewhere) and every row on a numpy that partitions otherwise (`_SELECT_SORTS`
    checks it once) go to argpartition itself.
    """
    if not _SELECT_SORTS:
        return np.argpartition(d2, k - 1, axis=1)[:, :k]
    rows, n = d2.shape
    at = np.arange(rows)
    idx = np.empty((rows, k + 1), np.intp)
    vals = np.empty((rows, k + 1))
    for j in range(k + 1):  # in place, each minimum set aside (a copy costs more)
        idx[:, j] = i = d2.argmin(axis=1)
        vals[:, j] = d2[at, i]
        d2[at, i] = np.inf
    d2[at[:, None], idx] = vals  # d2 as it was, bit for bit
    # a tie at the k-th; a NaN (argmin finds it first, argpartition puts it last)
    sure = (vals[:, k - 1] < vals[:, k]) & ~np.isnan(vals[:, 0])
    if n > _SORTED_WHOLE:
        size = (n - 1) // 8
        pivot = np.sort(d2[:, size * np.arange(1, 9)], axis=1)[:, 4]
        below = np.count_nonzero(d2 < pivot[:, None], axis=1)
        sure &= (below >= k) & (below <= _SORTED_WHOLE)
    out = idx[:, :k]
    unsure = np.flatnonzero(~sure)
    if len(unsure):
        out[unsure] = np.argpartition(d2[unsure], k - 1, axis=1)[:, :k]
    return out


def _select_sorts() -> bool:
    """Whether this numpy's argpartition picks as `nearest` assumes: checked on rows
    with small values planted where its pivot samples lie, where another order shows."""
    rng = np.random.default_rng(0)
    for n in (200, 300, 400):
        d2 = rng.uniform(0.0, 1.0, (64, n))
        size = (n - 1) // 8
        for r in range(0, 64, 2):
            pos = size * rng.choice(np.arange(1, 9), 1 + r % 7, replace=False)
            d2[r, pos] = rng.uniform(0.0, 0.01, len(pos))
        d2[1, :] = d2[1, 0]  # ties throughout
        globals()["_SELECT_SORTS"] = True
        try:
            ours = nearest(d2, 5)
        finally:
            globals()["_SELECT_SORTS"] = False
        theirs = np.argpartition(d2, 4, axis=1)[:, :5]
        rows = np.arange(len(d2))[:, None]
        if not (
            np.array_equal(d2[rows, ours], d2[rows, theirs])
            and np.array_equal(np.sort(ours, axis=1), np.sort(theirs, axis=1))
        ):
            return False
    return True


_SELECT_SORTS = False
_SELECT_SORTS = _select_sorts()


class ForceDistributor:
    """Shares contacts among the k nearest of fixed limb points (N, 3), norms computed once."""

    def __init__(self, limb_points: np.ndarray, k: int = 5) -> None:
        if k < 1:
            raise ValueError(f"k must be 1 or more (the paper's is 5), not {k}")
        self.limb_points = limb_points
        self.k = min(k, len(limb_points))
        self._sq = np.sum(limb_points**2, axis=1)[None, :]
        self._points_t = limb_points.T
        self._scratch = np.empty((0, len(limb_points)))

    def __call__(self, positions: np.ndarray, magnitudes: np.ndarray) -> np.ndarray:
        """Force map (N,) float32 from contacts at `positions` (C, 3) with `magnitudes` (C,)."""
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        return self.maps(positions, magnitudes, np.array([len(positions)]))[0]

    def maps(self, positions: np.ndarray, magnitudes: np.ndarray, counts: np.ndarray) -> np.ndarray:
        """Force maps (B, N) float32 of B steps whose contacts are stacked step after step.

        `positions` (C, 3) and `magnitudes` (C,) hold the contacts of every step,
        `counts` (B,) how many each step has. One pass over all steps costs what one
        step did; each map is bit-identical to its step's alone. Only the product with
        the limb points is formed step by step: BLAS rounds a row by where it falls
        in the matrix, so one product over all steps would change the last bits.
        """
        n, k, b = len(self.limb_points), self.k, len(counts)
        positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        magnitudes = np.asarray(magnitudes, dtype=np.float64).reshape(-1)
        if len(magnitudes) != len(positions) or counts.sum() != len(positions):
            raise ValueError(  # numpy would broadcast one magnitude over every contact
                f"{len(positions)} positions, {len(magnitudes)} magnitudes and counts "
                f"summing to {counts.sum()}: give one magnitude per contact"
            )
        if len(positions) == 0:
            return np.zeros((b, n), dtype=np.float32)
        if len(self._scratch) < len(positions):  # kept: a fresh block page-faults
            self._scratch = np.empty((2 * len(positions), n))
        cross = self._scratch[: len(positions)]
        ends = np.cumsum(counts)
        for lo, hi in zip(ends - counts, ends, strict=True):
            if hi > lo:
                cross[lo:hi] = 2.0 * positions[lo:hi] @ self._points_t
        # |p|^2 - 2 p.q + |q|^2, in place: each big temporary is a fresh page-faulting block
        d2 = np.subtract((positions**2).sum(axis=1)[:, None], cross, out=cross)
        d2 += self._sq
        idx = nearest(d2, k) if k < n else np.tile(np.arange(n), (len(d2), 1))
        d = np.sqrt(np.maximum(d2[np.arange(len(d2))[:, None], idx], 0.0))
        if k == 1:
            w = np.ones_like(d)
        else:
            total = d.sum(axis=1, keepdims=True)
            touching = total > 0
            safe = np.where(touching, total, 1.0)
            w = np.where(touching, (1.0 - d / safe) / (k - 1), 1.0 / k)
        # bincount adds each point's shares in contact order starting from 0.0, as
        # np.add.at into zeros does; the step's offset keeps the maps apart
        step = np.repeat(np.arange(b), counts)
        out = np.bincount(
            (idx + (step * n)[:, None]).ravel(), (w * magnitudes[:, None]).ravel(), b * n
        )
        return out.reshape(b, n).astype(np.float32)


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
        parents: list[list[int]] = []
        weights: list[list[float]] = []
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
        nodes = np.asarray(nodes, dtype=np.int64)
        _, pos, f = self.spread(
            limb, vertices[None], np.zeros(len(nodes), np.int64), nodes, magnitudes
        )
        return pos, f

    def spread(
        self,
        limb: Limb,
        vertices: np.ndarray,
        step: np.ndarray,
        nodes: np.ndarray,
        magnitudes: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`__call__` for B steps at once: each sample's step (S,), position (S, 3), force (S,).

        `vertices` (B, V, 3) holds the cloth at each step; `step`, `nodes` and
        `magnitudes` (C,) list each step's contacting nodes, step after step. The
        samples come out step after step too, each step's as its own call gives them.
        """
        if len(nodes) == 0:
            return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0)
        n_samples, n_vertices = len(self.parents), self.n_vertices
        lo, hi = self._start[nodes], self._start[nodes + 1]
        counts = hi - lo
        first = np.cumsum(counts) - counts
        listed = self._samples[np.arange(counts.sum()) + np.repeat(lo - first, counts)]
        # each (step, sample) once, sorted by step then sample, as np.unique would give
        # them: marking them in a table and reading it back skips unique's sort
        listed += np.repeat(step, counts) * n_samples
        marked = np.zeros(len(vertices) * n_samples, dtype=bool)
        marked[listed] = True
        at, ids = np.divmod(np.flatnonzero(marked), n_samples)
        parents, w = self.parents[ids], self.weights[ids]
        pos = np.einsum("sk,skd->sd", w, vertices[at[:, None], parents])
        # a node's own sample always counts: its contact says it touches the limb
        depth = limb_sdf(limb, pos)
        near = (depth < self.reach) | self._at_node[ids]
        slot = np.full(len(vertices) * n_vertices, -1)
        slot[step * n_vertices + nodes] = np.arange(len(nodes))
        which = slot[at[:, None] * n_vertices + parents]  # (S, 3) contact of each parent, or -1
        inside = which >= 0
        share = np.where(inside & near[:, None], w, 0.0)
        sums = np.bincount(which[inside], share[inside], len(nodes))  # > 0: own sample
        owner = np.maximum(which, 0)
        mags = np.asarray(magnitudes, dtype=np.float64)
        f = (share / sums[owner] * mags[owner]).sum(axis=1)  # share is 0 where not inside
        keep = f > 0
        surface, _ = surface_points(limb, pos[keep], depth[keep])
        return at[keep], surface, f[keep]
