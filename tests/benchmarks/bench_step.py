"""Benchmark: one stateful inference step (batch 1) of the force-map LSTM, N = 400.

dresslog's numpy `NumpyEstimator.step` (Eq. 2 applied, fresh output arrays) against
torch's `ForceMapLSTM` fed one step at a time with its state carried, on one thread,
measured in the same run. Target: numpy p99 <= 0.5 ms.

    python tests/benchmarks/bench_step.py [--steps 5000] [--points 400] [--hidden 50]
        [--input-differences]

`--hidden 100 --input-differences` is what both bundled models are: 100 cells that read
phi and its change per step (the numpy step forms the change; torch is handed it).
"""

from __future__ import annotations

import os

# One core: pin BLAS before numpy is imported (torch is pinned below).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import torch  # noqa: E402

from dresslog.model.inputs import network_inputs  # noqa: E402
from dresslog.model.network import ForceMapLSTM  # noqa: E402
from dresslog.model.numpy_lstm import NumpyEstimator  # noqa: E402


def latencies(step, phi: np.ndarray, warmup: int = 200) -> np.ndarray:
    """Per-call wall time in ms (first `warmup` calls dropped)."""
    out = np.empty(len(phi))
    for k, p in enumerate(phi):
        start = time.perf_counter_ns()
        step(p)
        out[k] = time.perf_counter_ns() - start
    return out[warmup:] / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--points", type=int, default=400)
    parser.add_argument("--hidden", type=int, default=50)
    parser.add_argument("--input-differences", action="store_true")
    args = parser.parse_args()

    torch.set_num_threads(1)
    torch.manual_seed(0)
    width = 18 if args.input_differences else 9
    net = ForceMapLSTM(args.points, hidden=args.hidden, input_dim=width).eval()
    est = NumpyEstimator(net.weights())
    phi = np.random.default_rng(0).normal(size=(args.steps, 9)).astype(np.float32)
    x = network_inputs(phi, args.input_differences)

    state = None

    def torch_step(p: np.ndarray) -> None:
        nonlocal state
        with torch.inference_mode():
            out, state = net(torch.from_numpy(p).view(1, 1, width), state)
        out.numpy()

    results = {"numpy": latencies(est.step, phi), "torch": latencies(torch_step, x)}
    print(
        f"one inference step, N={args.points} limb points, {args.hidden} cells, "
        f"{width} inputs, {args.steps} steps, 1 thread"
    )
    for name, ms in results.items():
        p50, p99 = np.percentile(ms, [50, 99])
        print(f"  {name:6s} p50 {p50:.4f} ms  p99 {p99:.4f} ms  mean {ms.mean():.4f} ms")
    ratio50 = np.median(results["torch"]) / np.median(results["numpy"])
    ratio99 = np.percentile(results["torch"], 99) / np.percentile(results["numpy"], 99)
    print(f"  numpy is {ratio50:.1f}x faster at p50, {ratio99:.1f}x at p99")
    target = np.percentile(results["numpy"], 99) <= 0.5
    print(f"  target numpy p99 <= 0.5 ms: {'met' if target else 'MISSED'}")


if __name__ == "__main__":
    main()
