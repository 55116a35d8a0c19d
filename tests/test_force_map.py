"""The k-nearest force distribution of Sec. IV-B."""

from __future__ import annotations

import numpy as np
import pytest

from dresslog.force_map import distribute
from dresslog.model.postprocess import contact_targets


def _reference(positions, magnitudes, points, k=5):
    out = np.zeros(len(points))
    for x, f in zip(positions, magnitudes, strict=True):
        d = np.linalg.norm(points - x, axis=1)
        idx = np.argsort(d)[:k]
        s = d[idx].sum()
        for i in idx:
            out[i] += (1 - d[i] / s) / (k - 1) * f
    return out


def test_matches_a_loop_over_contacts() -> None:
    rng = np.random.default_rng(0)
    points = rng.normal(size=(300, 3))
    pos = rng.normal(size=(40, 3))
    mag = rng.uniform(0, 2, size=40)
    np.testing.assert_allclose(
        distribute(pos, mag, points), _reference(pos, mag, points), rtol=1e-5
    )


def test_each_contact_is_shared_whole() -> None:
    rng = np.random.default_rng(1)
    points = rng.normal(size=(400, 3))
    pos = rng.normal(size=(25, 3))
    mag = rng.uniform(0, 3, size=25)
    fm = distribute(pos, mag, points)
    assert fm.dtype == np.float32 and fm.shape == (400,)
    assert fm.sum() == pytest.approx(mag.sum(), rel=1e-5)
    assert np.count_nonzero(distribute(pos[:1], mag[:1], points)) == 5


def test_nearer_points_get_more() -> None:
    points = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0], [9, 0, 0]])
    fm = distribute(np.array([[0.1, 0, 0]]), np.array([1.0]), points)
    assert np.all(np.diff(fm[:5]) < 0) and fm[5] == 0


def test_no_contacts_give_zeros_and_a_contact_on_a_point_is_safe() -> None:
    points = np.eye(3)
    assert not distribute(np.zeros((0, 3)), np.zeros(0), points).any()
    fm = distribute(points[:1], np.array([2.0]), points, k=1)
    assert fm[0] == pytest.approx(2.0)


def test_contact_map_is_plus_minus_a_tenth() -> None:
    cm = contact_targets(np.array([[0.0, 0.3], [1e-6, -1.0]], dtype=np.float32))
    np.testing.assert_array_equal(cm, np.array([[-0.1, 0.1], [0.1, -0.1]], dtype=np.float32))
