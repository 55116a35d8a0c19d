"""The k-nearest force distribution of Sec. IV-B and the spread of a node's force on its cloth."""

from __future__ import annotations

import numpy as np
import pytest

from dresslog.force_map import ClothSpreader, ForceDistributor, nearest
from dresslog.limb import Limb, build_limb, limb_points, limb_sdf, surface_points
from dresslog.model.postprocess import contact_targets
from dresslog.sim.garments import garment_for
from dresslog.spec import Task


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
        ForceDistributor(points)(pos, mag), _reference(pos, mag, points), rtol=1e-5
    )


def test_each_contact_is_shared_whole() -> None:
    rng = np.random.default_rng(1)
    points = rng.normal(size=(400, 3))
    pos = rng.normal(size=(25, 3))
    mag = rng.uniform(0, 3, size=25)
    fm = ForceDistributor(points)(pos, mag)
    assert fm.dtype == np.float32 and fm.shape == (400,)
    assert fm.sum() == pytest.approx(mag.sum(), rel=1e-5)
    assert np.count_nonzero(ForceDistributor(points)(pos[:1], mag[:1])) == 5


def test_nearer_points_get_more() -> None:
    points = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0], [9, 0, 0]])
    fm = ForceDistributor(points)(np.array([[0.1, 0, 0]]), np.array([1.0]))
    assert np.all(np.diff(fm[:5]) < 0) and fm[5] == 0


def test_no_contacts_give_zeros_and_a_contact_on_a_point_is_safe() -> None:
    points = np.eye(3)
    assert not ForceDistributor(points)(np.zeros((0, 3)), np.zeros(0)).any()
    fm = ForceDistributor(points, 1)(points[:1], np.array([2.0]))
    assert fm[0] == pytest.approx(2.0)


def test_contact_map_is_plus_minus_a_tenth() -> None:
    cm = contact_targets(np.array([[0.0, 0.3], [1e-6, -1.0]], dtype=np.float32))
    np.testing.assert_array_equal(cm, np.array([[-0.1, 0.1], [0.1, -0.1]], dtype=np.float32))


def _draped_sleeve() -> tuple[Limb, np.ndarray, ClothSpreader]:
    """The gown's sleeve laid with its ring axis on the forearm's, 2 mm larger than the arm."""
    limb = build_limb(Task.GOWN)
    garment = garment_for(Task.GOWN)
    v = garment.vertices.copy()
    # the sleeve's rings are at x in [0, 0.27], centre (y 0, z -0.10), radius 0.10
    yz = v[:, 1:] - np.array([0.0, -0.10])
    r = np.linalg.norm(yz, axis=1, keepdims=True)
    sleeve = np.arange(len(v)) < 140
    v[sleeve, 1:] = yz[sleeve] / r[sleeve] * 0.052  # onto a 5.2 cm tube round the axis
    v[:, 0] += 0.05  # over the forearm, clear of the fist
    spreader = ClothSpreader(garment.triangles, len(v), subdivisions=3, reach=0.012)
    return limb, v, spreader


def test_spread_keeps_each_nodes_force_and_puts_it_on_the_limb() -> None:
    limb, v, spreader = _draped_sleeve()
    nodes = np.array([30, 31, 45, 60])
    mags = np.array([0.5, 1.0, 0.25, 2.0])
    pos, f = spreader(limb, v, nodes, mags)
    assert f.sum() == pytest.approx(mags.sum(), rel=1e-9)
    assert len(pos) > 4 * len(nodes)  # spread over the cloth around each node
    np.testing.assert_allclose(limb_sdf(limb, pos), 0.0, atol=1e-4)  # to 0.1 mm
    for node, mag in zip(nodes, mags, strict=True):  # each alone keeps its whole force
        _, alone = spreader(limb, v, node[None], mag[None])
        assert alone.sum() == pytest.approx(mag, rel=1e-9) and alone.max() < mag


def test_spread_leaves_a_force_where_the_cloth_around_it_is_off_the_limb() -> None:
    limb, v, spreader = _draped_sleeve()
    lifted = v.copy()
    lifted[:, 2] += 0.5  # every node far off the arm: only the node's own sample is near
    pos, f = spreader(limb, lifted, np.array([31]), np.array([1.5]))
    assert len(f) == 1 and f[0] == pytest.approx(1.5)
    np.testing.assert_allclose(pos[0], surface_points(limb, lifted[31][None])[0][0])
    assert spreader(limb, v, np.zeros(0, int), np.zeros(0))[1].size == 0


def test_maps_of_several_steps_are_each_steps_map_bit_for_bit() -> None:
    """The simulator maps 10 steps in one call; each must equal its step mapped alone."""
    limb = build_limb(Task.SHORTS)
    distributor = ForceDistributor(limb_points(limb).points)
    rng = np.random.default_rng(3)
    counts = np.array([7, 0, 1, 38, 12])
    pos, _ = surface_points(limb, rng.normal(size=(counts.sum(), 3)) * 0.1 + [0.5, 0, 0.2])
    mag = rng.uniform(0, 2, size=counts.sum())
    maps = distributor.maps(pos, mag, counts)
    ends = np.cumsum(counts)
    spans = zip(ends - counts, ends, strict=True)
    alone = [distributor(pos[lo:hi], mag[lo:hi]) for lo, hi in spans]
    assert maps.dtype == np.float32 and maps.tobytes() == np.stack(alone).tobytes()
    assert not maps[1].any() and maps[3].sum() == pytest.approx(mag[8:46].sum(), rel=1e-5)


def test_spread_of_several_steps_is_each_steps_spread_bit_for_bit() -> None:
    limb, v, spreader = _draped_sleeve()
    moved = v + np.array([0.01, 0.0, 0.002])  # the sleeve a little further along, a little higher
    nodes = [np.array([30, 31, 45, 60]), np.array([31, 46])]
    mags = [np.array([0.5, 1.0, 0.25, 2.0]), np.array([0.7, 0.1])]
    at, pos, f = spreader.spread(
        limb, np.stack([v, moved]), np.repeat([0, 1], [4, 2]), np.concatenate(nodes),
        np.concatenate(mags),
    )  # fmt: skip
    for j, cloth in enumerate((v, moved)):
        p, g = spreader(limb, cloth, nodes[j], mags[j])
        assert pos[at == j].tobytes() == p.tobytes() and f[at == j].tobytes() == g.tobytes()
    assert list(at) == sorted(at)


def test_a_distributor_refuses_what_it_cannot_share() -> None:
    """k = 0 was a ZeroDivisionError; one magnitude for two contacts was broadcast (2 N)."""
    points = np.eye(3)
    with pytest.raises(ValueError, match="k must be 1 or more"):
        ForceDistributor(points, 0)
    with pytest.raises(ValueError, match="2 positions, 1 magnitudes"):
        ForceDistributor(points)(points[:2], np.array([1.0]))


@pytest.mark.parametrize("task", list(Task))
def test_nearest_points_come_as_argpartition_gives_them(task: Task) -> None:
    """The 5 distances are summed in the order of their points, so `nearest` must give
    argpartition's points in argpartition's order: on contacts near the limb (300 and
    400 points), with ties at the 5th and a NaN, and with `d2` left as it was."""
    points = limb_points(build_limb(task)).points
    rng = np.random.default_rng(11)
    pos, _ = surface_points(build_limb(task), rng.normal(size=(3000, 3)) * 0.15 + [0.4, 0, 0.3])
    pos[:200] = points[rng.integers(0, len(points), 200)]  # on a point: one distance is 0
    d2 = ((pos[:, None] - points[None]) ** 2).sum(axis=2)
    d2[200:220] = np.round(d2[200:220], 2)  # ties throughout
    d2[220, 7] = np.nan
    before = d2.copy()
    ours = nearest(d2, 5)
    theirs = np.argpartition(before, 4, axis=1)[:, :5]
    rows = np.arange(len(d2))[:, None]
    assert d2.tobytes() == before.tobytes()
    assert before[rows, ours].tobytes() == before[rows, theirs].tobytes()
    assert (np.sort(ours, axis=1) == np.sort(theirs, axis=1)).all()
