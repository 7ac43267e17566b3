"""Write result files so that a failed step never leaves one that looks complete.

Every writer goes to ``<name>.tmp`` in the same folder and renames at the end (a rename is
atomic on one file system): a crash leaves at most a ``.tmp`` file, never a truncated result.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd
import xarray as xr

from pipeline.common import cf


def _tmp(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    return path.with_name(path.name + ".tmp")


def write_netcdf(dataset: xr.Dataset, path: Path, title: str | None = None) -> None:
    """``dataset.to_netcdf(path)`` with the CF-1.10 metadata of :mod:`pipeline.common.cf`, atomically."""
    tmp = _tmp(Path(path))
    try:
        cf.apply(dataset, title).to_netcdf(tmp, engine="netcdf4")
        tmp.replace(path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_csv(frame: pd.DataFrame, path: Path) -> None:
    """``frame.to_csv(path, index=False)``, atomically."""
    tmp = _tmp(Path(path))
    frame.to_csv(tmp, index=False)
    tmp.replace(path)


def write_text(text: str, path: Path) -> None:
    """A text file, atomically."""
    tmp = _tmp(Path(path))
    tmp.write_text(text)
    tmp.replace(path)


def write_json(data: dict[str, Any], path: Path) -> None:
    """``data`` as indented JSON (numpy scalars as floats), atomically."""
    write_text(json.dumps(data, indent=1, default=float), path)


def clear_stale(*paths: Path) -> None:
    """Remove a step's outputs from an earlier invocation before it starts, so that a step killed
    before it writes them leaves nothing that looks complete beside its main file (a ``.vts`` of
    another run beside a new ``.nc``)."""
    for path in paths:
        Path(path).unlink(missing_ok=True)
