"""Format versions of what the pipeline writes, and the readers' check against results of another version.

``run.json`` carries ``format_version`` (a key) and every fields NetCDF file a ``format_version``
attribute. A reader refuses a file whose version differs from the one it was written for, naming
the file and telling which stage to rerun, instead of failing later on a missing key or, worse,
reading a changed layout as if it were the current one.

Files written before versioning was introduced (no ``format_version`` at all) are accepted only
when they hold everything the current readers need; otherwise the message lists what is missing.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

#: Layout of run.json (pipeline.dem.planar_run). Raise when a key is renamed, removed or changes meaning.
RUN_FORMAT_VERSION = 1
#: Layout of fields/{case}/{run}.nc (pipeline.coarse_graining.fields). 2: errors include the
#: autocorrelation time; fluidity, granular_temperature; u_x_disp and the wall contact planes.
FIELDS_FORMAT_VERSION = 2

#: Keys an unversioned run.json must hold: the dump lists and the contact column names, whose
#: absence (older layouts mapped generic c_pgl[k] names implicitly) would be read without error.
RUN_REQUIRED: tuple[str, ...] = ("particle_dumps", "contact_dumps", "contact_columns")
#: Attributes of a fields file the calibration and the models read.
FIELDS_REQUIRED_ATTRS: tuple[str, ...] = (
    "d", "rho_s", "z_bottom_wall", "z_top_wall", "wall_speed", "wall_pressure", "gravity",
)
#: Variables of a fields file the calibration and the scores read.
FIELDS_REQUIRED_VARS: tuple[str, ...] = ("u_x", "u_x_err", "nu", "p", "mu", "I", "shear_rate")


class FormatError(ValueError):
    """A result file was written by another version of the pipeline; the message names it."""


def _check(path: str | Path, what: str, version: Any, current: int, present: Iterable[str],
           required: Iterable[str], rerun: str) -> None:
    if version is None:
        missing = [key for key in required if key not in set(present)]
        if missing:
            raise FormatError(f"{path}: {what} without format_version, from an older pipeline: lacks "
                              f"{', '.join(missing)}; delete it and rerun {rerun}")
        return
    try:
        number = int(version)
    except (TypeError, ValueError):
        raise FormatError(f"{path}: {what} has format_version {version!r}, not an integer") from None
    if number != current:
        age = "an older" if number < current else "a newer"
        raise FormatError(f"{path}: {what} has format_version {number}, this pipeline reads version {current} "
                          f"(written by {age} pipeline); delete it and rerun {rerun}")


def check_run_record(run: Mapping[str, Any], path: str | Path) -> None:
    """Refuse a run.json of another format version (see module docstring)."""
    _check(path, "run.json", run.get("format_version"), RUN_FORMAT_VERSION, run.keys(), RUN_REQUIRED,
           "the DEM stage for this run")


def check_fields(attrs: Mapping[str, Any], variables: Iterable[str], path: str | Path) -> None:
    """Refuse a fields file of another format version; ``attrs`` its global attributes."""
    present = set(attrs) | set(variables)
    _check(path, "fields file", attrs.get("format_version"), FIELDS_FORMAT_VERSION, present,
           FIELDS_REQUIRED_ATTRS + FIELDS_REQUIRED_VARS, "the fields stage for this run")


def open_fields(path: str | Path) -> Any:
    """Open a fields NetCDF file (an ``xarray.Dataset``) after checking its format version."""
    import xarray as xr

    ds = xr.open_dataset(path)
    try:
        check_fields(ds.attrs, ds.data_vars, path)
    except FormatError:
        ds.close()
        raise
    return ds
