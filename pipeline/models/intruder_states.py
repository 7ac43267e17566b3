"""The nominal intruder solve's converged 2D states, one file per model
(``models/intruder/{model}.states.npz``): the warm starts of its parameter draws and its grid
study (``pipeline.models.intruder_draws``), which run as jobs of their own."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from continuum.intruder import IntruderSpeed
from pipeline.common import atomic

#: Separator of a scene index and a state's key in the states file.
_SEP = "/"


def save_states(results: list[IntruderSpeed | None], path: Path, model: str, cells_per_d: float,
                provenance: dict[str, Any] | None = None) -> None:
    """The nominal solve's converged 2D states (the warm starts of the draws and the grid study),
    one group of arrays per scene in ``scenes_of``'s order; a scene without a speed has none.
    ``provenance`` (the config and software versions) is stored as JSON under ``_provenance``."""
    arrays: dict[str, np.ndarray] = {}
    predicted = []
    for k, result in enumerate(results):
        predicted.append(result is not None)
        if result is not None and result.state is not None:
            arrays.update({f"{k}{_SEP}{name}": np.asarray(v) for name, v in result.state.items()})
            arrays[f"{k}{_SEP}_speed"] = np.array([result.speed])
    arrays["_predicted"] = np.array(predicted, dtype=bool)
    arrays["_cells_per_d"] = np.array([cells_per_d])
    arrays["_model"] = np.array([model])
    arrays["_provenance"] = np.array([json.dumps(provenance or {}, default=str)])
    tmp = atomic.temporary(path)
    with open(tmp, "wb") as handle:  # (np.savez on a path would append .npz to the temporary name)
        np.savez(handle, **arrays)
    tmp.replace(path)


def load_states(path: Path, model: str, n_scenes: int) -> tuple[list[IntruderSpeed | None], float]:
    """``save_states``' file as warm starts (None where the nominal solve gave no speed), and the
    grid they are on (cells per d). Raises ValueError naming the file if it is another model's or
    another scene list's."""
    with np.load(path) as data:
        stored = str(data["_model"][0])
        predicted = data["_predicted"]
        if stored != model or predicted.size != n_scenes:
            raise ValueError(f"{path}: states of {stored} for {predicted.size} scenes, not of {model} for {n_scenes}")
        out: list[IntruderSpeed | None] = []
        for k in range(n_scenes):
            if not predicted[k]:
                out.append(None)
                continue
            state = {key.split(_SEP, 1)[1]: data[key].copy() for key in data.files
                     if key.startswith(f"{k}{_SEP}") and not key.endswith(f"{_SEP}_speed")}
            speed = float(data[f"{k}{_SEP}_speed"][0]) if f"{k}{_SEP}_speed" in data.files else float("nan")
            out.append(IntruderSpeed(model, speed, True, 0, 0.0, 0.0, 0, "2d", state=state or None))
        return out, float(data["_cells_per_d"][0])
