"""Benchmark: write and read back 100,000 ForceMap messages of 400 float32.

dresslog's numpy CDR codec (TrialWriter / TrialReader) against the strongest peer,
rosbags' serde (`Typestore.serialize_cdr` / `deserialize_cdr`, compiled per type),
each message written and read through mcap's own writer and reader; mcap_ros2's
pure-Python codec is shown beside them. The codec alone (payloads to and from numpy,
no file) is timed too, so the file's share is seen apart. Target: >= 5x both ways
against mcap_ros2; against rosbags, what is measured.

Then the cost of the standard channels viewers draw (`dresslog.io.drawn`: force
clouds, the garment's mesh, markers, tf): a recorded trial (samples/gown.mcap) written with them
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
from dresslog.io.msgdefs import msg_text, schema_text
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


def _rosbags_store():  # rosbags.typesys.Typestore
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    name = wk.SCHEMAS[wk.FORCE_MAP]
    store.register(get_types_from_msg(msg_text(name), name))
    return store


def rosbags_write(path: Path, t_ns: np.ndarray, forces: np.ndarray) -> None:
    """rosbags' serialiser message by message, into an MCAP by mcap's writer."""
    from mcap.writer import CompressionType, Writer

    store, name = _rosbags_store(), wk.SCHEMAS[wk.FORCE_MAP]
    ForceMap, Header, Time = (  # noqa: N806 (classes)
        store.types[n] for n in (name, "std_msgs/msg/Header", "builtin_interfaces/msg/Time")
    )
    empty = np.zeros(0, np.float32)
    with path.open("wb") as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="bench")
        sid = writer.register_schema(name, "ros2msg", schema_text(name).encode())
        cid = writer.register_channel(wk.FORCE_MAP, "cdr", sid)
        for i, (t, row) in enumerate(zip(t_ns.tolist(), forces, strict=True)):
            stamp = Time(sec=t // 10**9, nanosec=t % 10**9)
            msg = ForceMap(header=Header(stamp=stamp, frame_id="world"), forces=row, contact=empty)
            writer.add_message(cid, t, bytes(store.serialize_cdr(msg, name)), t, i)
        writer.finish()


def rosbags_read(path: Path) -> np.ndarray:
    """mcap's reader, rosbags' deserialiser message by message."""
    from mcap.reader import make_reader

    store, name = _rosbags_store(), wk.SCHEMAS[wk.FORCE_MAP]
    with path.open("rb") as stream:
        rows = [
            store.deserialize_cdr(message.data, name).forces
            for *_, message in make_reader(stream).iter_messages(topics=[wk.FORCE_MAP])
        ]
    return np.asarray(rows, dtype=np.float32)


def codecs(t_ns: np.ndarray, forces: np.ndarray) -> dict[str, tuple[float, float]]:
    """Encode and decode alone, no file: (encode s, decode s) of dresslog's and rosbags'."""
    from dresslog.io import cdr

    name = wk.SCHEMAS[wk.FORCE_MAP]

    def ours_encode() -> list[bytes]:
        msgs = cdr.new_messages(name, {"header.frame_id": 5, "forces": N_POINTS, "contact": 0},
                                len(forces))  # fmt: skip
        cdr.set_stamp(msgs, t_ns, "world")
        msgs["forces"] = forces
        return cdr.to_payloads(msgs)

    encode_ours, payloads = timed(ours_encode)
    decode_ours, runs = timed(cdr.decode, name, payloads)
    np.testing.assert_array_equal(runs[0]["forces"], forces)
    store = _rosbags_store()
    ForceMap, Header, Time = (  # noqa: N806 (classes)
        store.types[n] for n in (name, "std_msgs/msg/Header", "builtin_interfaces/msg/Time")
    )
    empty = np.zeros(0, np.float32)

    def theirs_encode() -> list[bytes]:
        return [
            bytes(store.serialize_cdr(ForceMap(
                header=Header(stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id="world"),
                forces=row, contact=empty), name))
            for t, row in zip(t_ns.tolist(), forces, strict=True)
        ]  # fmt: skip

    encode_theirs, theirs = timed(theirs_encode)
    assert theirs == payloads, "rosbags' bytes are dresslog's"
    decode_theirs, _ = timed(lambda: [store.deserialize_cdr(p, name).forces for p in theirs])
    return {"dresslog": (encode_ours, decode_ours), "rosbags": (encode_theirs, decode_theirs)}


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
        peer = Path(tmp) / "rosbags.mcap"
        w_peer, _ = timed(rosbags_write, peer, t_ns, forces)
        r_peer, got = timed(rosbags_read, peer)
        np.testing.assert_array_equal(got, forces)
        sizes = [p.stat().st_size / 1e6 for p in (ours, peer, theirs)]
    print(f"{count} ForceMap messages of {N_POINTS} float32, written to and read from MCAP")
    print(f"{'':10}{'dresslog':>14}{'rosbags':>14}{'ratio':>8}{'mcap_ros2':>14}{'ratio':>8}")
    for label, a, b, c in (("write", w_ours, w_peer, w_theirs), ("read", r_ours, r_peer, r_theirs)):
        print(
            f"{label:10}{count / a:>10,.0f} m/s{count / b:>10,.0f} m/s{b / a:>7.1f}x"
            f"{count / c:>10,.0f} m/s{c / a:>7.1f}x"
        )
    print(f"{'file MB':10}{sizes[0]:>14.1f}{sizes[1]:>14.1f}{'':>8}{sizes[2]:>14.1f}")
    alone = codecs(t_ns, forces)
    (enc_ours, dec_ours), (enc_peer, dec_peer) = alone["dresslog"], alone["rosbags"]
    print("codec alone (payloads <-> numpy, no file)")
    for label, a, b in (("encode", enc_ours, enc_peer), ("decode", dec_ours, dec_peer)):
        print(f"{label:10}{count / a:>10,.0f} m/s{count / b:>10,.0f} m/s{b / a:>7.1f}x")
    drawn_cost(args.repeats)
    if args.record:
        record_cost()


if __name__ == "__main__":
    main()
