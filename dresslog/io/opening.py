"""A trial's metadata and channels as `TrialReader` checks them on opening: the
`dresslog` record (or its latched copy on `/dresslog/metadata`, which generic tools keep
where they drop records) and our channels under our schemas."""

from __future__ import annotations

from pydantic import ValidationError

from dresslog.errors import TrialFormatError, first_problem
from dresslog.io import cdr, jsontext
from dresslog.io import well_known as wk
from dresslog.io.checks import CONVERT_HINT
from dresslog.io.source import McapSource
from dresslog.spec import RECORDED, TRIAL_FORMAT_VERSION, TrialMetadata


def has_metadata_channel(source: McapSource) -> bool:
    """Whether the file holds the latched copy of its metadata record."""
    info = source.channels.get(wk.METADATA_TOPIC)
    return info is not None and info.count > 0


def check_channels(source: McapSource, has_metadata: bool) -> None:
    """Refuse a file without our required channels, or with ours under another schema."""
    channels = source.channels
    if not any(info.count for t, info in channels.items() if t != wk.METADATA_TOPIC):
        empty = ", ".join(sorted(channels))
        what = f" (its channels {empty} are empty)" if empty else ""
        if not has_metadata:
            raise TrialFormatError(
                f"holds no messages{what} and no `{wk.METADATA_NAME}` metadata record: "
                f"an empty MCAP file, not a trial; {CONVERT_HINT}",
                path=source.path,
            )
        raise TrialFormatError(
            f"holds no messages{what}: a trial with no step; re-record it", path=source.path
        )
    missing = [t for t in wk.REQUIRED if t not in channels]
    if missing and (not has_metadata or not any(t in channels for t in wk.SCHEMAS)):
        topics = ", ".join(sorted(channels)) or "none"
        raise TrialFormatError(
            f"not a dresslog trial (channels: {topics}); {CONVERT_HINT}", path=source.path
        )
    if missing:
        raise TrialFormatError(
            f"missing channel {missing[0]}; the model needs end-effector wrench and twist",
            path=source.path,
        )
    for topic, info in channels.items():
        expected = wk.SCHEMAS.get(topic) or wk.UNSTAMPED.get(topic)
        if expected and (info.schema, info.encoding) != (expected, wk.MESSAGE_ENCODING):
            raise TrialFormatError(
                f"has schema {info.schema or 'none'} ({info.encoding}), expected {expected} (cdr)",
                path=source.path,
                channel=topic,
            )


def _metadata_from_channel(source: McapSource) -> dict[str, str] | None:
    """The metadata a generic tool kept: the last message of the latched channel
    `/dresslog/metadata` (a std_msgs/msg/String of the record's JSON), for a file whose
    record a conversion (to a ROS 1 bag and back) dropped."""
    if not has_metadata_channel(source):
        return None
    last = b""
    for _, _, data in source.messages([wk.METADATA_TOPIC]):
        last = data
    try:
        text = cdr.decode(wk.UNSTAMPED[wk.METADATA_TOPIC], [last])[0][0]["data"]
        record = jsontext.loads(text.decode())
    except (cdr.MessageError, ValueError, KeyError) as err:
        raise TrialFormatError(
            f"message does not hold the trial's metadata: {err}",
            path=source.path,
            channel=wk.METADATA_TOPIC,
        ) from None
    if not isinstance(record, dict) or not all(isinstance(v, str) for v in record.values()):
        raise TrialFormatError(
            "message is not the JSON of the metadata record (names and texts)",
            path=source.path,
            channel=wk.METADATA_TOPIC,
        )
    return record


def trial_metadata(source: McapSource) -> TrialMetadata:
    """The trial's metadata from the `dresslog` record (or, where a generic tool dropped
    it, from its latched channel), or why it cannot be read."""
    metadata = source.metadata.get(wk.METADATA_NAME)
    if metadata is None:
        metadata = _metadata_from_channel(source)
    if metadata is None:
        raise TrialFormatError(
            f"has no `{wk.METADATA_NAME}` metadata record; {CONVERT_HINT}", path=source.path
        )
    if "trial" not in metadata:
        raise TrialFormatError(
            f"`{wk.METADATA_NAME}` metadata record has no `trial` entry", path=source.path
        )
    try:
        entry = jsontext.loads(metadata["trial"])
        version = entry.get("format_version") if isinstance(entry, dict) else None
        if isinstance(version, int) and version > TRIAL_FORMAT_VERSION:
            raise TrialFormatError(
                f"written by a newer dresslog (trial format {version}; this one reads "
                f"{TRIAL_FORMAT_VERSION}); upgrade dresslog",
                path=source.path,
            )
        return TrialMetadata.model_validate(entry, context=RECORDED)
    except ValidationError as err:
        problem = first_problem(err, "metadata")
        message = f"metadata record is invalid: {problem}"
        raise TrialFormatError(message, path=source.path) from None
    except ValueError as err:  # not JSON, NaN, nested past reading
        first = str(err).splitlines()[0]
        raise TrialFormatError(f"metadata record is invalid: {first}", path=source.path) from None
