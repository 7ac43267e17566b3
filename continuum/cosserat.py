"""Cosserat plasticity (Mohan, Rao & Nott 2002) -- placeholder until implemented."""
from __future__ import annotations

import xarray as xr

from .errors import ContinuumError
from .geometry import PlanarShear
from .parameters import CosseratParameters

MODEL = "cosserat"


def solve(geometry: PlanarShear, params: CosseratParameters, n_grid: int = 200, case: str | None = None) -> xr.Dataset:
    raise ContinuumError("cosserat solver not implemented yet")
