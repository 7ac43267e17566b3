"""Assemble a solver's profiles into the results contract's ``xarray.Dataset``.

Only the variables a model predicts are passed in; nothing is filled with placeholders.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np
import xarray as xr

from .geometry import PlanarShear

# units and long names of every variable a planar solution may carry
VARIABLES: dict[str, tuple[str, str]] = {
    "u_x": ("m s-1", "velocity along the flow direction x"),
    "shear_rate": ("s-1", "shear rate du_x/dz"),
    "nu": ("1", "solid fraction"),
    "p": ("Pa", "pressure, mean normal stress (compressive positive)"),
    "mu": ("1", "stress ratio tau / p"),
    "spin": ("s-1", "mean grain spin about y (Cosserat), same sign as the vorticity du_x/dz / 2"),
    "fluidity": ("s-1", "granular fluidity g = shear_rate / mu (NGF)"),
}


def build_solution(
    model: str,
    geometry: PlanarShear,
    z: np.ndarray,
    fields: Mapping[str, np.ndarray],
    *,
    converged: bool,
    iterations: int,
    residual: float,
    solve_seconds: float,
    n_grid: int,
    parameters: Mapping[str, float],
    extra_attrs: Mapping[str, float | int | str] | None = None,
) -> xr.Dataset:
    """Return the contract's Dataset on coordinate ``z`` (m).

    Args:
        fields: variable name -> values on ``z``; names must be in ``VARIABLES``.
        parameters: parameter values used, under the contract's names (``d``, ``mu_s``, ``l``...).
        extra_attrs: model-specific diagnostics (e.g. ``tau`` in Pa, ``yield_height`` in m).
    """
    z = np.asarray(z, dtype=float)
    data_vars = {}
    for name, values in fields.items():
        if name not in VARIABLES:
            raise KeyError(f"unknown solution variable {name!r}")
        values = np.asarray(values, dtype=float)
        if values.shape != z.shape:
            raise ValueError(f"{name} has shape {values.shape}, z has {z.shape}")
        units, long_name = VARIABLES[name]
        data_vars[name] = ("z", values, {"units": units, "long_name": long_name})
    attrs: dict[str, float | int | str] = {
        "model": model,
        "converged": int(bool(converged)),
        "iterations": int(iterations),
        "residual": float(residual),
        "solve_seconds": float(solve_seconds),
        "n_grid": int(n_grid),
        "d": float(geometry.d),
        "rho_s": float(geometry.rho_s),
        "depth": float(geometry.depth),
        "wall_speed": float(geometry.wall_speed),
        "wall_pressure": float(geometry.wall_pressure),
        "gravity": float(geometry.gravity),
        "normal_stress_ratio": float(geometry.normal_stress_ratio),
    }
    attrs.update({k: float(v) for k, v in parameters.items()})
    if extra_attrs:
        attrs.update(extra_attrs)
    coords = {"z": ("z", z, {"units": "m", "long_name": "height above the bottom wall"})}
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)
