"""`ConvertOptions`: everything `convert` takes besides the log and the output, checked once.

The command builds one from its options and passes it whole; a Python caller may too, or
give the options as keywords (`convert(log, out, "gown", tare_s=0.5)`), which
`ConvertOptions.build` sorts into the signal's part (`SignalOptions`, shared with `live`)
and the log's own (topics, CSV columns, clock, window).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, model_validator

from dresslog.convert import resample as rs
from dresslog.convert.signal import OptionError, SignalOptions, finite
from dresslog.errors import ConversionError
from dresslog.io.files import printable
from dresslog.spec import MAX_DURATION, Task, task_of


def window_mistake(start_s: float, end_s: float) -> str | None:
    """What is wrong with a window from `start_s` to `end_s` (finite, 0 or more) before the
    log is read: not in order, shorter than two steps or longer than a trial may last."""
    if start_s >= end_s:
        return f"--start {start_s:g} s is not before --end {end_s:g} s; give a start before the end"
    if end_s - start_s < 2 / rs.RATE_HZ:
        return (
            f"--start {start_s:g} s to --end {end_s:g} s holds less than two 100 Hz steps; give "
            f"a window of {2 / rs.RATE_HZ:g} s or more"
        )
    if end_s - start_s > MAX_DURATION:
        return (
            f"--start {start_s:g} s to --end {end_s:g} s is more than the {MAX_DURATION:g} s a "
            "trial may last; give an hour or less"
        )
    return None


def _refuse(given: dict[str, Any]) -> None:
    """`convert`'s own checks of the options as given, before pydantic coerces them."""
    given["task"] = task_of(given.get("task"), ConversionError)  # type: ignore[arg-type]
    if given.get("pose_tf") is not None and given.get("pose_topic") is not None:
        raise OptionError("--pose-tf and --pose-topic both give the pose: use one")
    start_s, end_s = given.get("start_s", 0.0), given.get("end_s")
    for option, value in (("--start", start_s), ("--end", end_s)):
        if value is not None and not (finite(value, None) and value >= 0):
            raise ConversionError(f"{option} {value} s: give a time of 0 s or more")
    if end_s is not None and (message := window_mistake(start_s, end_s)):
        raise OptionError(message)
    if (clock := given.get("clock", "header")) not in ("header", "log"):
        raise ConversionError(f"clock {clock!r}: use header or log")


class ConvertOptions(BaseModel):
    """`convert`'s options: the task, which streams of the log to read and how, the
    signal's frame (`signal`) and the window of the log to keep.

    `pose_tf` ("PARENT:CHILD", e.g. "base_link:tool0") takes a bag's pose from its /tf
    and /tf_static, CHILD's in PARENT, where no PoseStamped topic holds it; `motion`,
    `columns` and `time_unit` are a CSV's. `start_s` and `end_s` (s from the first step of
    the time every stream covers; `end_s` None: to its end) keep the steps from one up to
    the other, e.g. one trial of a long session: the duration cap, the tare and the checks
    apply to them, and the output's times start at 0 at `start_s`.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    task: Task
    wrench_topic: str | None = None
    twist_topic: str | None = None
    pose_topic: str | None = None
    pose_tf: str | None = None
    motion: Path | None = None
    columns: dict[str, str] | None = None
    time_unit: str | None = None
    clock: Literal["header", "log"] = "header"
    signal: SignalOptions = SignalOptions()
    start_s: float = 0.0
    end_s: float | None = None
    overwrite: bool = False

    @model_validator(mode="before")
    @classmethod
    def _checked(cls, data: Any) -> Any:
        if isinstance(data, dict):
            data = dict(data)
            _refuse(data)
        return data

    @classmethod
    def build(cls, task: Task | str, **options: Any) -> ConvertOptions:
        """The options from flat keywords, as `convert` and the command take them: the
        signal's (`SignalOptions`' fields) go into `signal`."""
        signal = SignalOptions.take(options)
        return cls.model_validate(dict(options, task=task, signal=signal))

    @property
    def windowed(self) -> bool:
        """Whether a window of the log is kept, not all of it."""
        return self.start_s > 0 or self.end_s is not None

    def check_names(self, path: Path) -> None:
        """The log's and the motion file's names go into the trial's notes, JSON: UTF-8 only."""
        for given in (path, self.motion):
            if given is not None and printable(Path(given).name) != Path(given).name:
                raise ConversionError(
                    "its name is not UTF-8, which the trial's metadata must be; rename it",
                    path=printable(given),
                )
