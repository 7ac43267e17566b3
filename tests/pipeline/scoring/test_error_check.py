"""Replica scatter against stated errors (pipeline.scoring.error_check) on replicas of known noise."""
from __future__ import annotations

import numpy as np
import xarray as xr

from pipeline.scoring.error_check import replica_chi2


def replicas(rng, stated: float, true: float, n: int = 4) -> list[xr.Dataset]:
    z = np.linspace(0.0, 0.04, 161)
    out = []
    for _ in range(n):
        ds = xr.Dataset({"nu": ("z", 0.6 + true * rng.standard_normal(z.size)), "nu_err": ("z", np.full(z.size, stated))},
                        coords={"z": z}, attrs={"d": 0.002, "z_bottom_wall": 0.0, "z_top_wall": 0.04, "width": 0.00025})
        out.append(ds)
    return out


def test_right_errors_give_chi2_one_and_understated_ones_do_not(rng) -> None:
    good = replica_chi2(replicas(rng, 0.01, 0.01), "nu")
    assert abs(good["chi2"] - 1.0) < 3 * good["chi2_err"]
    low = replica_chi2(replicas(rng, 0.005, 0.01), "nu")
    assert low["chi2"] > 1.0 + 3 * low["chi2_err"]  # errors half the truth: chi2 about 4
    assert good["pairs"] == 6
