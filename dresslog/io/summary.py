"""What `dresslog info` reports about a trial file, as a pydantic model (prints as JSON)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel

from dresslog.io import well_known as wk
from dresslog.io.files import printable
from dresslog.io.reader import TrialReader
from dresslog.spec import TrialMetadata
from dresslog.trial import median_rate


class ChannelSummary(BaseModel):
    topic: str
    schema_name: str
    count: int


class TrialSummary(BaseModel):
    """A trial at a glance: task, timing, channels, and what it can be used for."""

    path: str
    size_bytes: int
    task: str
    outcome: str
    steps: int
    duration_s: float
    rate_hz: float
    limb_points: int | None
    has_ground_truth: bool
    has_estimate: bool
    channels: list[ChannelSummary]
    metadata: TrialMetadata


def summarize(path: str | Path) -> TrialSummary:
    """Open a trial and describe it; raises `TrialFormatError` for anything not a trial.

    Every stream is decoded and checked, so a file `info` passes is one `infer` runs on;
    none is kept once checked.
    """
    with TrialReader(path) as reader:
        reader.check()
        t_ns = reader.measurements.t_ns
        steps = len(t_ns)
        rate = median_rate(t_ns)
        # each step stands for its interval: 700 steps at 100 Hz are 7 s, not 6.99
        duration = (t_ns[-1] - t_ns[0]) / 1e9 + 1 / rate if steps > 1 else 0.0
        limb = reader.limb_points
        return TrialSummary(
            path=printable(path),
            size_bytes=Path(path).stat().st_size,
            task=reader.metadata.task.value,
            outcome=reader.metadata.outcome.value,
            steps=steps,
            duration_s=round(float(duration), 6),
            rate_hz=round(rate, 3),
            limb_points=len(limb) if limb is not None else None,
            has_ground_truth=reader.has(wk.FORCE_MAP),
            has_estimate=reader.has(wk.ESTIMATE),
            channels=[
                ChannelSummary(topic=c.topic, schema_name=c.schema, count=c.count)
                for c in reader.channels.values()
            ],
            metadata=reader.metadata,
        )


def format_summary(summary: TrialSummary) -> str:
    """The human-readable form printed by `dresslog info`."""
    md = summary.metadata
    lines = [
        f"{summary.path}  ({summary.size_bytes / 1e6:.2f} MB)",
        f"  task      {summary.task}   outcome {summary.outcome}"
        + (f" on the {md.caught_on}" if md.caught_on else "")
        + (f" ({md.failure_reason})" if md.failure_reason else ""),
        f"  steps     {summary.steps} over {summary.duration_s:.2f} s at {summary.rate_hz:g} Hz",
        f"  limb      {summary.limb_points or 'no'} limb points; ground truth "
        f"{'yes' if summary.has_ground_truth else 'no'}; estimate "
        f"{'yes' if summary.has_estimate else 'no'}",
        "  channels",
    ]
    width = max(len(c.topic) for c in summary.channels)
    lines += [f"    {c.topic:<{width}}  {c.count:>6}  {c.schema_name}" for c in summary.channels]
    if md.spec is not None:
        lines.append(f"  spec      {md.spec.describe()}")
    if md.source:
        lines += _source_lines(md.source)
    if md.software:
        lines.append("  software  " + ", ".join(f"{k} {v}" for k, v in md.software.items()))
    return "\n".join(lines)


def _source_lines(source: dict[str, object]) -> list[str]:
    """A converted log's provenance: its file, then each stream with how it was resampled."""

    def part(key: str, kind: type) -> Any:  # what our converter writes, else empty
        value = source.get(key)
        return value if isinstance(value, kind) else kind()

    lines = [f"  source    {source.get('format', '?')} {source.get('file', '?')}"]
    if "motion_file" in source:
        lines[0] += f", motion {source['motion_file']}"
    processing, streams = part("processing", dict), part("streams", dict)
    for kind, stream in streams.items():
        origin = ", ".join(str(stream[k]) for k in ("topic", "file", "clock") if k in stream)
        lines.append(
            f"    {kind:<7} {stream.get('messages', '?')} messages at "
            f"{stream.get('rate_hz', 0):g} Hz ({origin} clock): {processing.get(kind, 'as is')}"
        )
    lines += [  # what was derived rather than recorded, e.g. the twist from the pose
        f"    {kind:<7} {how}"
        for kind, how in processing.items()
        if isinstance(how, str) and kind in ("twist", "pose") and kind not in streams
    ]
    if "window_s" in processing and isinstance(window := processing["window_s"], list):
        lines.append(f"    kept    {window[0]:g}-{window[1]:g} s of the time every stream covers")
    if "tare_s" in processing:
        lines.append(f"    tared   over the first {processing['tare_s']} s")
    if "wrench_frame" in processing:
        lines.append(f"    turned  the wrench {processing['wrench_frame']}")
    if "rotation_xyzw" in processing:
        lines.append(f"    rotated by the quaternion (x y z w) {processing['rotation_xyzw']}")
    if "translation_m" in processing:
        lines.append(f"    moved   the pose by {processing['translation_m']} m")
    lines += [f"    note    {text}" for text in part("notes", list)]
    lines += [f"    warning {text}" for text in part("warnings", list)]
    return lines
