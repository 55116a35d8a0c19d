"""RMSE against ground truth, per step and over a trial, as the paper defines it (Sec. V-B).

The trial RMSE is sqrt(1/(TN) sum_t sum_i (f_ti - fhat_ti)^2): one mean over
every step and point, not a mean of per-step RMSEs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from dresslog.replay.engine import StepResult, TrialContext


def step_rmse(truth: np.ndarray, estimate: np.ndarray) -> float:
    """RMSE between one ground-truth and one estimated force map, in newtons."""
    diff = np.asarray(truth, dtype=np.float64) - estimate
    return math.sqrt(float(diff @ diff) / max(len(diff), 1))


@dataclass
class TrialMetrics:
    """What a replay measured: step count, RMSE (None without truth), zero-estimate RMSE,
    and the estimate's total force on the limb (None without a model), which is all a
    log without ground truth can be summed up by."""

    steps: int = 0
    rmse: float | None = None
    zero_rmse: float | None = None
    per_step: list[float] = field(default_factory=list)
    mean_total: float | None = None  # N, over the steps
    peak_total: float | None = None  # N
    peak_s: float | None = None  # when the peak came, s from the first step
    touching: float | None = None  # share of all steps whose estimate puts force on the limb

    @property
    def ratio(self) -> float | None:
        """RMSE over the all-zero estimate's, the figure the paper compares by."""
        if self.rmse is None or not self.zero_rmse:
            return None
        return self.rmse / self.zero_rmse

    def scores(self) -> str | None:
        """The RMSE beside the all-zero estimate's and their ratio, as `infer` and
        `record --live` print them; None without ground truth."""
        if self.rmse is None:
            return None
        ratio = f", ratio {self.ratio:.3f}" if self.ratio is not None else ""
        return f"RMSE {self.rmse:.4g} N (all-zero estimate {self.zero_rmse:.4g} N{ratio})"


class MetricsSink:
    """Accumulates squared errors so that the trial RMSE is exact at any step."""

    def __init__(self) -> None:
        self._reset()

    def _reset(self) -> None:
        self.metrics = TrialMetrics()
        self._sq = 0.0
        self._truth_sq = 0.0
        self._count = 0
        self._totals: list[float] = []
        self._t_ns: list[int] = []
        self._first_ns: int | None = None  # the trial's first step, with an estimate or not

    def open(self, context: TrialContext) -> None:
        """Start a trial's sums afresh (one sink may score several trials in turn)."""
        self._reset()

    def write(self, result: StepResult) -> None:
        """Add the step's squared error and estimated total; a step without truth or estimate
        only counts."""
        self.metrics.steps += 1
        if self._first_ns is None:
            self._first_ns = result.step.t_ns
        truth, estimate = result.step.truth, result.estimate
        if estimate is not None:
            self._totals.append(float(estimate.sum(dtype=np.float64)))
            self._t_ns.append(result.step.t_ns)
        if truth is None or estimate is None or result.rmse is None:
            return
        n = len(truth)
        self._sq += result.rmse**2 * n
        t64 = truth.astype(np.float64)
        self._truth_sq += float(t64 @ t64)
        self._count += n
        self.metrics.per_step.append(result.rmse)

    def close(self) -> None:
        """Turn the sums into `metrics`: RMSE, all-zero RMSE, the estimate's mean and peak
        totals."""
        if self._totals:
            totals, m = np.asarray(self._totals), self.metrics
            peak = int(totals.argmax())
            m.mean_total, m.peak_total = float(totals.mean()), float(totals[peak])
            m.peak_s = (self._t_ns[peak] - (self._first_ns or 0)) / 1e9
            m.touching = float((totals > 0).sum()) / m.steps
        if self._count:
            self.metrics.rmse = math.sqrt(self._sq / self._count)
            self.metrics.zero_rmse = math.sqrt(self._truth_sq / self._count)

    def commit(self) -> None:
        """Nothing to move: metrics live in memory."""

    def abort(self) -> None:
        """Nothing to undo: metrics live in memory."""
