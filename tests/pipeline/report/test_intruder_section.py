"""The report's intruder bands: a model's 2.5-97.5 % range over its parameter draws, per sweep."""
from __future__ import annotations

import numpy as np
import xarray as xr

from pipeline.report.intruder_section import draws_band


def test_band_spans_the_draws_and_keeps_the_sweeps_apart(tmp_path) -> None:
    speed = np.array([[1.0, 2.0, 10.0], [3.0, 4.0, 30.0], [5.0, 6.0, 50.0]])  # draws x runs
    ens = xr.Dataset({"speed": (("draw", "run"), speed),
                      "force_sweep": ("run", np.array([0, 1, 1], np.int8)),
                      "depth_over_d": ("run", np.array([5.0, 7.0, 7.0])),
                      "push_over_yield": ("run", np.array([0.43, 0.9, 0.3]))})
    path = tmp_path / "ngf.nc"
    ens.to_netcdf(path)
    x, lo, hi = draws_band(path, sweep=True)
    assert list(x) == [0.3, 0.9]  # ordered by push
    assert np.allclose(lo, np.percentile(speed[:, [2, 1]], 2.5, axis=0))
    assert np.allclose(hi, np.percentile(speed[:, [2, 1]], 97.5, axis=0))
    x, lo, hi = draws_band(path, sweep=False)
    assert list(x) == [5.0] and lo[0] < 3.0 < hi[0]
    assert draws_band(tmp_path / "missing.nc", sweep=True) is None
