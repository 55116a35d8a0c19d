"""Oracle bounds on the RMSE ratio, on the real limb points."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from dresslog.errors import ModelError
from dresslog.limb import build_limb, limb_points
from dresslog.model.bounds import error_split, oracle_ratios

POINTS = limb_points(build_limb("gown")).points


def peaks(rng: np.random.Generator, steps: int = 40, n_peaks: int = 3) -> np.ndarray:
    """Force maps of a few one-point peaks that wander over the limb, (steps, N)."""
    f = np.zeros((steps, len(POINTS)))
    for t in range(steps):
        f[t, rng.choice(len(POINTS), n_peaks, replace=False)] = rng.uniform(0.1, 1.0, n_peaks)
    return f


def test_blurring_sharp_peaks_costs_more_the_wider_the_blur() -> None:
    truths = [peaks(np.random.default_rng(k)) for k in range(3)]
    r = oracle_ratios(truths, POINTS)
    blurs = [r[f"blur {s:g} cm"] for s in (0.5, 1, 2, 4, 8)]
    assert blurs[0] < 0.05  # a kernel narrower than the ~2 cm spacing keeps each peak
    assert all(a < b for a, b in pairwise(blurs))
    assert 0.8 < blurs[-1] < 1.0  # spread over the limb: barely better than zero


def test_a_map_of_fixed_shape_is_matched_by_its_total_and_profile() -> None:
    rng = np.random.default_rng(0)
    shape = np.zeros(len(POINTS))
    shape[:20] = rng.uniform(size=20)
    truths = [np.outer(rng.uniform(0, 2, 30), shape) for _ in range(3)]
    r = oracle_ratios(truths, POINTS, train=truths)
    assert r["total x own profile"] < 1e-9 and r["total x mean profile"] < 1e-9
    assert r["blur 2 cm"] > 0.1  # but blurring still moves force off the points


def test_flicker_is_zero_for_a_steady_map_and_large_for_one_that_blinks() -> None:
    steady = np.tile(peaks(np.random.default_rng(1), steps=1), (20, 1))
    blinking = steady * (np.arange(20) % 2)[:, None]
    assert oracle_ratios([steady], POINTS)["3-step flicker"] < 1e-9
    assert oracle_ratios([blinking], POINTS)["3-step flicker"] > 0.4


def test_no_force_anywhere_is_refused() -> None:
    with pytest.raises(ModelError, match="nothing to place"):
        oracle_ratios([np.zeros((5, len(POINTS)))], POINTS)


def test_error_split_tells_a_wrong_total_from_a_wrong_place() -> None:
    truth = peaks(np.random.default_rng(2))
    too_strong = 1.5 * truth  # every force in its place, half as strong again
    misplaced = np.roll(truth, 7, axis=1)  # every step's total right, all of it elsewhere
    at_total, true_shape = error_split(truth, too_strong)
    assert at_total < 1e-12 and true_shape > 0.1 * np.sqrt(np.mean(truth**2))
    at_total, true_shape = error_split(truth, misplaced)
    assert true_shape < 1e-12 and at_total > 0.5 * np.sqrt(np.mean(truth**2))
