"""Entity paths of a dresslog Rerun recording and its default layout (the blueprint).

Paths live here so that the sink that logs them, the blueprint that arranges
them and the tests that read them back cannot drift apart.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import rerun.blueprint as rrb

STEP = "step"
SIM_TIME = "sim_time"

WORLD = "world"
ESTIMATE = "world/estimate"
TRUTH_LIMB = "world/truth/limb"
ESTIMATE_LIMB = "world/estimate/limb"
TRUTH_LABEL = "world/truth/label"
ESTIMATE_LABEL = "world/estimate/label"
GARMENT = "world/truth/garment"
EE = "world/truth/ee"
EE_PATH = "world/truth/ee_path"
CONTACTS = "world/truth/contacts"
CONTACT_FORCES = "world/truth/contact_forces"
EE_FORCE = "plots/ee/force"
EE_TORQUE = "plots/ee/torque"
EE_VELOCITY = "plots/ee/velocity"
TOTAL_FORCE = "plots/total_force"
TOTAL_TRUTH = "plots/total_force/truth"
TOTAL_ESTIMATE = "plots/total_force/estimate"
RMSE = "plots/rmse"
SPEC = "trial/spec"

#: The force value behind each limb point's colour, logged beside it (AnyValues).
FORCE_FIELD = "force_newtons"


def estimate_offset(points: np.ndarray, margin: float = 0.1) -> np.ndarray:
    """Where to draw the estimate limb: below the ground truth, as Fig. 6 stacks them."""
    height = float(np.ptp(points[:, 2])) if len(points) else 0.5
    return np.array([0.0, 0.0, -(height + margin)])


def eye(points: np.ndarray, both: bool) -> rrb.EyeControls3D:
    """A camera in front of the limb(s) (looking along +y, z up) that frames both of them."""
    import rerun.blueprint as rrb

    low, high = points.min(axis=0), points.max(axis=0)
    if both:
        low = np.minimum(low, low + estimate_offset(points))
    center = (low + high) / 2
    size = float(np.max(high - low))
    position = center + np.array([0.1, -1.25, 0.3]) * size
    return rrb.EyeControls3D(position=position, look_target=center, eye_up=[0, 0, 1])


def _titles(has_truth: bool, has_estimate: bool) -> tuple[str, str]:
    """The 3D view's and the total-force plot's names: they say what is drawn."""
    if has_truth and has_estimate:
        return (
            "Force map: ground truth (top), estimate (bottom)",
            "Total limb force (N): truth vs estimate",
        )
    if has_estimate:
        return (
            "Force map: estimate (the trial has no ground truth)",
            "Total limb force (N): estimate",
        )
    if has_truth:
        return "Force map: ground truth", "Total limb force (N): ground truth"
    return "Force map (no ground truth, no model: nothing to show)", "Total limb force (N)"


def default_blueprint(
    has_estimate: bool = True, limb_points: np.ndarray | None = None, has_truth: bool = True
) -> rrb.Blueprint:
    """3D heat maps on the left, the signals over time on the right, the spec below."""
    import rerun.blueprint as rrb

    both = has_truth and has_estimate
    name, total = _titles(has_truth, has_estimate)
    camera = eye(limb_points, both) if limb_points is not None and len(limb_points) else None
    plots = [
        rrb.TimeSeriesView(name="End-effector force (N)", origin=EE_FORCE),
        rrb.TimeSeriesView(name="End-effector torque (N m)", origin=EE_TORQUE),
        rrb.TimeSeriesView(name="End-effector velocity (m/s)", origin=EE_VELOCITY),
        rrb.TimeSeriesView(name=total, origin=TOTAL_FORCE),
    ]
    if both:
        plots.append(rrb.TimeSeriesView(name="RMSE per step (N)", origin=RMSE))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(
                    name=name, origin=WORLD, background=[250, 250, 252], eye_controls=camera
                ),
                rrb.TextDocumentView(name="Trial spec", origin=SPEC),
                row_shares=[5, 1],
            ),
            rrb.Vertical(*plots),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline=STEP, state="collapsed"),
        rrb.BlueprintPanel(expanded=False),
        rrb.SelectionPanel(expanded=False),
    )
