"""`sweep`: the generalisation experiments of Figs. 12 and 13 (`dresslog sweep`)."""

from __future__ import annotations

import contextlib
import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from dresslog.dataset import Split, generate, load_dataset, load_manifest
from dresslog.dataset.executors import LOCAL, Execution, check_executor
from dresslog.dataset.generate import MAX_TRIALS
from dresslog.dataset.manifest import FORMAT as DATASET_FORMAT
from dresslog.dataset.manifest import Manifest, check_files
from dresslog.errors import DatasetError, DresslogWarning, SimulationError, first_problem
from dresslog.experiments.evaluation import (
    check_data_task,
    finite,
    score_rows,
    warn_no_force,
)
from dresslog.experiments.plots import plot_sweep
from dresslog.folders import CARD_FILE, MANIFEST_FILE, SWEEP_FILE
from dresslog.io import jsontext
from dresslog.io.files import (
    atomic_path,
    make_folders,
    named_as_recording,
    remove_folders,
    resolved,
)
from dresslog.limb import build_limb, limb_points
from dresslog.model.conditions import (
    DURATION,
    describe,
    simulator_in,
    trained_conditions,
)
from dresslog.model.evaluate import Scores
from dresslog.model.files import FORMAT as MODEL_FORMAT
from dresslog.model.files import LoadedModel, load_model
from dresslog.spec import SIMULATOR_NAME, Task, TrialSpec, simulator_fields, task_of

#: The kinds of setting, in the order the table lists them.
_KINDS = ("baseline", "speed", "rotation")
#: Mid-range speeds (m/s) the paper used for the rotation sweep (12.5 and 17.5 cm/s).
ROTATION_SPEED = {Task.GOWN: 0.125, Task.SHORTS: 0.175}


@dataclass(frozen=True)
class Setting:
    """One sweep setting: its name, the spec fields it fixes, and its scores."""

    name: str
    kind: str  # "baseline", "speed" or "rotation"
    value: float
    axis: str
    overrides: dict[str, Any]
    scores: Scores | None = None

    @property
    def folder(self) -> str:
        """The setting's folder in the sweep's folder: its name without colons, which some file
        systems refuse."""
        return self.name.replace(":", "_")

    @property
    def order(self) -> tuple[int, str, float]:
        """Where the table lists it: by kind, axis and value, as the plot reads."""
        return _KINDS.index(self.kind), self.axis, self.value


@dataclass(frozen=True)
class SweepReport:
    task: str
    model: str
    n: int
    baseline_rmse: float
    settings: list[Setting]
    #: what the model was trained on (`trained_conditions`): speed spans, m/s, and
    #: rotation spans, (axis, low, high) deg; low == high for one fixed condition
    trained_speeds: list[tuple[float, float]] = field(default_factory=list)
    trained_rotations: list[tuple[str, float, float]] = field(default_factory=list)
    #: whether some training trials had the limb unturned
    trained_unturned: bool = True
    #: the sweep sequences' duration and the training trials' longest, s
    duration: float = DURATION
    trained_duration: float = DURATION

    def ratio(self, setting: Setting) -> float:
        """The setting's RMSE over the in-range setting's: Figs. 12 and 13's y axis (nan when
        the in-range RMSE is 0)."""
        assert setting.scores is not None
        return setting.scores.rmse / self.baseline_rmse if self.baseline_rmse else math.nan

    def trained(self) -> str:
        """What the model was trained on, as the plot shades it: one line under the table."""
        turned = describe(
            self.trained_speeds, self.trained_rotations, unturned=self.trained_unturned
        )
        return f"trained at {turned}{self.longer()}"

    def longer(self) -> str:
        """`, on 7 s trials (these 20 s)` when the sweep's sequences run longer than any
        the model was trained on: every setting's error, the in-range one's too, then
        holds the model's reading of a longer trial."""
        if self.duration <= self.trained_duration:  # shorter: a prefix of a training trial
            return ""
        return f", on {self.trained_duration:g} s trials (these {self.duration:g} s)"

    def table(self) -> str:
        """Per setting: RMSE, all-zero RMSE, their ratio and x in-range. The ratio tells a
        setting that only puts more force on the limb (ratio steady) from one the model
        misreads (ratio up), which x in-range alone cannot."""
        head = (
            f"{'setting':<18}{'n':>5}{'RMSE (N)':>12}{'zero (N)':>12}{'ratio':>8}{'x in-range':>12}"
        )
        lines = [head]
        for s in self.settings:
            assert s.scores is not None
            lines.append(
                f"{s.name:<18}{s.scores.n:>5}{s.scores.rmse:>12.5f}"
                f"{s.scores.zero_rmse:>12.5f}{s.scores.ratio:>8.3f}{self.ratio(s):>12.2f}"
            )
        return "\n".join(lines)


def parse_rotation(text: str) -> tuple[str, float]:
    """'y:-15' -> ('y', -15.0): degrees about an axis, forearm at the elbow, foot at the ankle."""
    axis, sep, degrees = text.partition(":")
    try:
        if not sep or axis not in ("x", "y", "z"):
            raise ValueError
        return axis, float(degrees) + 0.0  # -0 is 0: one setting, one folder
    except ValueError:
        raise DatasetError(f"rotation {text!r} is not AXIS:DEGREES, e.g. y:-15") from None


def parse_speed(text: str | float) -> float:
    """'0.2' -> 0.2 (m/s); a number by its shortest repr, so float32 0.2 is 0.2 too."""
    try:
        return float(str(text))
    except ValueError:
        raise DatasetError(f"speed {text!r} is not a number in m/s, e.g. 0.2") from None


def sweep_settings(
    task: Task | str,
    speeds: Sequence[float | str],
    rotations: Sequence[str],
    duration: float | None = None,
    simulator: str = SIMULATOR_NAME,
) -> list[Setting]:
    """The in-range baseline, then one setting per speed and per rotation.

    Every setting's fields are checked as a spec here, so a bad value stops the sweep
    before its first trial, not after the settings before it. `simulator` is the
    model's (a `SIMULATORS` name): its trials are simulated as its training trials were.
    """
    task = task_of(task, DatasetError)
    for name, values in (("speeds", speeds), ("rotations", rotations)):
        if isinstance(values, str | int | float):  # a str would be swept letter by letter
            raise DatasetError(f"{name} must be a list of values, not the one {values!r}")
    extra: dict[str, Any] = {} if duration is None else {"duration": duration}  # 0 is refused
    extra["sim"] = simulator_fields(simulator)
    settings = [Setting("in-range", "baseline", math.nan, "", dict(extra))]
    for speed in map(parse_speed, speeds):
        fixed = {"speed": speed, **extra}
        settings.append(Setting(f"speed:{speed:.10g}", "speed", speed, "", fixed))
    for text in rotations:
        axis, degrees = parse_rotation(text)
        fields = {
            "speed": ROTATION_SPEED[task],
            "limb_rotation": {"axis": axis, "degrees": degrees},
            **extra,
        }
        settings.append(Setting(f"rot:{axis}:{degrees:.10g}", "rotation", degrees, axis, fields))
    unique: dict[str, Setting] = {}  # a value given twice (0.1 and 0.10) is swept once
    for setting in settings:
        unique.setdefault(setting.name, setting)
    settings = list(unique.values())
    for setting in settings:
        try:
            spec = TrialSpec.model_validate({"task": task, **setting.overrides})
            limb_points(build_limb(task, rotation=spec.limb_rotation))  # folded onto itself?
        except ValidationError as err:
            raise DatasetError(f"{setting.name}: invalid {first_problem(err)}") from None
        except SimulationError as err:  # the same for every seed: not one trial runs
            raise DatasetError(f"{setting.name}: {err}") from None
    return settings


def _check_sweep_folder(out: Path) -> None:
    """Refuse an output named as a recording, a file, a link to nothing, or a dataset or
    model folder (or inside one), where the sweep's setting folders would mix with what is
    there."""
    if (misnamed := named_as_recording(out, "a sweep")) is not None:
        raise DatasetError(misnamed, path=out)
    if out.exists() and not out.is_dir():
        raise DatasetError("is a file; give the sweep a folder of its own", path=out)
    if out.is_symlink() and not out.exists():  # mkdir's "File exists" would mislead
        raise DatasetError("is a symbolic link to nothing; create its folder", path=out)
    where = resolved(out)
    for folder in (where, *where.parents):  # nor anywhere inside one
        what = _dresslog_folder(folder)
        if what is not None:
            place = "is" if folder == where else f"is inside {folder},"
            message = f"{place} {what} folder; give the sweep a folder of its own"
            raise DatasetError(message, path=out)


def _dresslog_folder(folder: Path) -> str | None:
    """ "a dataset" or "a model" if `folder` is one of ours (another tool's manifest.json
    does not count), else None."""
    for name, what, kind in ((MANIFEST_FILE, "a dataset", DATASET_FORMAT),
                             (CARD_FILE, "a model", MODEL_FORMAT)):  # fmt: skip
        try:
            if jsontext.loads((folder / name).read_text(encoding="utf-8")).get("format") == kind:
                return what
        except (OSError, UnicodeDecodeError, ValueError, AttributeError):
            continue
    return None


def default_sweep_folder(model: str | Path) -> Path:
    """`MODEL-sweep` in the current folder: never beside a bundled model, in the package."""
    return Path(f"{Path(model).resolve().name}-sweep")


def sweep(
    model: str | Path,
    out: str | Path,
    *,
    speeds: Sequence[float | str] = (),
    rotations: Sequence[str] = (),
    n: int = 128,
    seed: int = 0,
    duration: float | None = None,
    execution: Execution = LOCAL,
    progress: bool = True,
) -> SweepReport:
    """Re-simulate the same `n` fresh sequences per setting and score the model on each.

    Each setting is a dataset folder under `out` (so an interrupted sweep resumes); the
    sweep seeds are the same in every setting, so settings differ only in what they fix.
    The report also scores the settings earlier runs left complete in `out` (`_earlier`),
    so a sweep extended a value at a time keeps one table of them all.

    Args:
        model: the model folder to score.
        out: the sweep's folder: one dataset folder per setting, and the report.
        speeds: end-effector speeds (m/s) to sweep.
        rotations: limb rotations to sweep, as ``"y:-15"``.
        n: sequences per setting.
        seed: the sweep's seed, from which every sequence's is drawn.
        duration: every sequence's length in s; None: the task's default.
        execution: where and how the trials run, and how many workers decode them.
        progress: show progress bars.

    Returns:
        The report: each setting's scores and ratio to the in-range setting.

    Raises:
        DatasetError: bad settings or `n`, a folder that is not a sweep's, a setting's
            generation that fails.
        ModelError: `model` is no model folder, or one that does not load.
    """
    if not 1 <= n <= MAX_TRIALS:
        raise DatasetError(
            f"a sweep runs 1 to {MAX_TRIALS:,} sequences per setting (-n), not {n:,}"
        )
    loaded = load_model(model)
    task = loaded.card.task
    if not speeds and not rotations:
        raise DatasetError("give at least one --speeds or --rotations value")
    seen = trained_conditions(loaded.card)
    simulator = seen.simulators[-1]  # the newest the model has seen
    settings = sweep_settings(task, speeds, rotations, duration, simulator)  # bad: no folder
    check_executor(execution.executor, execution.ray_address)
    out = Path(out)
    _check_sweep_folder(out)
    longest, length = max(seen.durations), DURATION if duration is None else duration
    if length > longest:  # said before the long simulation
        warnings.warn(
            f"sweep sequences of {length:g} s run longer than the model's training trials "
            f"({longest:g} s), so every setting's error, the in-range one's too, measures "
            "how it reads the longer trial as well",
            DresslogWarning,
            stacklevel=2,
        )
    made = make_folders(out / SWEEP_FILE)
    done: list[Setting] = []
    for setting in settings:
        try:
            generate(
                task,
                n,
                out / setting.folder,
                splits={Split.SWEEP: n},
                overrides=setting.overrides,
                seed=seed,
                execution=execution,
                progress=progress,
                label=f"{task.value} {setting.name}",
            )
        except BaseException:
            remove_folders(made)  # a sweep folder this run made, if it is still empty
            raise
        done.append(_scored(loaded, out, setting, execution.workers))
    done += _earlier(loaded, out, settings, n, seed, execution.workers)
    done.sort(key=lambda s: s.order)
    baseline = done[0].scores
    assert baseline is not None
    report = SweepReport(
        task.value, str(model), n, baseline.rmse, done,
        list(seen.speeds), list(seen.rotations), seen.unturned,
        length, longest,
    )  # fmt: skip
    if empty := [s.name for s in done if s.scores is not None and s.scores.zero_rmse == 0]:
        in_range = ", as is x in-range, the in-range RMSE being 0 too" if baseline.rmse == 0 else ""
        warn_no_force(
            out,
            f"sweep sequence of {', '.join(empty)}",
            f"the all-zero RMSE is 0 and the ratio to it is not a number (nan){in_range}",
            "sweep longer sequences (--duration)",
        )
    _write_sweep(out, report)
    return report


def _scored(loaded: LoadedModel, out: Path, setting: Setting, workers: int | None) -> Setting:
    """`setting` with the model's scores on its folder's sequences."""
    arrays = load_dataset(out / setting.folder, workers=workers, progress=False)
    check_data_task(loaded, arrays.task, arrays.n_points)
    scores = score_rows(loaded, arrays, arrays.rows(Split.SWEEP))
    return Setting(**{**asdict(setting), "scores": scores})


def _earlier(
    loaded: LoadedModel, out: Path, asked: list[Setting], n: int, seed: int, workers: int | None
) -> list[Setting]:
    """The settings earlier sweeps left in `out` that compare with the `asked` ones, scored:
    complete and whole, of the same `n` sequences, seed and fixed fields (the duration).

    The others are named in one warning with why, as the table leaves them out: an earlier
    folder is this run's context, not its subject, so its damage must not stop the sweep.
    """
    task = loaded.card.task
    other: list[str] = []  # another -n, seed or duration, or unfinished
    damaged: list[str] = []  # a trial missing, resized or not matching its checksum
    fits: list[Setting] = []
    for setting, manifest in _found(out, task, asked):
        if (manifest.task, manifest.seed, manifest.overrides, manifest.n_sweep) != (
            task, seed, setting.overrides, n
        ) or not manifest.complete:  # fmt: skip
            other.append(f"{setting.name} ({manifest.counts() or 'no trials'})")
            continue
        try:
            check_files(out / setting.folder, manifest)  # missing or resized
            fits.append(_scored(loaded, out, setting, workers))  # checksums, as it decodes
        except DatasetError:  # its own cure, `generate`, refuses a sweep's folder
            option = "--speeds" if setting.kind == "speed" else "--rotations"
            again = f"{option} {setting.name.partition(':')[2]}"
            damaged.append(
                f"{setting.name} (a trial is damaged or missing; sweep it again with {again})"
            )
    reasons = []
    if other:
        reasons.append(
            f"as not {n} complete sequence{'s' * (n != 1)} of this sweep's seed and fields: "
            f"{', '.join(other)}; sweep them again with these options to add them"
        )
    if damaged:
        reasons.append(f"as damaged: {', '.join(damaged)}")
    if reasons:
        message = f"{out}: left out of the table, {'; and '.join(reasons)}"
        warnings.warn(message, DresslogWarning, stacklevel=3)
    return fits


def _found(out: Path, task: Task, asked: list[Setting]) -> list[tuple[Setting, Manifest]]:
    """The sweep setting folders in `out` besides the `asked` ones, with their manifests."""
    names, duration = {s.folder for s in asked}, asked[0].overrides.get("duration")
    simulator = simulator_in(asked[0].overrides)
    found: list[tuple[Setting, Manifest]] = []
    for folder in (f for f in out.iterdir() if f.is_dir() and f.name not in names):
        kind, _, value = folder.name.partition("_")
        if kind not in ("speed", "rot"):
            continue
        value = value.replace("_", ":", 1) if kind == "rot" else value
        try:  # not a setting's name, or not a dataset: not the sweep's
            (setting,) = sweep_settings(
                task, [value] * (kind == "speed"), [value] * (kind == "rot"), duration, simulator
            )[1:]
            manifest = load_manifest(folder)
        except DatasetError:
            continue
        if setting.folder == folder.name:  # not `speed_0.20`: a name the sweep never gives
            found.append((setting, manifest))
    found.sort(key=lambda f: f[0].order)  # the warning names them in the table's order
    return found


def _write_sweep(out: Path, report: SweepReport) -> None:
    # ratio (to all-zero) before ratio_to_in_range: the last column stays where it was
    rows = ["setting,kind,axis,value,n,rmse,zero_rmse,ratio,ratio_to_in_range"]
    for s in report.settings:
        assert s.scores is not None
        value = "" if math.isnan(s.value) else f"{s.value:.10g}"
        rows.append(
            f"{s.name},{s.kind},{s.axis},{value},{s.scores.n},{s.scores.rmse:.6g},"
            f"{s.scores.zero_rmse:.6g},{s.scores.ratio:.4g},{report.ratio(s):.4g}"
        )
    summary_json = asdict(report)  # ratio to all-zero under scores; to in-range added here
    for row, s in zip(summary_json["settings"], report.settings, strict=True):
        row["ratio_to_in_range"] = report.ratio(s)
    # all three written in full before any is put in place: a stopped or failing run
    # leaves the last sweep's table and plot together, never one beside the other's
    with contextlib.ExitStack() as stack:
        table, summary, plot = (
            stack.enter_context(atomic_path(out / name))
            for name in ("sweep.csv", SWEEP_FILE, "sweep.png")
        )
        table.write_text("\n".join(rows) + "\n")
        summary.write_text(json.dumps(finite(summary_json), indent=2) + "\n")
        plot_sweep(plot, report)
