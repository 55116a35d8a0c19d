"""How a trial's channels can be wrong, in words: stamps that repeat or go back, a model
input with a gap or at another rate, a folder given for a file. Pure functions, used by
`TrialReader` as it reads.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from dresslog.io import well_known as wk
from dresslog.spec import Task
from dresslog.trial import STEP_HZ, median_rate

CONVERT_HINT = "for a ROS bag or a force/torque CSV, run `dresslog convert` first"


#: How many folders of trials a folder's hint names before it counts the rest.
_HINT_FOLDERS = 3


def folder_hint(folder: Path) -> str:
    """A folder of trials (a day's, a dataset split) is given by its files, and one whose
    trials lie in subfolders (a dataset's splits, a sweep's settings) by theirs; a model's
    (safetensors weights) with --model; a bag folder (metadata.yaml beside its storage) or
    one holding no trials is converted first."""
    if (folder / "metadata.yaml").exists():
        return CONVERT_HINT
    if any(folder.glob("*.safetensors")):  # weights: a model's folder
        return "a model's (it holds weights): give it with --model, after a trial"
    held = [folder]
    if not any(folder.glob("*.mcap")):  # its subfolders', or theirs where a subfolder has none
        near = {p.parent for p in folder.glob("*/*.mcap")}
        far = {p.parent for p in folder.glob("*/*/*.mcap") if p.parent.parent not in near}
        held = sorted(near | far)
    if not held:
        return CONVERT_HINT
    named = " ".join(str(f / "*.mcap") for f in held[:_HINT_FOLDERS])
    more = len(held) - _HINT_FOLDERS
    return f"give its trials, {named}" + (f" (and {more} more folders)" if more > 0 else "")


def stamp_problem(stamps: np.ndarray) -> str:
    """What makes a channel's sorted header stamps not one step each: all unset, some
    repeated, or negative; "" if nothing."""
    repeated = np.flatnonzero(np.diff(stamps) == 0)
    if len(stamps) > 1 and stamps[0] == stamps[-1]:
        return f"all {len(stamps)} messages have the header stamp {stamps[0]} ns, unset"
    if len(repeated):
        return (
            f"{len(repeated)} messages repeat another's header stamp (the first "
            f"{stamps[repeated[0]] / 1e9:.6g} s), and a step is one stamp"
        )
    if stamps[0] < 0:
        return f"header stamp {stamps[0]} ns is negative"
    return ""


def backwards(log_ns: np.ndarray, stamps: np.ndarray) -> str:
    """Where a channel's header stamps, in the order its messages were logged, go back: a
    clock that jumped back (sorted, its steps would interleave with the earlier ones as a
    channel at twice the rate, or repeat their stamps); "" if they never do."""
    in_log_order = stamps[np.argsort(np.asarray(log_ns, dtype=np.int64), kind="stable")]
    back = np.flatnonzero(np.diff(in_log_order) < 0)
    if not len(back):
        return ""
    i, first = int(back[0]) + 1, in_log_order[0]
    was, now = (in_log_order[i - 1] - first) / 1e9, (in_log_order[i] - first) / 1e9
    more = f" ({len(back)} times in all)" if len(back) > 1 else ""
    return (
        f"header stamps go backwards at message {i} of {len(stamps)} in the order logged, "
        f"from {was:.3f} s to {now:.3f} s (counted from the first stamp){more}: its clock "
        "jumped back, and a step is one time"
    )


def off_rate(rate: float) -> str:
    """Why a channel at `rate` Hz cannot be the model's input (its steps are `STEP_HZ`)."""
    return (
        f"is at {rate:.4g} Hz, and the model reads {STEP_HZ} Hz steps; "
        "resample the log onto them with `dresslog convert`"
    )


#: What to do about a trial whose steps are not the model's: make it again.
CURE = "re-record it, or re-convert its log"


@cache
def task_points(task: Task) -> int:
    """How many force-map points the limb of `task` has (300 on the arm, 400 on the leg)."""
    from dresslog.limb import build_limb  # lazily: the limb's geometry is not a reader's

    return sum(build_limb(task).points_per_part.values())


def _seconds(t_ns: int | np.integer, origin: int | np.integer) -> str:
    return f"{(int(t_ns) - int(origin)) / 1e9:.3f} s"


def input_problem(wrench: np.ndarray, twist: np.ndarray) -> tuple[str, str] | None:
    """(channel, problem and cure) of the model's two input channels' sorted stamps when they do
    not give one run of steps that both cover: at other rates, a hole in either, or one
    ending or starting while the other goes on. None if they do (or share no stamp at
    all, which `measurements` words itself). Times count from the trial's first step."""
    origin = min(wrench[0], twist[0])
    channels = ((wk.WRENCH, wrench), (wk.TWIST, twist))
    rates = {topic: median_rate(t) for topic, t in channels}
    if all(rates.values()) and abs(rates[wk.WRENCH] / rates[wk.TWIST] - 1) > 0.02:
        topic = next((t for t, r in rates.items() if abs(STEP_HZ / r - 1) > 0.02), wk.TWIST)
        return topic, off_rate(rates[topic])
    for topic, t_ns in channels:
        if len(t_ns) < 3:
            continue
        steps = np.diff(t_ns)
        step = np.median(steps)
        if len(holes := np.flatnonzero(steps > 1.5 * step)):
            at = holes[0]
            more = f"; {len(holes)} gaps in all" if len(holes) > 1 else ""
            return topic, (
                f"has a gap: no message between {_seconds(t_ns[at], origin)} and "
                f"{_seconds(t_ns[at + 1], origin)} ({(steps[at] - step) / 1e9:.3g} s, "
                f"{round(steps[at] / step) - 1} steps missing{more}), and the model would read "
                f"the steps either side as consecutive; {CURE}"
            )
    common = np.intersect1d(wrench, twist)
    if not len(common):
        return None
    for (topic, t_ns), (other, with_it) in zip(channels, channels[::-1], strict=True):
        alone = np.setdiff1d(t_ns, with_it)
        if not len(alone):
            continue
        if alone[0] > with_it[-1]:
            return other, (
                f"stops at {_seconds(with_it[-1], origin)}, {(t_ns[-1] - with_it[-1]) / 1e9:.3g} "
                f"s before {topic} does: the last {len(alone)} of {len(t_ns)} {topic} steps have "
                f"no {other} message, and the model reads both on every step; {CURE}"
            )
        if alone[-1] < with_it[0]:
            return other, (
                f"starts at {_seconds(with_it[0], origin)}, {(with_it[0] - t_ns[0]) / 1e9:.3g} s "
                f"after {topic} does: the first {len(alone)} of {len(t_ns)} {topic} steps have "
                f"no {other} message, and the model reads both on every step; {CURE}"
            )
        return other, (
            f"has no message of the stamp of {len(alone)} of {len(t_ns)} {topic} steps (the "
            f"first at {_seconds(alone[0], origin)}), and the model reads both on every step; "
            + CURE
        )
    return None
