"""How low can the paper's RMSE ratio go on a dataset? Oracles handed part of the truth.

The ratio (RMSE / all-zero RMSE) depends on the data as much as on the model: a
force map of a few sharp peaks is matched only by an estimate that puts the force
on the right couple of centimetres of limb. These oracles measure that limit, so a
change to the simulator can be judged before a model is trained on it.

Public API
----------
``oracle_ratios(truths, points, train=None, sigmas_cm=SIGMAS_CM) -> dict[str, float]``
    ``truths``: ground-truth force maps (T_i, N) of the scored sequences; ``points``:
    the limb points (N, 3), m; ``train``: force maps whose per-step mean gives the
    "mean profile". Keys: ``blur <s> cm`` (the exact map blurred along the limb by a
    Gaussian of sigma s: every force known, placed to within s), ``total x mean
    profile`` (only given ``train``: exact total force per step, spread by the training
    maps' mean shape at that step), ``total x own profile`` (spread by the sequence's own average
    shape), ``3-step flicker`` (the truth against its own centred 3-step mean: the
    step-to-step noise no causal estimate follows).
``error_split(truth, estimate) -> (at_true_total, true_shape_at_estimated_total)``
    One sequence's RMSE with half of a model's estimate replaced by the truth: the
    estimate rescaled to the true total force of each step (what its placement alone
    costs), and the true map rescaled to the estimate's total (what its total alone
    costs). Says whether a model errs in how much force there is or where it falls.
``describe_oracle(name) -> str``
    What an oracle's estimate is handed, in words, for ``eval --bounds``' rows.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dresslog.errors import ModelError
from dresslog.model.postprocess import rmse, sequence_rmse, zero_baseline_rmse

#: The oracles `oracle_ratios` scores besides the blurs, and what each is handed.
MEAN_PROFILE, OWN_PROFILE, FLICKER = "total x mean profile", "total x own profile", "3-step flicker"
_HANDED = {
    MEAN_PROFILE: "each step's exact total, spread as the training maps",
    OWN_PROFILE: "each step's exact total, spread as its sequence's mean",
    FLICKER: "the truth's own 3-step mean: noise no causal model follows",
}

SIGMAS_CM = (0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0)


def _shape(forces: np.ndarray) -> np.ndarray:
    """Rows scaled to sum to 1 (rows of zeros stay zero)."""
    total = forces.sum(axis=-1, keepdims=True)
    return forces / np.where(total > 0, total, 1.0)


def _step_mean(maps: Sequence[np.ndarray], steps: int) -> np.ndarray:
    """Mean map per step over the sequences that reach that step, (steps, N)."""
    acc = np.zeros((steps, maps[0].shape[1]))
    count = np.zeros((steps, 1))
    for m in maps:
        n = min(len(m), steps)
        acc[:n] += m[:n]
        count[:n] += 1
    return acc / np.maximum(count, 1)


def _moving_mean3(f: np.ndarray) -> np.ndarray:
    """Centred 3-step mean, the ends averaged over the steps that exist."""
    padded = np.concatenate([f[:1], f, f[-1:]])
    return (padded[:-2] + padded[1:-1] + padded[2:]) / 3


def oracle_ratios(
    truths: Sequence[np.ndarray],
    points: np.ndarray,
    train: Sequence[np.ndarray] | None = None,
    sigmas_cm: Sequence[float] = SIGMAS_CM,
) -> dict[str, float]:
    """RMSE / all-zero RMSE of each oracle on `truths` (see the module docstring)."""
    truths = [np.asarray(t, np.float64) for t in truths]
    zero = zero_baseline_rmse(truths)
    if not zero:
        raise ModelError("every force map is zero: there is nothing to place")
    dist = np.linalg.norm(points[:, None] - points[None], axis=-1)
    out: dict[str, float] = {}
    for sigma in sigmas_cm:
        kernel = np.exp(-0.5 * (dist / (sigma / 100)) ** 2)
        kernel /= kernel.sum(axis=0, keepdims=True)  # each point's force keeps its total
        out[f"blur {sigma:g} cm"] = rmse(truths, [t @ kernel.T for t in truths]) / zero
    totals = [t.sum(axis=1, keepdims=True) for t in truths]
    if train is not None:
        steps = max(len(t) for t in truths)
        profile = _shape(_step_mean([np.asarray(m, np.float64) for m in train], steps))
        ests = [s * profile[: len(s)] for s in totals]
        out[MEAN_PROFILE] = rmse(truths, ests) / zero
    own = [s * _shape(t.sum(axis=0)) for s, t in zip(totals, truths, strict=True)]
    out[OWN_PROFILE] = rmse(truths, own) / zero
    out[FLICKER] = rmse(truths, [_moving_mean3(t) for t in truths]) / zero
    return out


def describe_oracle(name: str) -> str:
    """What the oracle `name` (a key of `oracle_ratios`) is handed, in a few words."""
    if name.startswith("blur "):
        return f"every force exact, placed within {name.removeprefix('blur ')}"
    return _HANDED.get(name, "")


def error_split(truth: np.ndarray, estimate: np.ndarray) -> tuple[float, float]:
    """RMSE of the estimate at the true totals, and of the true shape at the estimated totals."""
    truth, estimate = np.asarray(truth, np.float64), np.asarray(estimate, np.float64)
    true_total = truth.sum(axis=1, keepdims=True)
    est_total = estimate.sum(axis=1, keepdims=True)
    return (
        sequence_rmse(truth, _shape(estimate) * true_total),
        sequence_rmse(truth, _shape(truth) * est_total),
    )
