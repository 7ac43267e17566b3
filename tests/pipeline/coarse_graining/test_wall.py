"""The wall's slip, effective plane, slip length and stress (pipeline.coarse_graining.wall) on
profiles and force series whose answers are known."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from pipeline.coarse_graining.wall import wall_slip, wall_stresses

D = 0.002
V = 0.1


def _fields(u: np.ndarray, z: np.ndarray, err: float, top: float, bottom: float, gravity: float = 0.0) -> xr.Dataset:
    ds = xr.Dataset({"u_x_disp": ("z", u), "u_x_disp_err": ("z", np.full_like(z, err))}, coords={"z": z})
    ds.attrs.update({"z_top_contact_plane": top, "z_bottom_contact_plane": bottom, "width": 0.5 * D,
                     "gravity": gravity})
    return ds


def test_linear_profile_with_known_slips_gives_them_back():
    # Homogeneous shear at rate s between planes 15 d apart, the bed slipping b s at each wall.
    bottom, top, b = 0.4 * D, 15.4 * D, 0.45 * D
    rate = V / (top - bottom + 2 * b)
    z = np.arange(0.0, 16 * D, 0.25 * D)
    u = rate * (z - bottom + b)
    out = wall_slip(_fields(u, z, 1e-6 * V, top, bottom), V, D)
    for side in ("top", "bottom"):
        assert out[f"wall_{side}_slip"] == pytest.approx(b * rate, rel=1e-9)
        assert out[f"wall_{side}_shear_rate"] == pytest.approx(rate, rel=1e-9)
        assert out[f"wall_{side}_slip_length"] == pytest.approx(b, rel=1e-6)
    assert out["wall_top_effective_plane"] == pytest.approx(top + b, rel=1e-9)
    assert out["wall_bottom_effective_plane"] == pytest.approx(bottom - b, rel=1e-6)


def test_bed_at_rest_at_the_bottom_has_no_slip_length():
    # A band under the top wall over a bed at rest: no shear rate resolved at the bottom.
    bottom, top = 0.5 * D, 20.5 * D  # on grid points: no interpolation error
    z = np.arange(0.0, 21 * D, 0.25 * D)
    u = 0.7 * V * np.exp(-(top - z) / (1.7 * D))  # the default bed's band: 1.7 d
    rng = np.random.default_rng(1)
    err = 1e-3 * V
    out = wall_slip(_fields(u + rng.normal(0, err, z.size), z, err, top, bottom, gravity=9.81), V, D)
    assert out["wall_top_slip"] == pytest.approx(0.3 * V, abs=3 * err)
    assert np.isnan(out["wall_bottom_slip_length"]) and np.isnan(out["wall_bottom_effective_plane"])
    assert abs(out["wall_bottom_slip"]) < 5 * err
    # the exponential's slope at the plane, 0.7 V / 1.7 d, and b = 0.3 V over it; 10 %: the noise
    # (1e-3 V a point, correlated over 2 points) on a fit over 1.75 d extrapolated 0.75 d
    assert out["wall_top_shear_rate"] == pytest.approx(0.7 * V / (1.7 * D), rel=0.1)
    assert out["wall_top_slip_length"] == pytest.approx(0.3 / 0.7 * 1.7 * D, rel=0.1)
    # the first layer's own lag is the value at the plane itself: here the same profile
    assert out["wall_top_first_layer_slip"] == pytest.approx(0.3 * V, abs=3 * err)


def test_wall_stresses_are_the_series_means_per_area_with_block_errors():
    rng = np.random.default_rng(2)
    n, area = 4000, (8 * D) ** 2
    series = pd.DataFrame({"ftop_x": -85.0 * area + rng.normal(0, 5 * area, n), "ftop_z": -200.0 * area + rng.normal(0, 5 * area, n),
                           "fbot_x": 85.0 * area + rng.normal(0, 5 * area, n), "fbot_z": 260.0 * area + rng.normal(0, 5 * area, n)})
    out = wall_stresses(series, area)
    sem = 5.0 / np.sqrt(n)
    for key, value in (("top_shear", 85.0), ("top_normal", 200.0), ("bottom_shear", 85.0), ("bottom_normal", 260.0)):
        assert out[f"wall_{key}_stress"] == pytest.approx(value, abs=4 * sem)
        # independent samples: the error is their standard error, within the blocks' own scatter
        assert 0.4 * sem < out[f"wall_{key}_stress_err"] < 2.5 * sem
