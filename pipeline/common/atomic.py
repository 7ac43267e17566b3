"""Write result files so that a failed step never leaves one that looks complete.

Every writer goes to a temporary name in the same folder and renames at the end (a rename is
atomic on one file system): a crash leaves at most a temporary file, never a truncated result.
Each output has one temporary name, :func:`temporary`; a step clears those a killed earlier run
left of its outputs when it starts (:func:`clear_stale`).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pandas as pd
import xarray as xr

from pipeline.common import cf


#: Suffixes whose writer picks the format by the file name (VTK's): their temporary keeps the suffix.
SUFFIX_PICKS_FORMAT = (".vts", ".vtp", ".vtu")


def temporary(path: Path) -> Path:
    """The name ``path`` is written under until it is complete: ``<name>.tmp``, or for
    :data:`SUFFIX_PICKS_FORMAT` ``.<stem>.tmp<suffix>`` (hidden, so not taken for a result)."""
    path = Path(path)
    if path.suffix in SUFFIX_PICKS_FORMAT:
        return path.with_name(f".{path.stem}.tmp{path.suffix}")
    return path.with_name(path.name + ".tmp")


def _tmp(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    return temporary(path)


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


def clear_stale(*paths: Path, temporaries_of: tuple[Path, ...] = ()) -> list[Path]:
    """Before a step starts: remove its side outputs ``paths`` from an earlier invocation, so that a
    step killed before it writes them leaves nothing that looks complete beside its main file (a
    ``.vts`` of another run beside a new ``.nc``), and the temporaries a killed earlier run left of
    those and of the main outputs ``temporaries_of`` (their :func:`temporary` names only, never
    another file), saying in one line which. Returns the temporaries removed."""
    for path in paths:
        Path(path).unlink(missing_ok=True)
    removed = []
    for output in (*paths, *temporaries_of):
        stale = temporary(output)
        if stale.is_file():
            stale.unlink()
            removed.append(stale)
    if removed:
        print(f"note: removed {', '.join(map(str, removed))}: temporary file(s) of an earlier run of this step "
              "that did not finish", file=sys.stderr)
    return removed
