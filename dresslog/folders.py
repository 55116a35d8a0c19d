"""The file names that mark dresslog's folders: a dataset, a model, a sweep.

Named in one low module so that the code of each kind of folder can recognise the others
(`eval DATA MODEL` given the two swapped, `train` given a model) without importing the
other's code: `dresslog.dataset.manifest` and `dresslog.model.files` both read these.
"""

from __future__ import annotations

from typing import Final

#: A dataset folder's index (`dresslog.dataset.manifest`).
MANIFEST_FILE: Final = "manifest.json"
#: The file that marks a sweep's folder (`dresslog sweep` writes it beside its table and
#: plot), so a dataset's checks can recognise one too.
SWEEP_FILE: Final = "sweep.json"
#: A model folder's weights and card (`dresslog.model.files`).
WEIGHTS_FILE: Final = "model.safetensors"
CARD_FILE: Final = "card.json"
#: The learning curve `dresslog train` draws beside a model's files.
TRAINING_PLOT: Final = "training.png"
#: What a model folder holds; `train --overwrite` replaces these and nothing else.
MODEL_FILES: Final = frozenset({WEIGHTS_FILE, CARD_FILE, TRAINING_PLOT})
