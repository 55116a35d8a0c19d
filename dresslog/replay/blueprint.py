"""Entity paths of a dresslog Rerun recording and its default layout (the blueprint).

Paths live here so that the sink that logs them, the blueprint that arranges
them and the tests that read them back cannot drift apart.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from dresslog.replay.colors import ZERO

if TYPE_CHECKING:
    import rerun.blueprint as rrb

STEP = "step"
#: Seconds since the trial's first step: the timeline the viewer opens on, so that play
#: runs at the trial's own speed (a sequence timeline plays steps at 30 per second).
TIME = "time"
#: Wall-clock time of a converted log whose stamps are epoch times, so that the trial
#: lines up with other recordings of the same run (a camera's, say).
TIMESTAMP = "timestamp"

WORLD = "world"
TRUTH = "world/truth"
ESTIMATE = "world/estimate"
TRUTH_LIMB = "world/truth/limb"
ESTIMATE_LIMB = "world/estimate/limb"
GARMENT = "world/truth/garment"
CONTACTS = "world/truth/contacts"
CONTACT_FORCES = "world/truth/contact_forces"
#: The gripper is measured, not ground truth: both 3D views show it.
EE = "world/ee"
EE_PATH = "world/ee_path"
#: The measured force on the gripper as an arrow at it, in both 3D views.
EE_FORCE_ARROW = "world/ee_force"
EE_FORCE = "plots/ee/force"
EE_TORQUE = "plots/ee/torque"
EE_VELOCITY = "plots/ee/velocity"
TOTAL_FORCE = "plots/total_force"
TOTAL_TRUTH = "plots/total_force/truth"
TOTAL_ESTIMATE = "plots/total_force/estimate"
RMSE = "plots/rmse"
SPEC = "trial/spec"
#: The colour key under the limb in each force map: no force, then the ramp to the scale's
#: top; its labels apart, in white, as a point's label takes the point's colour.
LEGEND = "world/legend"
LEGEND_LABELS = "world/legend/labels"

#: The force value behind each limb point's colour, logged beside it (AnyValues).
FORCE_FIELD = "force_newtons"


def is_long(points: np.ndarray) -> bool:
    """A limb much wider than tall (the leg): its two maps go one above the other."""
    extent = np.ptp(points, axis=0)
    return bool(extent[0] > 1.5 * extent[2])


#: A map view alone in a 1920x1080 window is this much wider than tall; the viewer's
#: camera is 55 degrees tall.
ALONE_ASPECT = 1.58
HALF_HEIGHT = np.radians(27.5)


def eye(
    points: np.ndarray, alone: bool = False, start: np.ndarray | None = None
) -> rrb.EyeControls3D:
    """A camera in front of the limb (looking along +y, z up) that frames all of it.

    Far enough that the limb fits its view: half the window wide for an arm, whose two
    maps sit side by side; a wide, low view for a leg, whose maps are stacked; the
    whole of the maps' area when one map is `alone` (no ground truth, or no model).
    Given the gripper's `start`, a map `alone` moves aside (and back if it must) until
    the gripper is in view from the first step too: a converted arm log's had it off its
    edge for the first 1.5 s. Two maps side by side have no width to spare for it.
    """
    import rerun.blueprint as rrb

    low, high = points.min(axis=0), points.max(axis=0)
    center = (low + high) / 2
    size = float(np.max(high - low))
    arm = not is_long(points)
    # from the limb, in limb sizes: (leg, arm), with one view or with two
    distance = (0.9, 1.2) if alone else (0.5, 1.7)
    position = center + np.array([0.07, -1.0, 0.24]) * distance[arm] * size
    if start is not None and alone:
        # within 90% of the view's half width, as the tangent of the angle off its axis
        limit = 0.9 * np.tan(HALF_HEIGHT) * ALONE_ASPECT
        framed = np.vstack([points, np.reshape(start, (1, 3))])
        position, center = _fit_sideways(framed, position, center, limit)
    return rrb.EyeControls3D(position=position, look_target=center, eye_up=[0, 0, 1])


def _fit_sideways(
    points: np.ndarray, position: np.ndarray, target: np.ndarray, limit: float
) -> tuple[np.ndarray, np.ndarray]:
    """Move a camera sideways (and back) until `points` lie within `limit` of its axis
    (tangents, left and right), centred between them."""
    for _ in range(50):
        ahead = (target - position) / np.linalg.norm(target - position)
        right = np.cross(ahead, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        rays = points - position
        tangent = (rays @ right) / (rays @ ahead)
        lo, hi = float(tangent.min()), float(tangent.max())
        if lo >= -limit and hi <= limit:
            break
        depth = float((target - position) @ ahead)
        shift = right * (hi + lo) / 2 * depth
        position, target = position + shift, target + shift
        if hi - lo > 2 * limit:
            position = target + (position - target) * (hi - lo) / (2 * limit)
    return position, target


def legend_positions(points: np.ndarray, count: int) -> np.ndarray:
    """Where the colour key's `count` swatches go: in a row just under the limb, as wide as
    it, facing the camera (which looks along +y); near enough for the leg's low view."""
    low, high = points.min(axis=0), points.max(axis=0)
    x = np.linspace(low[0], high[0], count)
    y = np.full(count, (low[1] + high[1]) / 2)
    z = np.full(count, low[2] - 0.15 * (high[2] - low[2]))
    return np.stack([x, y, z], axis=1)


def _maps(has_truth: bool, has_estimate: bool) -> list[tuple[str, str]]:
    """The force maps to show, each (entity root, view name).

    Ground truth and estimate each get a view of their own: one view holding both had to
    place one limb apart from the other, and the garment hanging from the gripper fell
    across it.
    """
    views = []
    if has_truth:
        alone = "" if has_estimate else " (no estimate: no model for this trial)"
        views.append((TRUTH, f"Force map: ground truth{alone}"))
    if has_estimate:
        alone = "" if has_truth else " (the trial has no ground truth)"
        views.append((ESTIMATE, f"Force map: estimate{alone}"))
    if not views:
        views.append((TRUTH, "Force map (no ground truth, no model: nothing to show)"))
    return views


def _map_views(maps: list[tuple[str, str]], camera: Any) -> list[rrb.Spatial3DView]:
    """One 3D view per map, the gripper in each; limb points grey until a step colours them
    (a live view shows the limb before its first steps arrive)."""
    import rerun as rr
    import rerun.blueprint as rrb

    grey = rr.Points3D.from_fields(colors=[ZERO.tolist()])
    return [
        rrb.Spatial3DView(
            name=name,
            origin=WORLD,
            contents=[
                f"+ /{root}/**",
                f"+ /{EE}/**",
                f"+ /{EE_PATH}",
                f"+ /{EE_FORCE_ARROW}",
                f"+ /{LEGEND}/**",
            ],
            background=[250, 250, 252],
            eye_controls=camera,
            defaults=[grey],
        )
        for root, name in maps
    ]


def _total_title(has_truth: bool, has_estimate: bool) -> str:
    """The total-force plot's name: it says what is drawn."""
    if has_truth and has_estimate:
        return "Total limb force (N): truth vs estimate"
    if has_estimate:
        return "Total limb force (N): estimate"
    if has_truth:
        return "Total limb force (N): ground truth"
    return "Total limb force (N)"


def _plot(name: str, origin: str) -> rrb.TimeSeriesView:
    """A time series with its legend top left: a trial starts from rest, so its first
    second sits at zero and the top left is empty (bottom left, the viewer's default,
    hid the gripper's steady -x speed and the zero line of every total)."""
    import rerun.blueprint as rrb

    return rrb.TimeSeriesView(name=name, origin=origin, plot_legend=rrb.Corner2D.LeftTop)


def default_blueprint(
    has_estimate: bool = True,
    limb_points: np.ndarray | None = None,
    has_truth: bool = True,
    *,
    live: bool = False,
    gripper_start: np.ndarray | None = None,
) -> rrb.Blueprint:
    """Force maps with the 9-D signal beside them; total force, RMSE and spec along the bottom.

    The viewer labels an axis only where its ticks (powers of ten) fall far enough apart:
    the bottom row spans the window so that its plots label each second (a third of the
    maps' width had shown "+0s" only), and the force takes half the signal's column (a
    third had labelled the sample's 14 N range "0" only). A recording plays once from its
    first step at the trial's own speed (left to itself, a viewer reading it from a
    stream, as `view --web`'s browser does, opens it at its last step); a `live` view
    keeps following the newest step. A map alone keeps where the gripper starts in view
    too, where that is known (a recording's, not a live view's).
    """
    import rerun.blueprint as rrb

    maps = _maps(has_truth, has_estimate)
    camera, stacked = None, False
    if limb_points is not None and len(limb_points):
        camera = eye(limb_points, alone=len(maps) == 1, start=gripper_start)
        stacked = is_long(limb_points)
    views = _map_views(maps, camera)
    comparison = [_plot(_total_title(has_truth, has_estimate), TOTAL_FORCE)]
    if has_truth and has_estimate:
        comparison.append(_plot("RMSE per step (N)", RMSE))
    signal = rrb.Vertical(
        _plot("End-effector force (N)", EE_FORCE),
        _plot("End-effector torque (N m)", EE_TORQUE),
        _plot("End-effector velocity (m/s)", EE_VELOCITY),
        row_shares=[2, 1, 1],
    )
    return rrb.Blueprint(
        rrb.Vertical(
            rrb.Horizontal(
                rrb.Vertical(*views) if stacked else rrb.Horizontal(*views),
                signal,
                column_shares=[3, 2],
            ),
            rrb.Horizontal(*comparison, rrb.TextDocumentView(name="Trial spec", origin=SPEC)),
            row_shares=[3, 1],
        ),
        rrb.TimePanel(
            timeline=TIME,
            state="collapsed",
            play_state=None if live else "playing",  # None: unset, a live view follows
            playback_speed=None if live else 1.0,
        ),
        rrb.BlueprintPanel(expanded=False),
        rrb.SelectionPanel(expanded=False),
    )
