"""How well could any estimator do on a dataset? Oracle bounds on the paper's RMSE ratio.

A plot over `dresslog.model.bounds` (also `dresslog eval MODEL DATA --bounds`).
The paper scores force maps by RMSE over every step and limb point against the
all-zero estimate. How low that ratio can go depends on the data as much as on
the model: a force map made of a few sharp peaks is only matched by an estimate
that puts the force on the right 2 cm of limb. This script scores estimators
that are handed part of the truth, on a dataset's test split:

- misplaced truth: the exact force map blurred along the limb by a Gaussian of
  sigma cm (an estimate that knows every force but places it to within sigma);
- exact total force per step spread by the training split's mean profile at that
  step, or by the sequence's own time-averaged profile;
- unpredictable flicker: the truth against its own 3-step moving average.

    python scripts/learnability.py data/gown data/shorts \
        [--model gown=M ...] [-o docs/learnability.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

#: The paper's ratios (Sec. V-B), the issue's first bar.
PAPER_RATIO = {"gown": 0.45, "shorts": 0.48}


def ratios_for(data: Path, models: dict[str, str]) -> tuple[str, dict[str, float], float | None]:
    """Task, {oracle name: ratio} on `data`'s test split, and its task's model's ratio there."""
    from dresslog.dataset import load_manifest
    from dresslog.experiments import dataset_bounds, evaluate_dataset

    task = load_manifest(data).task.value
    model = models.get(task)
    if model is None:
        return task, dataset_bounds(data), None
    report = evaluate_dataset(model, data, bounds=True, progress=False)  # one dataset load
    return task, report.bounds, report.overall.ratio


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="+", type=Path)
    parser.add_argument("--model", action="append", default=[], help="TASK=MODEL_FOLDER")
    parser.add_argument("-o", "--out", type=Path, default=Path("docs/learnability.png"))
    args = parser.parse_args()
    pairs = [m.split("=", 1) for m in args.model]
    models = {p[0]: p[1] for p in pairs if len(p) == 2}
    if len(models) < len(pairs) or not set(models) <= set(PAPER_RATIO) or not all(models.values()):
        parser.error(f"--model takes TASK=MODEL_FOLDER, TASK one of {', '.join(PAPER_RATIO)}")

    import matplotlib

    from dresslog.model.bounds import SIGMAS_CM

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    unused = dict(models)
    for data in args.data:
        task, ratios, model_ratio = ratios_for(data, models)
        unused.pop(task, None)
        if not ratios:
            print(f"{data}: no force anywhere in the test split, nothing to bound")
            continue
        for name, value in ratios.items():
            print(f"{task:7s} {name:22s} {value:.3f}")
        line = ax.plot(SIGMAS_CM, [ratios[f"blur {s:g} cm"] for s in SIGMAS_CM], "o-",
                       label=f"{task}: exact forces misplaced by sigma")  # fmt: skip
        colour = line[0].get_color()
        ax.axhline(PAPER_RATIO[task], color=colour, ls=":", label=f"{task}: paper's LSTM")
        if model_ratio is not None:
            print(f"{task:7s} {'model ' + models[task]:22s} {model_ratio:.3f}")
            ax.axhline(model_ratio, color=colour, ls="--", label=f"{task}: our LSTM")
    for task, model in unused.items():
        print(f"--model {task}={model} not scored: no {task} dataset was given")
    ax.set_xlabel("sigma of the misplacement along the limb (cm)")
    ax.set_ylabel("RMSE / all-zero RMSE")
    ax.set_ylim(0, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title("How precisely must an estimate place the force?")
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
