"""Screenshot of the Rerun viewer on a sample trial, for the README (docs/screenshot.png).

Runs without a display: Rerun's headless viewer renders on Mesa's software
Vulkan (`apt-get install -y mesa-vulkan-drivers libvulkan1`). The trial is
replayed into an .rrd exactly as `dresslog view --save` would, opened in the
viewer with its default blueprint, and captured at the step where the limb
carries the most force. Rerun with:

    python scripts/screenshot.py [samples/gown.mcap] [--model M] [-o docs/screenshot.png]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def busiest_step(trial: Path) -> int:
    """The step whose ground-truth force map has the largest total (the middle without one)."""
    from dresslog.io.reader import TrialReader

    with TrialReader(trial) as reader:
        fm = reader.force_map
        if fm is None or not fm.forces.any():
            return len(reader.measurements) // 2
        return int(np.argmax(fm.forces.sum(axis=1)))


def capture(rrd: Path, out: Path, step: int, port: int, settle: float) -> None:
    """Open `rrd` in a headless viewer, move to `step`, save the window as `out`."""
    from rerun.experimental import ViewerClient

    viewer = ViewerClient.spawn(headless=True, port=port)
    try:
        viewer.open(str(rrd))
        # on the timeline the recording opens on (seconds), at the step's time
        viewer.set_time("time", duration=step / 100, play_state="paused")
        time.sleep(settle)  # draw a few frames; let the start-up notifications fade
        viewer.save_screenshot(str(out.resolve()))
    finally:
        viewer.quit()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trial", nargs="?", type=Path, default=REPO / "samples" / "gown.mcap")
    parser.add_argument("--model", type=Path, help="model folder (default: the bundled one)")
    parser.add_argument("-o", "--output", type=Path, default=REPO / "docs" / "screenshot.png")
    parser.add_argument("--step", type=int, help="step to show (default: the busiest)")
    parser.add_argument("--port", type=int, default=9877)
    parser.add_argument("--settle", type=float, default=7.0, help="seconds before capturing")
    args = parser.parse_args()

    from dresslog.replay.viewer import save_rrd

    args.output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="dresslog-shot-") as tmp:
        rrd = Path(tmp) / "trial.rrd"
        print(save_rrd(args.trial, rrd, model=args.model))
        step = args.step if args.step is not None else busiest_step(args.trial)
        capture(rrd, args.output, step, args.port, args.settle)
    print(f"step {step} -> {args.output}")


if __name__ == "__main__":
    main()
