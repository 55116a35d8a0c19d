"""Limb geometry and force-map sites."""

from __future__ import annotations

import numpy as np
import pytest

from dresslog.limb import POINT_LIFT, build_limb, limb_points, limb_sdf, segment_of
from dresslog.spec import LimbRotation, Task


@pytest.mark.parametrize(("task", "n"), [(Task.GOWN, 300), (Task.SHORTS, 400)])
def test_limb_has_the_reference_number_of_points(task: Task, n: int) -> None:
    lp = limb_points(build_limb(task))
    assert len(lp) == n
    assert lp.points.shape == (n, 3)
    assert lp.segment.max() < len(lp.segment_names)
    assert lp.limb == task.limb


def test_arm_points_per_segment_match_the_reference() -> None:
    lp = limb_points(build_limb(Task.GOWN))
    counts = dict(zip(lp.segment_names, np.bincount(lp.segment), strict=True))
    assert counts == {"fist": 36, "elbow": 17, "forearm": 101, "upper_arm": 146}


@pytest.mark.parametrize("task", list(Task))
def test_points_sit_just_outside_the_surface_about_2_cm_apart(task: Task) -> None:
    limb = build_limb(task)
    p = limb_points(limb).points
    d = limb_sdf(limb, p)
    assert d.min() > 0 and d.max() <= POINT_LIFT + 1e-9
    dist = np.linalg.norm(p[:, None] - p[None], axis=2)
    np.fill_diagonal(dist, np.inf)
    assert 0.015 < np.median(dist.min(axis=1)) < 0.035


def test_offset_moves_every_point() -> None:
    a = limb_points(build_limb(Task.GOWN)).points
    b = limb_points(build_limb(Task.GOWN, offset=(0.01, -0.02, 0.03))).points
    np.testing.assert_allclose(b - a, np.tile([0.01, -0.02, 0.03], (len(a), 1)), atol=1e-12)


def test_rotation_moves_only_the_forearm_about_the_elbow() -> None:
    base = build_limb(Task.GOWN)
    rot = build_limb(Task.GOWN, rotation=LimbRotation(axis="z", degrees=15))
    np.testing.assert_allclose(rot.spheres["shoulder"].center, base.spheres["shoulder"].center)
    elbow = base.spheres["elbow"].center
    r0 = np.linalg.norm(base.spheres["fist"].center - elbow)
    r1 = np.linalg.norm(rot.spheres["fist"].center - elbow)
    assert r1 == pytest.approx(r0)
    assert rot.spheres["fist"].center[1] > 0.05


def test_foot_is_at_45_degrees() -> None:
    leg = build_limb(Task.SHORTS)
    d = leg.spheres["toe"].center - leg.spheres["ankle"].center
    assert np.degrees(np.arctan2(d[2], d[0])) == pytest.approx(45.0)


def test_segment_of_points_is_their_part() -> None:
    limb = build_limb(Task.SHORTS)
    lp = limb_points(limb)
    agree = np.mean(segment_of(limb, lp.points) == lp.segment)
    assert agree > 0.9
