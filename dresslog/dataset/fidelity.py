"""How a folder's simulated trials compare with the dressing the paper describes.

`dresslog info DATA` prints these figures, so a researcher sees what a dataset holds
before training on it: the outcome mix (and where caught trials caught), where on the
limb the garment's force falls, how much of it arises while the gripper pulls, and the
force scale, the mean per-trial RMS of the ground-truth force map (the paper's all-zero
RMSE) beside the paper's own (Sec. V-A: gown 0.0148 N, shorts 0.102 N).

Each trial is read from its MCAP file alone, as any reader would: no simulator state.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dresslog.io.reader import TrialReader
from dresslog.sim.outcome import MOVING  # "while the gripper moves", as a catch counts it
from dresslog.spec import Outcome, Task
from dresslog.trial import STEP_HZ

#: The paper's all-zero RMSE per task, N (Sec. V-A): the force scale of its trials.
PAPER_ZERO_RMSE = {Task.GOWN: 0.0148, Task.SHORTS: 0.102}
#: Trials read at most, spread evenly over the folder: the figures settle well before.
MAX_READ = 200


@dataclass(frozen=True)
class TrialFigures:
    """One trial's share of the picture."""

    outcome: Outcome
    caught_on: str | None
    zero_rmse: float  # RMS of the force map over steps and points, N
    region_impulse: dict[str, float]  # force-time integral per limb part, N s
    moving_impulse: float  # of the limb's force-time integral, while the gripper moves


def trial_figures(path: str | Path) -> TrialFigures:
    """Read one trial's outcome, force scale and where and when its force falls."""
    with TrialReader(path) as trial:
        meta = trial.metadata
        forces = trial.force_map
        points = trial.limb_points
        twist = trial.twist
    if forces is None or points is None:
        return TrialFigures(meta.outcome, meta.caught_on, 0.0, {}, 0.0)
    f = forces.forces.astype(np.float64)
    dt = 1.0 / STEP_HZ  # a dataset's trials are all recorded at it
    per_part = np.zeros((len(f), len(points.segment_names)))
    for i in range(len(points.segment_names)):
        per_part[:, i] = f[:, points.segment == i].sum(axis=1)
    common = np.isin(twist.t_ns, forces.t_ns)
    speed = np.linalg.norm(twist.values[common, :3], axis=1)
    moving = np.isin(forces.t_ns, twist.t_ns[common][speed > MOVING])
    return TrialFigures(
        outcome=meta.outcome,
        caught_on=meta.caught_on,
        zero_rmse=float(np.sqrt(np.mean(f * f))) if f.size else 0.0,
        region_impulse={
            name: float(per_part[:, i].sum() * dt) for i, name in enumerate(points.segment_names)
        },
        moving_impulse=float(f[moving].sum() * dt),
    )


@dataclass
class Fidelity:
    """A set of trials' figures, summed."""

    task: Task
    trials: int = 0
    outcomes: Counter[str] = field(default_factory=Counter)
    caught_on: Counter[str] = field(default_factory=Counter)
    zero_rmse: list[float] = field(default_factory=list)
    regions: Counter[str] = field(default_factory=Counter)
    dressed_regions: Counter[str] = field(default_factory=Counter)
    moving: float = 0.0

    def add(self, t: TrialFigures) -> None:
        """Count one trial's figures in."""
        self.trials += 1
        self.outcomes[t.outcome.value] += 1
        if t.caught_on:
            self.caught_on[t.caught_on] += 1
        self.zero_rmse.append(t.zero_rmse)
        self.regions.update(t.region_impulse)
        if t.outcome is Outcome.DRESSED:
            self.dressed_regions.update(t.region_impulse)
        self.moving += t.moving_impulse

    @property
    def mean_zero_rmse(self) -> float:
        """The trials' mean all-zero RMSE (N): how much force a model has to estimate."""
        return float(np.mean(self.zero_rmse)) if self.zero_rmse else 0.0

    @property
    def moving_share(self) -> float:
        """The share of the limb's force-time integral taken while the gripper moves, not while
        it waits."""
        total = sum(self.regions.values())
        return self.moving / total if total > 0 else 0.0

    def as_dict(self) -> dict[str, object]:
        """The figures for `info --json`."""
        total = sum(self.regions.values()) or 1.0
        dressed = sum(self.dressed_regions.values()) or 1.0
        return {
            "trials_read": self.trials,
            "outcomes": dict(self.outcomes),
            "caught_on": dict(self.caught_on),
            "mean_zero_rmse": self.mean_zero_rmse,
            "paper_zero_rmse": PAPER_ZERO_RMSE[self.task],
            "force_share": {k: v / total for k, v in self.regions.items()},
            "dressed_force_share": {k: v / dressed for k, v in self.dressed_regions.items()},
            "moving_share": self.moving_share,
        }

    def lines(self) -> list[str]:
        """The figures as `info` prints them, one thing per line."""
        n = max(self.trials, 1)
        mix = ", ".join(f"{k} {v} ({v / n:.0%})" for k, v in self.outcomes.most_common())
        if self.caught_on:
            mix += "; caught on " + ", ".join(f"{k} {v}" for k, v in self.caught_on.most_common())
        paper = PAPER_ZERO_RMSE[self.task]
        return [
            f"  outcomes  {mix}",
            f"  force     mean per-trial RMS {self.mean_zero_rmse:.4f} N (the all-zero RMSE; "
            f"paper {paper:g} N, {self.mean_zero_rmse / paper:.2f}x)",
            f"  where     {_shares(self.regions)}",
            f"    dressed {_shares(self.dressed_regions)}",
            f"  when      {self.moving_share:.0%} of the limb's force-time integral while "
            "the gripper moves",
        ]


def _shares(regions: Counter[str]) -> str:
    total = sum(regions.values())
    if total <= 0:
        return "no force"
    return ", ".join(f"{k} {v / total:.0%}" for k, v in regions.most_common() if v / total >= 0.005)


def fidelity(task: Task, paths: Iterable[str | Path]) -> Fidelity:
    """The figures of the trials at `paths` (every one read)."""
    out = Fidelity(task)
    for path in paths:
        out.add(trial_figures(path))
    return out


def folder_fidelity(root: str | Path, task: Task, files: list[str]) -> tuple[Fidelity, int]:
    """The figures of a dataset folder's trial `files` (relative to `root`), at most
    `MAX_READ` of them, evenly spread; and how many were read."""
    if len(files) > MAX_READ:
        pick = np.linspace(0, len(files) - 1, MAX_READ).round().astype(int)
        files = [files[i] for i in pick]
    return fidelity(task, (Path(root) / f for f in files)), len(files)
