"""Score a model on held-out sequences as the paper does (Sec. V-B), in numpy only.

Public API
----------
``score_sequences(model, sequences, forces, *, batch_size=32, progress=False, profile=None,
parts=None) -> SequenceScores``
    ``model``: a ``LoadedModel`` or ``NumpyEstimator``; ``sequences``: phi (T_i, 9);
    ``forces``: ground truth (T_i, N). Runs every sequence from a zero state (batched,
    zero-padded at the end, which cannot change earlier outputs), applies Eq. 2, and keeps
    each sequence's figures; ``.scores(which=None)`` gives, for all or a group of them:
``Scores``: ``n`` (sequences), ``rmse`` (per-sequence RMSE averaged, N), ``zero_rmse`` (all-zero
    estimate), ``ratio`` (rmse / zero_rmse; the paper got 0.45 gown, 0.48 shorts),
    ``contact_precision`` / ``contact_recall`` (estimated contact = contact map > 0 vs
    true force > 0, counted over all steps and points),
    ``ratio_at_true_total`` / ``ratio_true_shape`` (the ratio with the estimate's total
    or its shape replaced by the truth's, `dresslog.model.bounds.error_split`); ratios,
    precision and recall are nan where undefined (no force in the truth, no contact);
    ``as_metrics()`` gives the finite ones as a dict for ``ModelCard.metrics``.
    With ``profile`` (an ``ErrorProfile``), every step's truth and estimate are also added
    to it: where along the limb and at what total force the model errs (``eval --plot``).
    With ``parts`` (limb part name -> its points' mask), ``.part_scores(which)`` gives the
    same figures over each part's points alone: whether the elbow's force is found as
    well as the fist's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from dresslog.errors import ModelError
from dresslog.model.bounds import error_split
from dresslog.model.files import LoadedModel
from dresslog.model.numpy_lstm import NumpyEstimator
from dresslog.model.postprocess import apply_contact, sequence_rmse, split_output
from dresslog.trial import padded


@dataclass(frozen=True)
class Scores:
    """The paper's numbers for one group of sequences."""

    n: int
    rmse: float
    zero_rmse: float
    ratio: float
    contact_precision: float
    contact_recall: float
    #: the ratio with the estimate rescaled to each step's true total force: where it errs
    ratio_at_true_total: float
    #: the ratio of the true map rescaled to the estimate's total: how much it errs
    ratio_true_shape: float

    @classmethod
    def none(cls) -> Scores:
        """The scores of an empty group: n 0, every figure nan (null in JSON)."""
        return cls(0, *[math.nan] * 7)

    def as_metrics(self) -> dict[str, float]:
        """The summary numbers, finite only (JSON has no nan)."""
        values = {
            "rmse": self.rmse,
            "zero_rmse": self.zero_rmse,
            "ratio": self.ratio,
            "contact_precision": self.contact_precision,
            "contact_recall": self.contact_recall,
            "ratio_at_true_total": self.ratio_at_true_total,
            "ratio_true_shape": self.ratio_true_shape,
            "n_sequences": float(self.n),
        }
        return {k: v for k, v in values.items() if math.isfinite(v)}


class ErrorProfile:
    """Where and how much a model errs over every step of a group of sequences: per limb
    point the mean true and estimated force and the RMSE; per step the true and
    estimated total force (what `dresslog.experiments.plots.plot_eval` draws)."""

    def __init__(self, n_points: int) -> None:
        self.steps = 0
        self._true = np.zeros(n_points)
        self._estimate = np.zeros(n_points)
        self._squared_error = np.zeros(n_points)
        self._totals: list[np.ndarray] = []

    def add(self, truth: np.ndarray, estimate: np.ndarray) -> None:
        """One sequence's maps (T, N), after Eq. 2."""
        truth, estimate = np.asarray(truth, np.float64), np.asarray(estimate, np.float64)
        self.steps += len(truth)
        self._true += truth.sum(axis=0)
        self._estimate += estimate.sum(axis=0)
        self._squared_error += ((estimate - truth) ** 2).sum(axis=0)
        self._totals.append(np.stack([truth.sum(axis=1), estimate.sum(axis=1)], axis=1))

    @property
    def mean_true(self) -> np.ndarray:
        """(N,) N: each point's true force, averaged over every step."""
        return self._true / max(self.steps, 1)

    @property
    def mean_estimate(self) -> np.ndarray:
        """(N,) N: each point's estimated force, averaged over every step."""
        return self._estimate / max(self.steps, 1)

    @property
    def rmse(self) -> np.ndarray:
        """(N,) N: each point's RMSE over every step."""
        return np.sqrt(self._squared_error / max(self.steps, 1))

    @property
    def totals(self) -> np.ndarray:
        """(steps, 2) N: each step's true and estimated total force over the limb."""
        return np.concatenate(self._totals) if self._totals else np.zeros((0, 2))


def _ratio(a: float, b: float) -> float:
    return a / b if b else math.nan


@dataclass(frozen=True)
class SequenceScores:
    """Each sequence's figures, in the order given to `score_sequences`."""

    rmse: np.ndarray  # (S,) N, after Eq. 2
    zero_rmse: np.ndarray  # (S,) N, of the all-zero estimate
    at_true_total: np.ndarray  # (S,) N, RMSE of the estimate rescaled to the true totals
    true_shape: np.ndarray  # (S,) N, RMSE of the true map rescaled to the estimate's totals
    contacts: np.ndarray  # (S, 3) int: contact true positives, false positives, false negatives
    #: the limb parts scored alone, in the order of the arrays below (empty: none asked for)
    part_names: tuple[str, ...] = ()
    part_rmse: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # (S, P) N
    part_zero: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # (S, P) N
    part_contacts: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3), np.int64))

    def scores(self, which: np.ndarray | None = None) -> Scores:
        """The paper's numbers for the sequences `which` selects (a mask or indices; all
        if None): means over sequences, counts summed."""
        chosen = slice(None) if which is None else which
        return _summed(
            self.rmse[chosen],
            self.zero_rmse[chosen],
            self.contacts[chosen],
            self.at_true_total[chosen],
            self.true_shape[chosen],
        )

    def part_scores(self, which: np.ndarray | None = None) -> dict[str, Scores]:
        """Per limb part, the paper's numbers over that part's points alone (each sequence's
        RMSE over its steps and the part's points, averaged over sequences; the ratio to
        the all-zero estimate's): the error where the force is, not diluted by the rest
        of the limb. The split of the error into place and amount is left nan."""
        chosen = slice(None) if which is None else which
        return {
            name: _summed(
                self.part_rmse[chosen, j], self.part_zero[chosen, j], self.part_contacts[chosen, j]
            )
            for j, name in enumerate(self.part_names)
        }


def _summed(
    rmse: np.ndarray,
    zero: np.ndarray,
    contacts: np.ndarray,
    at_true_total: np.ndarray | None = None,
    true_shape: np.ndarray | None = None,
) -> Scores:
    """A group's scores from its sequences' figures: means over sequences, counts summed;
    the error's split into place and amount nan where not given."""
    if not len(rmse):
        return Scores.none()
    tp, fp, fn = (int(n) for n in contacts.sum(axis=0))
    mean_rmse, mean_zero = float(np.mean(rmse)), float(np.mean(zero))

    def over_zero(values: np.ndarray | None) -> float:
        return math.nan if values is None else _ratio(float(np.mean(values)), mean_zero)

    return Scores(
        n=len(rmse),
        rmse=mean_rmse,
        zero_rmse=mean_zero,
        ratio=_ratio(mean_rmse, mean_zero),
        contact_precision=_ratio(tp, tp + fp),
        contact_recall=_ratio(tp, tp + fn),
        ratio_at_true_total=over_zero(at_true_total),
        ratio_true_shape=over_zero(true_shape),
    )


def score_sequences(
    model: LoadedModel | NumpyEstimator,
    sequences: Sequence[np.ndarray],
    forces: Sequence[np.ndarray],
    *,
    batch_size: int = 32,
    progress: bool = False,
    profile: ErrorProfile | None = None,
    parts: Mapping[str, np.ndarray] | None = None,
) -> SequenceScores:
    """Run every sequence through the model once (batched from a zero state), apply Eq. 2,
    and keep each sequence's figures: `.scores()` gives the paper's numbers for all of
    them, `.scores(which)` for any group, without running the network again."""
    from tqdm import tqdm

    est = model.estimator() if isinstance(model, LoadedModel) else model
    if len(sequences) != len(forces) or not sequences:
        raise ModelError(f"need matching sequences: {len(sequences)} inputs, {len(forces)} maps")
    for k, (phi, f) in enumerate(zip(sequences, forces, strict=True)):
        if f.shape != (len(phi), est.n_points):
            raise ModelError(
                f"sequence {k}: force map {f.shape} does not fit {len(phi)} steps and "
                f"the model's {est.n_points} limb points"
            )
    n = len(sequences)
    rmse, zero, at_true_total, true_shape = (np.zeros(n) for _ in range(4))
    contacts = np.zeros((n, 3), np.int64)
    masks = [np.asarray(m, bool) for m in (parts or {}).values()]
    part_rmse, part_zero = np.zeros((n, len(masks))), np.zeros((n, len(masks)))
    part_contacts = np.zeros((n, len(masks), 3), np.int64)
    order = np.argsort([len(p) for p in sequences])  # similar lengths together
    for start in tqdm(range(0, len(order), batch_size), disable=not progress, unit="batch"):
        idx = order[start : start + batch_size]
        out = est.forward(padded([sequences[k] for k in idx]))
        for row, k in enumerate(idx):
            forces_u, contact = split_output(out[row, : len(sequences[k])])
            truth = np.asarray(forces[k], np.float32)
            estimate = apply_contact(forces_u, contact)
            rmse[k] = sequence_rmse(truth, estimate)
            at_true_total[k], true_shape[k] = error_split(truth, estimate)
            zero[k] = sequence_rmse(truth, np.zeros_like(truth))
            if profile is not None:
                profile.add(truth, estimate)
            said, real = contact > 0, truth > 0
            contacts[k] = _confusion(said, real)
            for j, mask in enumerate(masks):
                part_rmse[k, j] = sequence_rmse(truth[:, mask], estimate[:, mask])
                part_zero[k, j] = sequence_rmse(truth[:, mask], np.zeros_like(truth[:, mask]))
                part_contacts[k, j] = _confusion(said[:, mask], real[:, mask])
    return SequenceScores(
        rmse, zero, at_true_total, true_shape, contacts,
        tuple(parts or ()), part_rmse, part_zero, part_contacts,
    )  # fmt: skip


def _confusion(said: np.ndarray, real: np.ndarray) -> list[int]:
    """Contact true positives, false positives and false negatives."""
    return [int(np.count_nonzero(m)) for m in (said & real, said & ~real, ~said & real)]
