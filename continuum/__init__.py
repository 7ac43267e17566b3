"""Continuum granular rheologies solved on planar shear cells.

``continuum`` knows nothing of DEM, dumps or files: solvers take a ``PlanarShear`` geometry and a
parameter dataclass and return an ``xarray.Dataset`` in the results contract's form.

Entry point::

    continuum.solve("ngf", geometry, NGFParameters(...), n_grid=200)

Model names and parameter types: ``local_mu_i`` (LocalMuIParameters), ``critical_state``
(CriticalStateParameters), ``cosserat`` (CosseratParameters), ``ngf`` (NGFParameters),
``volume_averaged`` (VolumeAveragedParameters). Extra keyword arguments go to the model's solver
(``nu_initial`` for the rate-independent models, ``case`` for error messages).
"""
from __future__ import annotations

from typing import Any, Callable

import xarray as xr

from . import cosserat, critical_state, local_mu_i, ngf, volume_averaged
from .errors import ContinuumError, ConvergenceError, OutOfRangeError
from .geometry import PlanarShear
from .parameters import (
    CosseratParameters,
    CriticalStateLine,
    CriticalStateParameters,
    LocalMuIParameters,
    MuIParameters,
    NGFParameters,
    SolidFractionLaw,
    VolumeAveragedParameters,
)

SOLVERS: dict[str, tuple[Callable[..., xr.Dataset], type]] = {
    "local_mu_i": (local_mu_i.solve, LocalMuIParameters),
    "critical_state": (critical_state.solve, CriticalStateParameters),
    "cosserat": (cosserat.solve, CosseratParameters),
    "ngf": (ngf.solve, NGFParameters),
    "volume_averaged": (volume_averaged.solve, VolumeAveragedParameters),
}
MODEL_NAMES: tuple[str, ...] = tuple(SOLVERS)


def solve(model_name: str, geometry: PlanarShear, params: Any, n_grid: int = 200, **options: Any) -> xr.Dataset:
    """Solve one model on a planar geometry (see the module docstring for names and types)."""
    try:
        solver, param_type = SOLVERS[model_name]
    except KeyError:
        raise KeyError(f"unknown model {model_name!r}; known: {', '.join(MODEL_NAMES)}") from None
    if not isinstance(params, param_type):
        raise TypeError(f"{model_name} needs {param_type.__name__}, got {type(params).__name__}")
    return solver(geometry, params, n_grid=n_grid, **options)


__all__ = [
    "solve", "SOLVERS", "MODEL_NAMES", "PlanarShear",
    "ContinuumError", "ConvergenceError", "OutOfRangeError",
    "MuIParameters", "SolidFractionLaw", "LocalMuIParameters", "NGFParameters", "CriticalStateLine",
    "CriticalStateParameters", "VolumeAveragedParameters", "CosseratParameters",
]
