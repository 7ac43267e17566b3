"""CF-1.10 metadata on every NetCDF file the workflow writes (what xarray, cf_xarray and ParaView key on).

- global ``Conventions``, ``title``, ``history`` (when and by what command), ``source`` (the
  package and LIGGGHTS versions);
- ``axis`` and ``positive`` on the coordinates (z up, x along the flow, depth below the top wall down);
- ``ancillary_variables`` tying each variable to its ``<name>_err`` standard error, whose
  ``standard_error`` role is named in ``long_name``;
- ``cell_methods = "time: mean"`` on the time-averaged fields of a fields file;
- units of numeric global attributes as ``<name>_units`` attributes, from :data:`ATTRIBUTE_UNITS`
  (names ending in ``_over_d``, ``_over_p``, ``_ratio`` and the like are dimensionless, "1").

No CF standard name fits these granular fields (the table has no generic solid fraction,
granular temperature or stress of a granular medium), so none is given rather than a wrong one.
"""
from __future__ import annotations

import datetime as _dt
import shlex
import sys

import numpy as np
import xarray as xr

from pipeline.common.provenance import software_versions

CONVENTIONS = "CF-1.10"
COORDINATES = {
    "z": {"axis": "Z", "positive": "up"},
    "x": {"axis": "X"},
    "depth_over_d": {"axis": "Z", "positive": "down"},
}
#: Units of the numeric global attributes the stages write (SI).
ATTRIBUTE_UNITS = {
    "width": "m", "kernel_cutoff": "m", "d": "m", "rho_s": "kg m-3", "time_window": "s", "time_step": "s",
    "steady_state_window": "s", "wall_pressure": "Pa", "gravity": "m s-2", "wall_speed": "m s-1", "cell": "m",
    "z_bottom_wall": "m", "z_top_wall": "m", "z_bottom_contact_plane": "m", "z_top_contact_plane": "m",
    "depth": "m", "tau": "Pa", "solve_seconds": "s", "residual": "1", "iterations": "1", "n_grid": "1",
    "converged": "1", "number_of_snapshots": "1", "error_blocks": "1", "timestep_first": "1", "timestep_last": "1",
    "l": "m", "mu_s": "1", "mu_2": "1", "I_0": "1", "A": "1", "sin_phi": "1", "nu_c": "1", "a": "1",
    "yield_height": "m", "contacts_included": "1", "format_version": "1", "I_max_solution": "1",
    "I_max_calibrated": "1", "nu_structure_alpha": "1", "u_x_disp_structure_alpha": "1", "outside_calibrated_range": "1", "normal_stress_ratio": "1", "cells_per_d": "1",
    "wall_friction": "1", "wall_friction_err": "1", "half_window_split_time": "s", "half_window_blocks": "1", "n_grid_refined": "1", "n_draws": "1",
    "n_solved": "1", "draws_seed": "1", "cells_per_d_refined": "1",
    "slip_length": "m", "top_wall_slip": "m s-1", "wall_layer_over_d": "1", "wall_layer_offset_over_d": "1",
}
_DIMENSIONLESS_SUFFIXES = ("_over_d", "_over_p", "_over_err", "_ratio", "_residual", "_rel", "_chi2", "_fraction",
                           "_count", "_points")


#: Units of the bulk means ``bulk_<field>`` (and ``bulk_<field>_err``) of the fields files.
BULK_UNITS = {"nu": "1", "p": "Pa", "mu": "1", "I": "1", "shear_rate": "s-1", "fluidity": "s-1",
              "granular_temperature": "m2 s-2", "margin_over_d": "1"}


#: Units of the wall's attributes ``wall_<top|bottom>_<quantity>`` (and ``_err``) of the fields files
#: (pipeline/coarse_graining/wall.py).
WALL_UNITS = {"slip": "m s-1", "first_layer_slip": "m s-1", "shear_rate": "s-1", "slip_length": "m",
              "effective_plane": "m", "shear_stress": "Pa", "normal_stress": "Pa"}


def attribute_units(name: str) -> str | None:
    """Units of a numeric global attribute, or None where none is known."""
    if name in ATTRIBUTE_UNITS:
        return ATTRIBUTE_UNITS[name]
    for side in ("wall_top_", "wall_bottom_"):
        if name.startswith(side) and name[len(side):].removesuffix("_err") in WALL_UNITS:
            return WALL_UNITS[name[len(side):].removesuffix("_err")]
    if name.startswith("bulk_"):
        field = name[5:].removesuffix("_err")
        if field in BULK_UNITS:
            return BULK_UNITS[field]
    base = name[6:] if name.startswith("check_") else name
    base = base[8:] if base.startswith("balance_") else base
    if base in ATTRIBUTE_UNITS:
        return ATTRIBUTE_UNITS[base]
    if base.endswith(_DIMENSIONLESS_SUFFIXES) or "residual" in base or base.startswith("identity_"):
        return "1"  # identity_*: largest mismatch over |sigma_zz|
    if "sigma_" in base or base.endswith("_over_area"):
        return "Pa"
    if base.startswith(("z_", "bulk_z")) or base.endswith("_z") or base.endswith(("_z_lo", "_z_hi", "_check")):
        return "m"
    if base.startswith(("slope_zz", "slope_xz")):  # stress gradients and their errors
        return "Pa m-1"
    if base in ("p_bulk",) or base.endswith("_expected"):
        return "Pa"
    return None


def apply(ds: xr.Dataset, title: str | None = None) -> xr.Dataset:
    """The dataset with the CF metadata above added (the input is not changed)."""
    out = ds.copy()
    versions = software_versions()
    command = " ".join(shlex.quote(a) for a in sys.argv) or "python"
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    out.attrs["Conventions"] = CONVENTIONS
    out.attrs.setdefault("title", title or f"granular-validate {ds.attrs.get('geometry', 'result')}")
    out.attrs["history"] = f"{stamp}: {command}"
    out.attrs["source"] = (f"granular-validate {versions.get('granular-validate', '?')}; LIGGGHTS (Debian package) "
                           f"{versions.get('liggghts', '?')}")
    for name, extra in COORDINATES.items():
        if name in out.coords:
            out[name].attrs.update(extra)
    averaged = "time_window" in out.attrs
    for name in list(out.data_vars):
        if name.endswith("_err"):
            continue
        if f"{name}_err" in out:
            out[name].attrs["ancillary_variables"] = f"{name}_err"
            out[f"{name}_err"].attrs.setdefault("long_name", f"standard error of {name}")
        if averaged and "z" in out[name].dims:
            out[name].attrs["cell_methods"] = "time: mean"
            if f"{name}_err" in out:
                out[f"{name}_err"].attrs["cell_methods"] = "time: mean"
    for key, value in list(out.attrs.items()):
        if key.endswith("_units") or isinstance(value, str):
            continue
        if isinstance(value, (int, float, np.integer, np.floating, np.ndarray, list, tuple)):
            units = attribute_units(key)
            if units is not None:
                out.attrs[f"{key}_units"] = units
    return out
