"""The paper's post-processing, training targets and error metric, in numpy only.

Public API
----------
``apply_contact(forces_u, contact) -> forces``
    Eq. 2: the estimated force is 0 where the contact estimate < 0 or the unprocessed
    force estimate < 0, else the unprocessed estimate. Any shape; float32 out.
``contact_targets(forces) -> chi``: Eq. 1, +0.1 where the true force > 0, -0.1 elsewhere.
``network_targets(forces, force_scale=1.0) -> (T, 2N)``: the training target
    ``[force map, contact map]``, forces multiplied by ``force_scale``.
``split_output(out (..., 2N)) -> (forces_u (..., N), contact (..., N))``: views, no copy.
``sequence_rmse(true (T, N), est (T, N)) -> float``
    RMSE over every step and limb point of one sequence (Sec. V-B).
``rmse(trues, ests) -> float``: the paper's RMSE, per-sequence RMSE averaged over sequences,
    so a long sequence counts as much as a short one.
``zero_baseline_rmse(trues) -> float``: the same metric for the all-zero estimate.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Eq. 1's contact-map magnitude: near typical forces so neither half dominates the MSE.
CONTACT_LEVEL = 0.1


def apply_contact(forces_u: np.ndarray, contact: np.ndarray) -> np.ndarray:
    """Eq. 2: zero every force the contact map calls no-contact, and every negative one."""
    forces_u = np.asarray(forces_u, dtype=np.float32)
    out = np.maximum(forces_u, np.float32(0.0))
    out[np.asarray(contact) < 0] = 0.0
    return out


def contact_targets(forces: np.ndarray) -> np.ndarray:
    """Eq. 1: the contact-map target for a ground-truth force map."""
    return np.where(np.asarray(forces) > 0, CONTACT_LEVEL, -CONTACT_LEVEL).astype(np.float32)


def network_targets(forces: np.ndarray, force_scale: float = 1.0) -> np.ndarray:
    """The per-step training target [force map x force_scale, contact map], (T, 2N) float32."""
    forces = np.asarray(forces, dtype=np.float32)
    return np.concatenate([forces * np.float32(force_scale), contact_targets(forces)], axis=-1)


def split_output(out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split a (..., 2N) network output into (unprocessed forces, contact map) views."""
    n = out.shape[-1] // 2
    return out[..., :n], out[..., n:]


def sequence_rmse(true: np.ndarray, est: np.ndarray) -> float:
    """RMSE over all T steps and N limb points of one sequence, in newtons."""
    true = np.asarray(true, dtype=np.float64)
    est = np.asarray(est, dtype=np.float64)
    if true.shape != est.shape:
        raise ValueError(f"shapes differ: true {true.shape}, estimate {est.shape}")
    if true.size == 0:
        raise ValueError("empty sequence")
    return float(np.sqrt(np.mean((true - est) ** 2)))


def rmse(trues: Sequence[np.ndarray], ests: Sequence[np.ndarray]) -> float:
    """The paper's metric: RMSE per sequence, averaged over sequences."""
    if len(trues) != len(ests):
        raise ValueError(f"{len(trues)} ground-truth sequences but {len(ests)} estimates")
    if not trues:
        raise ValueError("no sequences")
    return float(np.mean([sequence_rmse(t, e) for t, e in zip(trues, ests, strict=True)]))


def zero_baseline_rmse(trues: Sequence[np.ndarray]) -> float:
    """The paper's comparison: the same RMSE for an estimate of zero force everywhere."""
    return rmse(trues, [np.zeros_like(t) for t in trues])
