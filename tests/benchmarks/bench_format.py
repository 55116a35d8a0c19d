"""Benchmark: write and read back 100,000 ForceMap messages of 400 float32.

dresslog's numpy CDR codec (TrialWriter / TrialReader) against mcap_ros2's
generic writer and decoder, measured in the same run. Target: >= 5x both ways.

Then the cost of the standard channels viewers draw (`dresslog.io.drawn`: force
clouds, markers, tf): a recorded trial (samples/gown.mcap) written with them
against the same trial without them (`TrialWriter(draw=False)`), time and size;
with `--record`, `dresslog record`'s whole run both ways (two simulations).

    python tests/benchmarks/bench_format.py [--messages 100000] [--record]
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
from dresslog.trial import Trial

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


SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "gown.mcap"


def copy(path: Path, trial: Trial, draw: bool) -> int:
    """Write `trial` whole as `infer --mcap-out` copies it; returns the messages written."""
    from dresslog.replay.mcap_sink import copy_trial

    with TrialWriter(path, trial.metadata, overwrite=True, draw=draw) as writer:
        copy_trial(writer, trial)
    return sum(writer._sequence.values())


def drawn_cost(repeats: int) -> None:
    """The sample trial written with and without the drawn channels, in turn `repeats`
    times each; CPU time (the process's), as other work beside it skews wall time."""
    from dresslog.io.reader import read_trial

    trial = read_trial(SAMPLE)
    print(f"\n{SAMPLE.name} written whole, CPU time, best of {repeats}: without and with the")
    print("drawn channels")
    rows: dict[bool, tuple[float, int, int]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            for draw in (False, True):
                path = Path(tmp) / f"draw-{draw}.mcap"
                start = time.process_time()
                count = copy(path, trial, draw)
                took = time.process_time() - start
                if draw not in rows or took < rows[draw][0]:
                    rows[draw] = (took, count, path.stat().st_size)
    (t0, n0, s0), (t1, n1, s1) = rows[False], rows[True]
    print(f"{'':10}{'without':>14}{'with':>14}{'ratio':>8}")
    print(f"{'write ms':10}{t0 * 1e3:>14.1f}{t1 * 1e3:>14.1f}{t1 / t0:>7.2f}x")
    print(f"{'messages':10}{n0:>14,}{n1:>14,}{n1 / n0:>7.2f}x")
    print(f"{'msg/s':10}{n0 / t0:>14,.0f}{n1 / t1:>14,.0f}")
    print(f"{'file bytes':10}{s0:>14,}{s1:>14,}{s1 / s0:>7.2f}x")
    print(f"the drawn channels add {(t1 - t0) * 1e3:.0f} ms of writing and {s1 - s0:,} bytes")


def record_cost() -> None:
    """`dresslog record --task gown --seed 42` (what made the sample) without and with them."""
    from dresslog.io.reader import read_trial
    from dresslog.sim.record import WriterSink
    from dresslog.sim.simulate import simulate

    spec = read_trial(SAMPLE).metadata.spec
    print("\ndresslog record --task gown --seed 42, once each way (simulation included)")
    with tempfile.TemporaryDirectory() as tmp:
        for draw in (False, True):
            path = Path(tmp) / f"record-{draw}.mcap"
            start = time.perf_counter()
            with TrialWriter(path, TrialMetadata(task=spec.task, spec=spec), draw=draw) as w:
                sink = WriterSink(w)
                simulate(spec, sink)
                sink.flush()
            took = time.perf_counter() - start
            size = path.stat().st_size
            print(f"  {'with' if draw else 'without':8} {took:6.2f} s  {size:>10,} bytes")


def timed(fn, *args) -> tuple[float, object]:
    start = time.perf_counter()
    out = fn(*args)
    return time.perf_counter() - start, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--record", action="store_true", help="time `record` both ways too")
    args = parser.parse_args()
    count = args.messages
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
    drawn_cost(args.repeats)
    if args.record:
        record_cost()


if __name__ == "__main__":
    main()
