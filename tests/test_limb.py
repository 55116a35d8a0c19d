"""Limb geometry and force-map sites."""

from __future__ import annotations

import numpy as np
import pytest

from dresslog.limb import (
    POINT_LIFT,
    along_limb,
    build_limb,
    chain_joints,
    limb_points,
    limb_sdf,
    segment_of,
)
from dresslog.sim import random_spec
from dresslog.sim.garments import garment_for
from dresslog.sim.trajectory import constant_speed, keep_clear
from dresslog.spec import PAPER_AXES, LimbRotation, Task


@pytest.mark.parametrize(("task", "n"), [(Task.GOWN, 300), (Task.SHORTS, 400)])
def test_limb_has_the_reference_number_of_points(task: Task, n: int) -> None:
    lp = limb_points(build_limb(task))
    assert len(lp) == n
    assert lp.points.shape == (n, 3)
    assert lp.segment.max() < len(lp.segment_names)
    assert lp.limb == {Task.GOWN: "arm", Task.SHORTS: "leg"}[task]


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


def test_our_rotation_axes_do_what_the_papers_named_axes_do() -> None:
    """The paper (y up) avoids +Z for the forearm, which lifts it into the gripper, and
    says -Z flattens the foot; its Y swings them sideways. Ours are y and z (PAPER_AXES)."""
    assert PAPER_AXES == {"x": "X", "y": "Z", "z": "Y"}

    def distal(task: Task, axis: str, degrees: float) -> np.ndarray:
        limb = build_limb(task, rotation=LimbRotation(axis=axis, degrees=degrees))
        tip, pivot = ("fist", "elbow") if task is Task.GOWN else ("toe", "ankle")
        return limb.spheres[tip].center - limb.spheres[pivot].center

    straight = distal(Task.GOWN, "y", 0.0)
    assert distal(Task.GOWN, "y", 15.0)[2] > straight[2] + 0.05  # +Z: fist up
    assert distal(Task.GOWN, "y", -15.0)[2] < straight[2] - 0.05
    swung = distal(Task.GOWN, "z", 15.0)
    assert abs(swung[1]) > 0.05 and swung[2] == pytest.approx(straight[2])  # Y: sideways

    def elevation(v: np.ndarray) -> float:
        return float(np.degrees(np.arctan2(v[2], v[0])))

    assert elevation(distal(Task.SHORTS, "y", 0.0)) == pytest.approx(45.0)
    assert elevation(distal(Task.SHORTS, "y", -15.0)) == pytest.approx(30.0)  # -Z: flatter


def test_foot_is_at_45_degrees() -> None:
    leg = build_limb(Task.SHORTS)
    d = leg.spheres["toe"].center - leg.spheres["ankle"].center
    assert np.degrees(np.arctan2(d[2], d[0])) == pytest.approx(45.0)


def test_segment_of_points_is_their_part() -> None:
    limb = build_limb(Task.SHORTS)
    lp = limb_points(limb)
    agree = np.mean(segment_of(limb, lp.points) == lp.segment)
    assert agree > 0.9


def clearance(limb, path: np.ndarray, held: np.ndarray) -> np.ndarray:
    """Per step, how far the nearest held point is from the limb surface."""
    points = (path[:, None] + held[None]).reshape(-1, 3)
    return limb_sdf(limb, points).reshape(len(path), len(held)).min(axis=1)


HELD = np.array([[0.0, 0.0, 0.0], [0.1, 0.04, 0.0], [0.2, -0.04, 0.0]])


@pytest.mark.parametrize(
    ("task", "order"),
    [(Task.GOWN, ["fist", "forearm", "elbow", "upper_arm"]),
     (Task.SHORTS, ["toe", "foot", "heel", "ankle", "shin", "knee", "thigh"])],
)  # fmt: skip
def test_along_the_limb_runs_from_the_hand_or_foot_as_a_garment_is_drawn_on(
    task: Task, order: list[str]
) -> None:
    """`eval --plot` lays the limb out from the tip of the hand or foot: each part after
    the one the garment reaches before it, every point between the tip and the shoulder's
    or hip's far side, wherever the limb is placed."""
    limb = build_limb(task)
    points = limb_points(limb)
    along = along_limb(limb, points.points)
    names = list(points.segment_names)
    means = [along[points.segment == names.index(part)].mean() for part in order]
    assert means == sorted(means), dict(zip(order, means, strict=True))
    last = limb.spheres[limb.chain[-1]]
    assert -POINT_LIFT - 1e-9 <= along.min() < 0.01
    assert along.max() <= chain_joints(limb)[-1] + last.radius + POINT_LIFT
    moved = build_limb(task, offset=(0.3, -0.1, 0.05))
    np.testing.assert_allclose(along_limb(moved, limb_points(moved).points), along, atol=1e-12)
    joints = chain_joints(limb)
    assert joints[0] == limb.spheres[limb.chain[0]].radius and np.all(np.diff(joints) > 0.1)


def test_keep_clear_lifts_over_a_raised_arm_no_faster_than_the_path_moves() -> None:
    limb = build_limb(Task.GOWN, (0.0, 0.0, 0.10))  # the arm raised into the path
    n, step = 400, 0.7 / 399
    path = np.stack([np.linspace(0.8, 0.1, n), np.zeros(n), np.full(n, 0.10)], axis=1)
    lifted = keep_clear(path, limb, HELD, 0.01, max_lift=0.10, max_rise=step)
    before = clearance(limb, path, HELD)
    assert before.min() < 0 and clearance(limb, lifted, HELD).min() >= 0.01 - 1e-6
    assert np.array_equal(lifted[:, :2], path[:, :2]) and np.all(lifted[:, 2] >= path[:, 2])
    assert np.abs(np.diff(lifted[:, 2])).max() <= step + 1e-12  # no jumps
    assert np.array_equal(lifted[:20], path[:20])  # far from the arm: untouched


def test_keep_clear_smoothing_bounds_the_vertical_acceleration() -> None:
    """Without smoothing the lift is a tent over the raised arm: its vertical speed flips
    from +step to -step at once. Smoothed over 75 steps it changes by at most
    2 * step / 75 per step, still clears the arm and still lifts no faster."""
    limb = build_limb(Task.GOWN, (0.0, 0.0, 0.10))
    n, step = 400, 0.7 / 399
    path = np.stack([np.linspace(0.8, 0.1, n), np.zeros(n), np.full(n, 0.10)], axis=1)
    sharp = keep_clear(path, limb, HELD, 0.01, max_lift=0.10, max_rise=step)
    smooth = keep_clear(path, limb, HELD, 0.01, max_lift=0.10, max_rise=step, smoothing=75)
    assert np.abs(np.diff(sharp[:, 2], 2)).max() > step / 2  # corners: the rate jumps
    assert np.abs(np.diff(smooth[:, 2], 2)).max() <= 2 * step / 75 + 1e-12
    assert np.abs(np.diff(smooth[:, 2])).max() <= step + 1e-12
    assert np.all(smooth[:, 2] >= sharp[:, 2] - 1e-12)  # never below the needed lift
    assert clearance(limb, smooth, HELD).min() >= 0.01 - 1e-6
    assert smooth[:, 2].max() <= sharp[:, 2].max() + 1e-12  # and no higher than needed


def test_keep_clear_stops_where_lifting_would_not_clear_the_limb() -> None:
    limb = build_limb(Task.GOWN, (0.0, 0.0, 0.0))
    # along the forearm, 10 cm up, and on into the upright upper arm
    n = 400
    path = np.stack([np.linspace(0.6, -0.2, n), np.zeros(n), np.full(n, 0.10)], axis=1)
    held = HELD[:1]
    out = keep_clear(path, limb, held, 0.01, max_lift=0.10, max_rise=0.8 / n)
    moving = np.flatnonzero(np.any(np.diff(out, axis=0) != 0, axis=1))
    stop = moving[-1] + 1
    assert 0 < stop < n - 1 and np.all(out[stop:] == out[stop])  # holds still
    assert clearance(limb, out, held).min() >= 0.01 - 1e-6  # never pushed into the arm
    assert clearance(limb, path, held)[stop + 1 :].min() < 0.01  # where it would have gone


def test_keep_clear_leaves_a_clear_path_as_it_is() -> None:
    limb = build_limb(Task.GOWN, (0.0, 1.0, 0.0))  # the arm far to the side
    path = np.stack([np.linspace(0.8, 0.1, 50), np.zeros(50), np.full(50, 0.10)], axis=1)
    assert keep_clear(path, limb, HELD, 0.01, max_lift=0.10, max_rise=0.01) is path


def test_keep_clear_does_not_raise_the_held_edge_into_another_part_of_the_limb() -> None:
    """A gown trial (seed 1175044 of the v5 dataset) where lifting early, for the raised
    forearm ahead, would bring the top seam into the arm near the elbow: it stops first."""
    spec = random_spec(Task.GOWN, 1175044)
    limb = build_limb(Task.GOWN, spec.limb_offset, spec.limb_rotation)
    garment = garment_for(Task.GOWN)
    held = garment.vertices[garment.gripped]
    path = constant_speed(np.asarray(spec.control_points), spec.speed, np.arange(2100) / 300)
    out = keep_clear(path, limb, held, 0.01, max_lift=0.10, max_rise=spec.speed / 300)
    assert clearance(limb, out, held).min() >= 0.0
    assert np.all(out[-600:] == out[-1]) and not np.array_equal(out[-600:], path[-600:])
