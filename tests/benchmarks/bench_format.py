"""Benchmark: write and read back 100,000 ForceMap messages of 400 float32.

dresslog's numpy CDR codec (TrialWriter / TrialReader) against mcap_ros2's
generic writer and decoder, measured in the same run. Target: >= 5x both ways.

    python tests/benchmarks/bench_format.py [--messages 100000]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from dresslog.io import well_known as wk
from dresslog.io.msgdefs import schema_text
from dresslog.io.reader import TrialReader
from dresslog.io.writer import TrialWriter
from dresslog.spec import Task, TrialMetadata

N_POINTS = 400


def force_maps(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Sparse, realistic force maps: about 5% of the limb points touched."""
    rng = np.random.default_rng(0)
    forces = np.where(rng.random((count, N_POINTS)) < 0.05, rng.random((count, N_POINTS)), 0)
    return np.arange(count, dtype=np.int64) * 10_000_000, forces.astype(np.float32)


def dresslog_write(path: Path, t_ns: np.ndarray, forces: np.ndarray) -> None:
    with TrialWriter(path, TrialMetadata(task=Task.SHORTS), overwrite=True) as writer:
        writer.write_wrench(0, np.zeros(6))
        writer.write_twist(0, np.zeros(6))
        writer.write_force_map(t_ns, forces)


def dresslog_read(path: Path) -> np.ndarray:
    with TrialReader(path) as reader:
        return reader.force_map.forces


def ros2_write(path: Path, t_ns: np.ndarray, forces: np.ndarray) -> None:
    from mcap_ros2.writer import Writer

    name = wk.SCHEMAS[wk.FORCE_MAP]
    with path.open("wb") as stream:
        writer = Writer(stream)
        schema = writer.register_msgdef(name, schema_text(name))
        for i, (t, row) in enumerate(zip(t_ns.tolist(), forces, strict=True)):
            msg = {
                "header": {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9}, "frame_id": "world"},
                "forces": row.tolist(),
                "contact": [],
            }
            writer.write_message(wk.FORCE_MAP, schema, msg, log_time=t, publish_time=t, sequence=i)
        writer.finish()


def ros2_read(path: Path) -> np.ndarray:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        rows = [msg.forces for *_, msg in reader.iter_decoded_messages(topics=[wk.FORCE_MAP])]
    return np.asarray(rows, dtype=np.float32)


def timed(fn, *args) -> tuple[float, object]:
    start = time.perf_counter()
    out = fn(*args)
    return time.perf_counter() - start, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=100_000)
    count = parser.parse_args().messages
    t_ns, forces = force_maps(count)
    with tempfile.TemporaryDirectory() as tmp:
        ours, theirs = Path(tmp) / "dresslog.mcap", Path(tmp) / "mcap_ros2.mcap"
        w_ours, _ = timed(dresslog_write, ours, t_ns, forces)
        r_ours, got = timed(dresslog_read, ours)
        np.testing.assert_array_equal(got, forces)
        w_theirs, _ = timed(ros2_write, theirs, t_ns, forces)
        r_theirs, got = timed(ros2_read, theirs)
        np.testing.assert_array_equal(got, forces)
        sizes = ours.stat().st_size / 1e6, theirs.stat().st_size / 1e6
    print(f"{count} ForceMap messages of {N_POINTS} float32")
    print(f"{'':10}{'dresslog':>14}{'mcap_ros2':>14}{'ratio':>8}")
    for label, a, b in (("write", w_ours, w_theirs), ("read", r_ours, r_theirs)):
        print(f"{label:10}{count / a:>10,.0f} m/s{count / b:>10,.0f} m/s{b / a:>7.1f}x")
    print(f"{'file MB':10}{sizes[0]:>14.1f}{sizes[1]:>14.1f}")


if __name__ == "__main__":
    main()
