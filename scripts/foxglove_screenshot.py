"""Screenshot of Foxglove on a sample trial with dresslog's layout (docs/foxglove.png).

Foxglove's web app is not published as a site on npm, but `@foxglove/studio-base`
(MPL-2.0) ships the whole app prebuilt; `foxglove_screenshot/shot.mjs` serves that
bundle with a page that mounts it, holding dresslog's shipped layout, opens the trial in
headless Chromium and saves the window. The trial gets its estimate channels from
`dresslog infer --mcap-out` first, and is shown at the step where the limb carries the
most force. A docs tool, not part of the tests. It needs Node 18+, Debian's `chromium`
(`apt-get install -y chromium`; `CHROMIUM=/path` for another) and the pinned packages:

    (cd scripts/foxglove_screenshot && npm ci)
    python scripts/foxglove_screenshot.py [samples/gown.mcap] [--model M] [-o docs/foxglove.png]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
NODE_DIR = REPO / "scripts" / "foxglove_screenshot"


def busiest_time(trial: Path) -> str:
    """RFC 3339 time of the step whose ground-truth force map has the largest total."""
    from dresslog.io import well_known as wk
    from dresslog.io.reader import TrialReader

    with TrialReader(trial) as reader:
        fm = reader.force_map
        if fm is None:
            raise SystemExit(f"{trial}: no force map to show")
        step = int(np.argmax(fm.forces.sum(axis=1)))
        t_ns = int(fm.t_ns[step])
    sec, nsec = divmod(wk.TIME_ORIGIN_NS + t_ns, 10**9)  # the stamps' clock
    day = np.datetime64(sec, "s").astype(str)  # UTC, e.g. 2020-01-01T00:00:05
    return f"{day}.{nsec:09d}Z"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trial", nargs="?", type=Path, default=REPO / "samples" / "gown.mcap")
    parser.add_argument("--model", type=Path, help="model folder (default: the bundled one)")
    parser.add_argument("-o", "--output", type=Path, default=REPO / "docs" / "foxglove.png")
    parser.add_argument("--size", default="1600x1000", help="window WIDTHxHEIGHT")
    parser.add_argument("--settle", type=float, default=15.0, help="seconds to load and draw")
    args = parser.parse_args()
    if not (NODE_DIR / "node_modules").is_dir():
        raise SystemExit(f"run `npm ci` in {NODE_DIR} first")

    from dresslog.replay.foxglove import layout_text

    with tempfile.TemporaryDirectory() as tmp:
        estimated = Path(tmp) / "trial.mcap"
        infer = [str(Path(sys.executable).with_name("dresslog")), "infer", str(args.trial)]
        infer += ["--mcap-out", str(estimated), "-o", str(Path(tmp) / "trial.rrd")]
        if args.model:
            infer += ["--model", str(args.model)]
        subprocess.run(infer, check=True)
        layout = Path(tmp) / "layout.json"
        layout.write_text(layout_text(), encoding="utf-8")
        width, height = args.size.split("x")
        shot = ["node", "shot.mjs", str(estimated), str(layout), str(args.output.resolve())]
        shot += [busiest_time(estimated), width, height, str(args.settle)]
        subprocess.run(shot, cwd=NODE_DIR, check=True)


if __name__ == "__main__":
    main()
