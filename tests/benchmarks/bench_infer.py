"""Speed of `dresslog infer`: streaming latency per step, end-to-end work, start-up cost.

Not part of the default test run. Run from the repository root:

    python tests/benchmarks/bench_infer.py [TRIAL.mcap] [--model M] [--repeats 5]

Without arguments it uses samples/gown.mcap and the bundled gown model when
they exist, else a 700-step synthetic trial and a random model of the real size
(the speed does not depend on what the weights are). Streaming is measured on
one core (affinity pinned, BLAS single-threaded) against the 10 ms budget of a
100 Hz loop; the target is p99 <= 0.5 ms.

Then `infer --mcap-out`'s copy: the whole run with the copy, and what the standard
channels viewers draw (force clouds of truth and estimate, the garment's mesh, markers,
tf) add to it: the copy and its estimate written without them (`TrialWriter(draw=False)`)
and with them.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS: one core means one thread

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

BUDGET_MS = 10.0
TARGET_P99_MS = 0.5
TARGET_WORK_S = 0.5


def pin_one_core() -> str:
    if hasattr(os, "sched_setaffinity"):
        core = sorted(os.sched_getaffinity(0))[-1]
        os.sched_setaffinity(0, {core})
        return f"pinned to core {core}"
    return "not pinned"


def inputs(tmp: Path, trial: Path | None, model: Path | None) -> tuple[Path, Path]:
    from dresslog.model.bundled import bundled_model
    from dresslog.spec import Task

    if trial is None:
        sample = REPO / "samples" / "gown.mcap"
        if sample.is_file():
            trial = sample
        else:
            from tests.conftest import write_synthetic_trial

            trial = tmp / "synthetic.mcap"
            write_synthetic_trial(trial, Task.GOWN, 700)
    if model is None:
        from dresslog.io.reader import TrialReader

        with TrialReader(trial) as reader:
            task = reader.metadata.task
        model = bundled_model(task)
        if model is None:
            from tests.replay.conftest import save_random_model

            model = save_random_model(tmp, task)
    return trial, model


def percentiles(ns: list[int]) -> str:
    ms = np.asarray(ns) / 1e6
    p50, p99 = np.percentile(ms, [50, 99])
    return f"p50 {p50:.3f} ms  p99 {p99:.3f} ms  max {ms.max():.3f} ms"


def streaming(trial: Path, model: Path, repeats: int, tmp: Path) -> dict[str, list[int]]:
    """Per-step latency of the estimator alone and of a full engine step with every sink."""
    from dresslog.io.reader import read_trial
    from dresslog.model import load_model
    from dresslog.replay import McapSink, MetricsSink, Replay, RerunSink
    from dresslog.replay.engine import trial_context, trial_steps

    data = read_trial(trial)
    loaded = load_model(model)
    steps = list(trial_steps(data))
    estimator = loaded.estimator()
    out: dict[str, list[int]] = {"estimator.step": [], "engine step (all sinks)": []}
    clock = time.perf_counter_ns
    for _ in range(repeats):
        estimator.reset()
        for s in steps:
            t0 = clock()
            estimator.step(s.phi)
            out["estimator.step"].append(clock() - t0)
        sinks = [MetricsSink(), RerunSink(tmp / "lat.rrd"), McapSink(tmp / "lat.mcap")]
        replay = Replay(loaded.estimator(), sinks)
        replay.start(trial_context(data, trial))
        for s in steps:
            t0 = clock()
            replay.push(s)
            out["engine step (all sinks)"].append(clock() - t0)
        replay.abort()
    return out


def end_to_end(trial: Path, model: Path, repeats: int, tmp: Path) -> list[dict[str, float]]:
    """`replay_file` as `dresslog infer` runs it, imports already paid (measured apart)."""
    import rerun  # noqa: F401  (start-up cost, reported separately)

    from dresslog.replay.pipeline import replay_file

    runs = []
    for i in range(repeats):
        report = replay_file(trial, model=model, rrd=tmp / f"e2e{i}.rrd")
        runs.append(report.timings)
    return runs


def mcap_out(trial: Path, model: Path, repeats: int, tmp: Path) -> None:
    """`infer --mcap-out` end to end, and the drawn channels' share of it (best of runs)."""
    from dresslog.io.reader import read_trial
    from dresslog.io.writer import TrialWriter
    from dresslog.model import load_model
    from dresslog.replay.engine import trial_steps
    from dresslog.replay.mcap_sink import copy_trial
    from dresslog.replay.pipeline import replay_file

    runs, cpu = [], []
    for i in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        replay_file(trial, model=model, rrd=tmp / f"m{i}.rrd", mcap=tmp / f"m{i}.mcap")
        runs.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    whole, whole_cpu = statistics.median(runs), min(cpu)
    data = read_trial(trial)
    estimator = load_model(model).estimator()
    steps = list(trial_steps(data))
    results = [estimator.step(s.phi) for s in steps]
    forces, contact = (np.stack([r[i] for r in results]) for i in (0, 1))
    t_ns = np.array([s.t_ns for s in steps], np.int64)
    took: dict[bool, float] = {}
    for _ in range(repeats):  # in turn, CPU time: other work beside it skews wall time
        for draw in (False, True):
            start = time.process_time()
            with TrialWriter(tmp / "copy.mcap", data.metadata, overwrite=True, draw=draw) as w:
                copy_trial(w, data)
                w.write_force_map(t_ns, forces, contact, estimate=True)
            took[draw] = min(took.get(draw, np.inf), time.process_time() - start)
    added = took[True] - took[False]
    print(
        f"\ninfer --mcap-out end to end (median of {repeats}, imports included): "
        f"{whole * 1e3:.0f} ms"
    )
    print(
        f"  the copy (CPU time) without the drawn channels {took[False] * 1e3:6.1f} ms, "
        f"with them {took[True] * 1e3:6.1f} ms ({took[True] / took[False]:.2f}x)"
    )
    print(
        f"  its CPU time (best of {repeats}) {whole_cpu * 1e3:.0f} ms; the drawn channels add "
        f"{added * 1e3:.0f} ms, {100 * added / whole_cpu:.1f} % of it"
    )


def startup() -> dict[str, float]:
    """Import cost in a fresh interpreter, each measured alone (median of 3)."""
    code = (
        "import time,sys; t=time.perf_counter(); import {m}; "
        "print(time.perf_counter()-t, 'torch' in sys.modules)"
    )
    out = {}
    for module in ("dresslog.cli.main", "dresslog.replay.pipeline", "rerun", "dresslog.cli.infer"):
        times = []
        for _ in range(3):
            line = subprocess.run(
                [sys.executable, "-c", code.format(m=module)],
                capture_output=True,
                text=True,
                check=True,
                cwd=REPO,
            ).stdout.split()
            times.append(float(line[0]))
            assert line[1] == "False", f"{module} imported torch"
        out[module] = statistics.median(times)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trial", nargs="?", type=Path)
    parser.add_argument("--model", type=Path)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="dresslog-bench-") as name:
        tmp = Path(name)
        trial, model = inputs(tmp, args.trial, args.model)
        print(f"trial {trial}\nmodel {model}\n{pin_one_core()}")

        print(f"\nStreaming latency per step ({args.repeats} x replays; budget {BUDGET_MS} ms)")
        for what, ns in streaming(trial, model, args.repeats, tmp).items():
            p99 = np.percentile(ns, 99) / 1e6
            verdict = "ok" if p99 <= TARGET_P99_MS else "OVER TARGET"
            print(f"  {what:26s} {percentiles(ns)}  [{verdict}: p99 <= {TARGET_P99_MS} ms]")

        runs = end_to_end(trial, model, args.repeats, tmp)
        stages = {k: statistics.median(r[k] for r in runs) for k in runs[0] if k != "import_rerun"}
        total = sum(stages.values())
        verdict = "ok" if total <= TARGET_WORK_S else "OVER TARGET"
        print(f"\ninfer end to end (median of {args.repeats}): {total * 1e3:.0f} ms  [{verdict}]")
        for k, v in stages.items():
            print(f"  {k:12s} {v * 1e3:7.1f} ms  {100 * v / total:5.1f} %")
        print("  ('infer' includes buffering for the sinks; 'write' the .rrd encode and write)")
        mcap_out(trial, model, args.repeats, tmp)

    print("\nStart-up: import in a fresh interpreter (torch never imported)")
    for module, seconds in startup().items():
        print(f"  {module:26s} {seconds * 1e3:6.0f} ms")


if __name__ == "__main__":
    main()
