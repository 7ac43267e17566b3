"""The normal-stress ratio of the planar cell: p = sigma_zz / r is the same as scaling the loads."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import continuum
from continuum.geometry import PlanarShear
from continuum.parameters import VolumeAveragedParameters

from .conftest import D, shear_gravity


@pytest.mark.parametrize("model", ["local_mu_i", "ngf", "volume_averaged"])
def test_ratio_equals_scaled_wall_load_and_gravity(model, local_params, ngf_params, cs_params) -> None:
    # p(z) = (P + g rho_s int nu) / r exactly: a cell with ratio r solves as one with P / r and g / r.
    params = {"local_mu_i": local_params, "ngf": ngf_params,
              "volume_averaged": VolumeAveragedParameters(cs_params, 2 * D)}[model]
    g = shear_gravity()
    r = 1.06
    with_ratio = continuum.solve(model, replace(g, normal_stress_ratio=r), params, n_grid=200)
    scaled = continuum.solve(model, replace(g, wall_pressure=g.wall_pressure / r, gravity=g.gravity / r), params, n_grid=200)
    for name in ("u_x", "p", "mu"):
        if name in with_ratio:
            assert np.allclose(with_ratio[name].values, scaled[name].values, rtol=1e-6, atol=1e-12 * float(np.abs(scaled[name]).max()))
    assert with_ratio.attrs["normal_stress_ratio"] == r


def test_ratio_outside_dense_flow_is_refused() -> None:
    with pytest.raises(ValueError, match="normal_stress_ratio"):
        replace(shear_gravity(), normal_stress_ratio=3.0)
    assert PlanarShear(0.04, 0.1, 200.0, 9.81, 0.002, 2500.0).normal_stress_ratio == 1.0
