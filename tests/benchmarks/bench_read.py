"""Benchmark: peak memory and time of `dresslog info` and `infer` on a 30-minute trial.

The trial is samples/gown.mcap repeated end to end (its stamps moved on by 7 s each time)
until it lasts `--minutes`: 100 Hz wrench, twist, pose, contacts and 400-point force maps,
the garment at 10 Hz, as the simulator records them. Each command runs in its own process
under `/usr/bin/time -v` (maximum resident set size, wall time). The peer, in the same run,
is mcap's own indexed reader walking every message of the file without decoding it.

    python tests/benchmarks/bench_read.py [--minutes 30] [--keep LONG.mcap]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "samples" / "gown.mcap"


def long_trial(path: Path, minutes: float) -> int:
    """Write the sample over and over into one trial of `minutes`; returns its steps."""
    from dresslog.io.reader import read_trial
    from dresslog.io.writer import TrialWriter

    trial = read_trial(SAMPLE)
    assert trial.force_map is not None and trial.contacts is not None
    assert trial.limb_points is not None and trial.garment is not None and trial.pose is not None
    step = int(np.median(np.diff(trial.wrench.t_ns)))
    period = int(trial.wrench.t_ns[-1] - trial.wrench.t_ns[0]) + step
    repeats = max(1, round(minutes * 60e9 / period))
    with TrialWriter(path, trial.metadata, overwrite=True) as writer:
        writer.write_limb_points(int(trial.wrench.t_ns[0]), trial.limb_points)
        for k in range(repeats):
            shift = k * period
            writer.write_wrench(trial.wrench.t_ns + shift, trial.wrench.values)
            writer.write_twist(trial.twist.t_ns + shift, trial.twist.values)
            writer.write_pose(trial.pose.t_ns + shift, trial.pose.values)
            writer.write_force_map(trial.force_map.t_ns + shift, trial.force_map.forces)
            for t, contacts in zip(trial.contacts.t_ns, trial.contacts.items, strict=True):
                writer.write_contacts(int(t) + shift, contacts)
            for i, t in enumerate(trial.garment.t_ns):
                tris = trial.garment.triangles if k == 0 and i == 0 else None
                writer.write_garment(int(t) + shift, trial.garment.vertices[i], tris)
    return repeats * len(trial.wrench)


def measured(command: list[str]) -> tuple[float, float]:
    """(peak resident MB, wall seconds) of one command in its own process."""
    done = subprocess.run(
        ["/usr/bin/time", "-v", *command], capture_output=True, text=True, cwd=REPO
    )
    if done.returncode:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr[-2000:]}")
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", done.stderr)
    assert peak and wall
    seconds = 0.0
    for part in wall.group(1).split(":"):
        seconds = seconds * 60 + float(part)
    return int(peak.group(1)) / 1024, seconds


PEER = """
import sys
from mcap.reader import make_reader
with open(sys.argv[1], "rb") as f:
    n = sum(1 for _ in make_reader(f, validate_crcs=True).iter_messages())
print(n)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--keep", type=Path, help="write (or reuse) the long trial here")
    parser.add_argument("--no-infer", action="store_true", help="measure `info` alone")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="dresslog-bench-") as name:
        tmp = Path(name)
        path = args.keep or tmp / "long.mcap"
        if not path.exists():
            t0 = time.perf_counter()
            steps = long_trial(path, args.minutes)
            print(f"wrote {steps} steps in {time.perf_counter() - t0:.1f} s")
        print(f"{path}: {path.stat().st_size / 1e6:.0f} MB")
        dresslog = str(Path(sys.executable).with_name("dresslog"))
        runs = {
            "mcap iter_messages (peer)": [sys.executable, "-c", PEER, str(path)],
            "dresslog info": [dresslog, "info", str(path)],
        }
        if not args.no_infer:
            runs["dresslog infer"] = [dresslog, "infer", str(path), "-o", str(tmp / "long.rrd")]
        figures = {what: measured(command) for what, command in runs.items()}
        peer_mb, peer_s = figures["mcap iter_messages (peer)"]
        for what, (mb, s) in figures.items():
            print(
                f"  {what:26s} peak {mb:7.0f} MB ({mb / peer_mb:4.1f}x the peer)  "
                f"wall {s:6.1f} s ({s / peer_s:4.1f}x)"
            )


if __name__ == "__main__":
    main()
