"""The wall time series written by ``fix ave/time`` in every shear chunk.

Columns (SI units; forces are those the grains exert on the wall grains):
``step``, ``time`` (s), ``fbot_x``, ``fbot_z`` (N, on the bottom wall), ``ftop_x``, ``ftop_z``
(N, contact force on the top wall, the applied load excluded), ``h_top`` (m, mean height of the
top-wall grains), ``ke`` (J, translational kinetic energy of the flowing grains), ``max_overlap``
(m, largest contact overlap at the sample).

The pair-force sums (``series/pairsum_*.txt``, planar shear, same samples): ``step``, ``time`` (s),
``fsum_x``, ``fsum_y``, ``fsum_z`` (N), time averages. Along x and y the sum of all pair forces,
zero if every pair obeys action = reaction. Along z the forces summed over every atom: the pair
forces less the grains' weight and the top wall's load (and its damping, zero on average), so the
contact part is ``fsum_z`` + weight + load. Until issue 44 two LIGGGHTS 3.8 defects made the contact
sums non-zero (docs/dem.md, "Action and reaction"); the instantaneous sums and their round-off test
are ``series/pairforce_*.txt`` (pipeline/dem/force_balance.py).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

SERIES_COLUMNS = ("step", "time", "fbot_x", "fbot_z", "ftop_x", "ftop_z", "h_top", "ke", "max_overlap")
PAIRSUM_COLUMNS = ("step", "time", "fsum_x", "fsum_y", "fsum_z")


class SeriesError(ValueError):
    """A wall series file is missing, truncated or malformed."""


def read_wall_series(path: Path, columns: tuple[str, ...] = SERIES_COLUMNS) -> pd.DataFrame:
    """Read one ``fix ave/time`` file; raise :class:`SeriesError` naming the file and line."""
    if not path.exists():
        raise SeriesError(f"{path}: wall series file not found")
    rows = []
    for lineno, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip() or line.startswith("#"):
            continue
        words = line.split()
        if len(words) != len(columns):
            raise SeriesError(f"{path}:{lineno}: expected {len(columns)} columns, found {len(words)}")
        try:
            values = [float(w) for w in words]
        except ValueError:
            raise SeriesError(f"{path}:{lineno}: not a number in {line!r}") from None
        if not all(np.isfinite(values)):
            raise SeriesError(f"{path}:{lineno}: non-finite value in {line!r}")
        rows.append(values)
    if not rows:
        raise SeriesError(f"{path}: no samples")
    return pd.DataFrame(rows, columns=list(columns))
