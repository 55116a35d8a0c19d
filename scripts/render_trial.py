"""Render a recorded trial's frames: the cloth, the limb and its force map, as a PNG montage.

Reads only the MCAP file (garment vertices at 10 Hz, limb points, ground-truth force
map, gripper pose), so it shows what a trial holds, whichever simulator made it. One
row per viewpoint, one column per moment: the start, 25, 50 and 75% of the trial and
its end. The limb's force-map sites are drawn grey where untouched and coloured by
force where the garment presses; the gripper is the green dot.

    python scripts/render_trial.py trial.mcap -o frames.png [--views side top front]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from dresslog.errors import DresslogError
from dresslog.io import TrialReader

#: Camera (elevation, azimuth) in degrees per named view; world z up, limb along x.
VIEWS = {"side": (5, -90), "top": (85, -90), "front": (5, 0), "oblique": (25, -60)}
MOMENTS = (0.0, 0.25, 0.5, 0.75, 1.0)


def _frame_at(t_ns: np.ndarray, when: float) -> int:
    return int(np.clip(round(when * (len(t_ns) - 1)), 0, len(t_ns) - 1))


def render(path: Path, out: Path, views: list[str], title: str | None = None) -> Path:
    """Draw `path`'s frames into `out` (PNG) and return it."""
    with TrialReader(path) as trial:
        garment = trial.garment
        points = trial.limb_points
        fmap = trial.force_map
        pose = trial.pose
        meta = trial.metadata
    if garment is None or points is None:
        raise SystemExit(f"{path}: no garment or limb points to draw (a simulated trial has both)")
    # framed on the limb and the gripper's path: a garment flung aside may leave the frame
    near = points.points if pose is None else np.concatenate([points.points, pose.values[:, :3]])
    lo, hi = near.min(0), near.max(0)
    centre, half = (lo + hi) / 2, float((hi - lo).max()) / 2 + 0.05
    vmax = max(float(fmap.forces.max()), 1e-6) if fmap is not None else 1.0
    fig = plt.figure(figsize=(2.6 * len(MOMENTS), 2.6 * len(views) + 0.4))
    for row, view in enumerate(views):
        for col, when in enumerate(MOMENTS):
            ax = fig.add_subplot(len(views), len(MOMENTS), row * len(MOMENTS) + col + 1,
                                 projection="3d")  # fmt: skip
            g = _frame_at(garment.t_ns, when)
            t_ns = garment.t_ns[g]
            verts = garment.vertices[g]
            tris = verts[garment.triangles]
            ax.add_collection3d(Poly3DCollection(
                tris, facecolor=(0.25, 0.4, 0.85, 0.35), edgecolor=(0.1, 0.2, 0.5, 0.5),
                linewidth=0.3,
            ))  # fmt: skip
            label = f"t={t_ns / 1e9:.2f}s"
            if fmap is not None:
                k = int(np.clip(np.searchsorted(fmap.t_ns, t_ns), 0, len(fmap.t_ns) - 1))
                f = fmap.forces[k]
                touched = f > 0
                ax.scatter(*points.points[~touched].T, s=2, c="0.6", depthshade=False)
                ax.scatter(*points.points[touched].T, s=8, c=f[touched], cmap="inferno_r",
                           vmin=0, vmax=vmax, depthshade=False)  # fmt: skip
                label += f" limb {f.sum():.2f}N"
            if pose is not None:
                k = int(np.clip(np.searchsorted(pose.t_ns, t_ns), 0, len(pose.t_ns) - 1))
                ax.scatter(*pose.values[k, :3], s=30, c="limegreen", depthshade=False)
            ax.set_xlim(centre[0] - half, centre[0] + half)
            ax.set_ylim(centre[1] - half, centre[1] + half)
            ax.set_zlim(centre[2] - half, centre[2] + half)
            ax.set_box_aspect((1, 1, 1))
            ax.view_init(*VIEWS[view])
            ax.set_axis_off()
            ax.set_title(f"{view} {label}" if col == 0 else label, fontsize=8)
    heading = title or (
        f"{path.name}: {meta.task.value}, outcome {meta.outcome.value}"
        + (f"\n{meta.spec.describe()}" if meta.spec is not None else "")
    )
    fig.suptitle(heading, fontsize=9)
    fig.subplots_adjust(left=0, right=1, bottom=0, top=0.88, wspace=0, hspace=0.08)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("trial", type=Path)
    parser.add_argument("-o", "--output", type=Path)
    parser.add_argument("--views", nargs="+", default=["side", "oblique"], choices=list(VIEWS))
    parser.add_argument("--title")
    args = parser.parse_args()
    out = args.output or args.trial.with_suffix(".png")
    try:
        print(render(args.trial, out, args.views, args.title))
    except DresslogError as err:  # not a trial, or a damaged one: one line, exit 1
        raise SystemExit(f"Error: {err}") from None


if __name__ == "__main__":
    main()
