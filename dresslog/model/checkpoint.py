"""The training checkpoint: what an interrupted `train` resumes from.

One safetensors file beside the model folder, written after every epoch: the network's,
the optimiser's and the best epoch's tensors, and as JSON metadata the run's key
(settings, shape, a fingerprint of the data), its epochs so far and the optimiser's
groups. Nothing in it is unpickled; a checkpoint of another run is refused, not mixed in.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from dresslog.errors import ModelError
from dresslog.io.files import atomic_path
from dresslog.model.files import EpochRecord
from dresslog.model.network import ForceMapLSTM

if TYPE_CHECKING:
    from dresslog.model.train import TrainHistory


def run_key(
    net: ForceMapLSTM, history: TrainHistory, normalise: bool, data: str, init: str | None = None
) -> dict[str, Any]:
    """What a checkpoint must share with the run that resumes it: settings, shape, data,
    and the fingerprint of the weights it started from, if not random ones (a key without
    it is a run from random weights, as before fine-tuning existed)."""
    key = {
        "settings": history.settings.model_dump(),
        "arch": [net.n_points, net.hidden, net.layers],
        "normalise": normalise,
        "data": data,
    }
    return key if init is None else {**key, "init": init}


def fingerprint(*arrays: Sequence[np.ndarray]) -> str:
    """A hash of every sequence's values, in order: another dataset gives another one."""
    digest = hashlib.blake2b(digest_size=16)
    for group in arrays:
        for a in group:
            digest.update(np.ascontiguousarray(a).tobytes())
    return digest.hexdigest()


#: What a checkpoint's metadata says it is; another value is not read.
CHECKPOINT_FORMAT = "dresslog-checkpoint/1"


@dataclass
class RunState:
    """A run in progress, as its checkpoint keeps it: network, optimiser, the epochs so
    far, the kept epoch's weights (with keep_best) and the key a resuming run must share."""

    net: ForceMapLSTM
    optim: torch.optim.Optimizer
    history: TrainHistory
    key: dict[str, Any]
    best: dict[str, torch.Tensor] = field(default_factory=dict)


def save_checkpoint(path: Path, run: RunState) -> None:
    """Tensors in safetensors, everything else as JSON in its metadata: nothing to unpickle."""
    from safetensors.torch import save_file

    optim_state = run.optim.state_dict()
    tensors = {f"model.{k}": v for k, v in run.net.state_dict().items()}
    tensors |= {f"best.{k}": v for k, v in run.best.items()}
    for index, slots in optim_state["state"].items():
        tensors |= {f"optim.{index}.{name}": v for name, v in slots.items()}
    metadata = {
        "format": CHECKPOINT_FORMAT,
        "key": json.dumps(run.key),
        "epochs": json.dumps([e.model_dump() for e in run.history.epochs]),
        "param_groups": json.dumps(optim_state["param_groups"]),
    }
    from safetensors import SafetensorError

    with atomic_path(path) as tmp:
        try:
            save_file({k: v.detach().cpu().contiguous() for k, v in tensors.items()}, tmp, metadata)
        except SafetensorError as err:  # its I/O errors (a full disk) are not OSErrors
            raise ModelError(f"cannot write the checkpoint: {err}", path=path) from None


def _read_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
    """The metadata (decoded) and tensors of a checkpoint `save_checkpoint` wrote."""
    from safetensors import safe_open

    with safe_open(str(path), framework="pt") as stream:
        metadata = stream.metadata() or {}
        tensors = {name: stream.get_tensor(name) for name in stream.keys()}  # noqa: SIM118
    if metadata.get("format") != CHECKPOINT_FORMAT:
        raise ValueError("not a dresslog checkpoint")
    return {k: json.loads(metadata[k]) for k in ("key", "epochs", "param_groups")}, tensors


def resume(path: Path, run: RunState) -> None:
    """Continue from a checkpoint of the same settings and data; refuse one from another run."""
    unreadable = "is not a checkpoint dresslog can read; pass --overwrite to start afresh"
    try:
        metadata, tensors = _read_checkpoint(path)
    except Exception:  # safetensors' and json's reasons help no one here
        raise ModelError(unreadable, path=path) from None
    poisoned = sorted(
        name
        for name, value in tensors.items()
        if name.startswith(("model.", "best.")) and not torch.isfinite(value).all()
    )
    if poisoned:  # a damaged file: the run would go on from weights that estimate NaN
        raise ModelError(
            f"checkpoint's {poisoned[0]} holds NaN or infinite values; it is corrupt: pass "
            "--overwrite to start afresh",
            path=path,
        )
    saved, key = metadata["key"], json.loads(json.dumps(run.key))  # compared as stored
    if not isinstance(saved, dict):
        raise ModelError(unreadable, path=path)
    # an option first: the data's fingerprint is of what the network reads, which some
    # options change on the same dataset (--input-differences, --balance-loss; --seed
    # draws the sequences that validate)
    difference = _difference(saved, key)
    if not difference and saved.get("data") not in (None, key["data"]):
        raise ModelError(
            "checkpoint is from a run on other data (the dataset changed since): pass "
            "--overwrite to start afresh",
            path=path,
        )
    if saved != key:
        raise ModelError(
            f"checkpoint is from a run with other settings{difference}: repeat "
            "that run's options to resume it, or pass --overwrite to start afresh",
            path=path,
        )
    slots: dict[int, dict[str, torch.Tensor]] = {}
    for name, value in tensors.items():
        if name.startswith("optim."):
            index, slot = name.removeprefix("optim.").split(".", 1)
            slots.setdefault(int(index), {})[slot] = value
    try:
        run.net.load_state_dict(_under(tensors, "model."))
        run.optim.load_state_dict({"state": slots, "param_groups": metadata["param_groups"]})
        run.best.update(_under(tensors, "best."))
        run.history.epochs = [EpochRecord.model_validate(e) for e in metadata["epochs"]]
    except (KeyError, TypeError, ValueError, RuntimeError):  # a layout not our own
        raise ModelError(unreadable, path=path) from None


def _options(key: dict[str, Any]) -> dict[str, Any]:
    """A run key's settings by the `train` options that set them (its limb points are
    the data's)."""
    settings = dict(key.get("settings") or {})
    balance_loss = settings.pop("force_scale", 1.0) != 1.0
    arch = dict(zip(("hidden", "layers"), (key.get("arch") or [])[1:], strict=False))
    options = {**settings, "balance_loss": balance_loss, **arch, "normalise": key.get("normalise")}
    return {**options, "init": key.get("init")}


def _difference(saved: dict[str, Any], key: dict[str, Any]) -> str:
    """` (it had --epochs 40, this run --epochs 30)`: the first option two run keys differ
    in, so the interrupted run's can be repeated ("" if none is found)."""
    old, new = _options(saved), _options(key)

    def shown(name: str, value: Any) -> str:
        option = f"--{name.replace('_', '-')}"
        if value is None or value is False:
            return f"no {option}"
        if name == "init":  # a fingerprint of the weights: a model's path is not kept
            return f"{option} of weights {value[:8]}"
        return option if value is True else f"{option} {value}"

    for name in new:
        if old.get(name) != new[name]:
            return f" (it had {shown(name, old.get(name))}, this run {shown(name, new[name])})"
    return ""


def _under(tensors: dict[str, torch.Tensor], prefix: str) -> dict[str, torch.Tensor]:
    return {k.removeprefix(prefix): v for k, v in tensors.items() if k.startswith(prefix)}
