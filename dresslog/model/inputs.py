"""What the network reads at each step: the 9-D signal phi, and optionally its change.

A model trained with `input_differences` reads [phi_t, phi_t - phi_{t-1}] (18-D; the
change is 0 at the first step). The LSTM could form that difference itself, but its
tanh units, fed standardised inputs, pick up a step's change poorly: on the gown the
change as 9 more inputs took the test ratio from 0.680 to 0.663, and the bundled models
from 0.650 to 0.623 (gown) and 0.456 to 0.411 (shorts; docs/experiments.md).
The weights alone say which a model reads: their input width is 9 or 18.

`unfamiliar` says when a trial's signal lies where the model never read one (a channel
far outside its training data, or a gripper heading another way): a robot's log in
other axes or units, or from a sensor not tared, would otherwise be estimated silently.
"""

from __future__ import annotations

import numpy as np

from dresslog.trial import MOVING_SPEED

#: The end effector's measurement per step: force (3), torque (3), velocity (3).
PHI_DIM = 9
#: phi's channels and their units, as a warning names them.
PHI_NAMES = ("fx", "fy", "fz", "tx", "ty", "tz", "vx", "vy", "vz")
PHI_UNITS = ("N", "N", "N", "N m", "N m", "N m", "m/s", "m/s", "m/s")
#: A channel is unfamiliar when more than FAR_SHARE of a trial's steps, and at least
#: FAR_STEPS (0.5 s: not one knock), lie beyond FAR_SD of the training data's standard
#: deviations: 32 simulated trials the bundled models never saw have at most 1.7% of
#: steps beyond 10, an untared sensor (the gripper's own weight in fz) every step.
FAR_SD = 10.0
FAR_SHARE = 0.1
FAR_STEPS = 50
#: A channel that barely varied in training (a constant column) cannot say what is far.
STILL_STD = 1e-6
#: A moving step (over MOVING_SPEED) heads the training trials' way when its velocity is
#: within 60 degrees of their mean velocity; a log is unfamiliar when under ALONG_SHARE of
#: its moving steps do, or when it moves mostly one way more than 60 degrees from theirs.
#: Simulator v9's gown path turns from along the forearm (-x) to up the upper arm (+z), so
#: its mean way lies between the two, 37 and 53 degrees from each: 45 degrees counted
#: the first second of a trial, with its spline's sideways swing, as unfamiliar.
HEADING_COS = float(np.cos(np.radians(60)))
ALONG_SHARE = 0.2
#: What most often puts a channel far from the training data, by kind, or the gripper's
#: heading away from the training trials' way.
_CAUSES = {
    "N": "is the sensor tared (`convert --tare`), in world axes (`--wrench-frame pose`) and in N?",
    "N m": "is the sensor tared (`convert --tare`), in world axes and in N m, about the gripper "
    "centre (`--wrench-frame pose --sensor-offset`)?",
    "m/s": "is the velocity in m/s and in the world axes of the simulated trials (README, "
    '"Your robot\'s data")?',
    "heading": "is the log in the simulated trials' axes (`convert --rotate`; README, "
    '"Your robot\'s data")?',
}
#: A simulated trial's signal is the simulator's own, in its axes and tared, so what sets
#: it apart is the model's training: trials of another duration, speed or limb pose.
_SIMULATED_CAUSE = (
    "the trial is simulated, so the model was trained on trials unlike it (`dresslog info` "
    "on the model and its dataset says how)"
)


def network_inputs(phi: np.ndarray, differences: bool) -> np.ndarray:
    """(..., T, 9) -> the network's (..., T, 9) or, with `differences`, (..., T, 18)."""
    if not differences:
        return phi
    change = np.diff(phi, axis=-2, prepend=phi[..., :1, :])
    return np.concatenate([phi, change], axis=-1)


def reads_differences(input_dim: int) -> bool:
    """Whether a network of this input width reads phi's change too; ValueError if neither."""
    if input_dim not in (PHI_DIM, 2 * PHI_DIM):
        raise ValueError(f"input width {input_dim}: expected {PHI_DIM} or {2 * PHI_DIM}")
    return input_dim == 2 * PHI_DIM


def unfamiliar(
    phi: np.ndarray, mean: np.ndarray, std: np.ndarray, *, simulated: bool = False
) -> str | None:
    """Why a trial's signal (T, 9) is far from the training data's, or None if it is not.

    `mean` and `std` describe the training signal per channel (the first 9 are phi's).
    A network extrapolates there without a sign of it, and the usual causes are the
    recording's (a sensor not tared, in its own axes, in other units), not the model's;
    but a `simulated` trial's signal is the simulator's, so there it is the model's.
    """
    mean, std = np.asarray(mean[:PHI_DIM]), np.asarray(std[:PHI_DIM])
    far = np.abs(phi - mean) > FAR_SD * np.maximum(std, STILL_STD)
    far[:, std < STILL_STD] = False
    counts = far.sum(axis=0)
    k = int(counts.argmax())
    if counts[k] < max(FAR_STEPS, FAR_SHARE * len(phi)):
        why, cause = _heading(phi[:, 6:9], mean[6:9]), "heading"
    else:
        cause = unit = PHI_UNITS[k]
        why = (
            f"{PHI_NAMES[k]} lies beyond {FAR_SD:g} standard deviations of the model's "
            f"training data on {counts[k] / len(phi):.0%} of steps (median there "
            f"{np.median(phi[far[:, k], k]):.3g} {unit}; trained on {mean[k]:.3g} +- "
            f"{std[k]:.3g} {unit}), so the estimate there is a guess"
        )
    if why is None:
        return None
    return f"{why}; {_SIMULATED_CAUSE if simulated else _CAUSES[cause]}"


def _heading(velocity: np.ndarray, trained: np.ndarray) -> str | None:
    """Why the gripper's heading (velocity (T, 3)) is not the training trials', or None.

    The simulated gripper draws the garment along the limb, hand to shoulder or foot to
    hip (-x), so a log in another robot's axes, whose values all lie in range, moves
    elsewhere; the model reads the signal in the simulated trials' axes only. Counted
    step by step, so a log that also returns the way it came is not taken for one.
    """
    speed = np.sqrt((velocity * velocity).sum(axis=1))
    moving = speed > MOVING_SPEED
    usual = float(np.linalg.norm(trained))
    if moving.sum() < FAR_STEPS or usual < MOVING_SPEED:
        return None
    unit = velocity[moving] / speed[moving, None]
    along = float((unit @ (trained / usual) >= HEADING_COS).mean())
    mostly = unit.mean(axis=0)
    size = float(np.linalg.norm(mostly))
    one_way = size > 0.5  # one way, not back and forth
    away = one_way and float(mostly @ trained) / (size * usual) < HEADING_COS
    if along >= ALONG_SHARE and not away:
        return None
    if one_way:
        mostly_s = ", ".join(f"{round(v, 2) + 0.0:.2f}" for v in mostly / size)
        where = f"; it moves mostly along ({mostly_s})"
    else:
        where = ""
    usual_s = ", ".join(f"{round(v, 2) + 0.0:.2f}" for v in trained / usual)
    return (
        f"{along:.0%} of the gripper's moving steps head within 60 degrees of the model's "
        f"training trials' way ({usual_s}){where}, so the estimate is a guess"
    )
