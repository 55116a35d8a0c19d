"""The force-map LSTM: numpy inference, model files, the paper's metrics (no torch here).

Inference, model files and the bundled-model lookup (`bundled`) import no torch
(`dresslog infer` starts fast); the torch network, training and its checkpoint live in
`dresslog.model.network`, `train` and `checkpoint`, imported explicitly by the code that
trains. Each module's docstring lists its API.
"""

from dresslog.model.bundled import bundled_model, resolve_model
from dresslog.model.files import (
    DataProvenance,
    Hyperparameters,
    LoadedModel,
    ModelCard,
    Normalisation,
    check_model_folder,
    check_task,
    load_model,
    read_card,
    save_model,
)
from dresslog.model.numpy_lstm import NumpyEstimator
from dresslog.model.postprocess import (
    apply_contact,
    contact_targets,
    network_targets,
    rmse,
    sequence_rmse,
    zero_baseline_rmse,
)

__all__ = [
    "DataProvenance",
    "Hyperparameters",
    "LoadedModel",
    "ModelCard",
    "Normalisation",
    "NumpyEstimator",
    "apply_contact",
    "bundled_model",
    "check_model_folder",
    "check_task",
    "contact_targets",
    "load_model",
    "network_targets",
    "read_card",
    "resolve_model",
    "rmse",
    "save_model",
    "sequence_rmse",
    "zero_baseline_rmse",
]
