"""The solvers' tolerance knob: each solve meets the residual it is asked for, and its profile
approaches the machine-precision one as the tolerance shrinks."""
from __future__ import annotations

import numpy as np
import pytest

import continuum
from continuum.parameters import CosseratParameters, VolumeAveragedParameters
from continuum.tolerance import event_tolerance, wall_root

from .conftest import D, shear_gravity


def params_of(model: str, local_params, ngf_params, cs_params):
    return {"local_mu_i": local_params, "ngf": ngf_params, "critical_state": cs_params,
            "cosserat": CosseratParameters(cs_params, l=1.0 * D),
            "volume_averaged": VolumeAveragedParameters(cs_params, 1.0 * D)}[model]


@pytest.mark.parametrize("model", continuum.MODEL_NAMES)
def test_residual_meets_the_tolerance_and_profiles_converge(model, local_params, ngf_params, cs_params) -> None:
    geo = shear_gravity()
    params = params_of(model, local_params, ngf_params, cs_params)
    exact = continuum.solve(model, geo, params, n_grid=128)
    variable = "u_x" if "u_x" in exact else "nu"
    errors = []
    for tolerance in (1e-2, 1e-5, 1e-10):
        sol = continuum.solve(model, geo, params, n_grid=128, tolerance=tolerance)
        assert sol.attrs["residual"] <= tolerance
        scale = np.max(np.abs(exact[variable].values))
        errors.append(np.max(np.abs(sol[variable].values - exact[variable].values)) / scale)
    # Tighter is never worse; at 1e-10 the wall condition is met to 1e-10 and the profile, which
    # depends smoothly on the wall stress, lies within 1e-6 of the machine-precision one.
    assert errors[2] <= errors[1] + 1e-12 <= errors[0] + 2e-12
    assert errors[2] < 1e-6


def test_wall_root_tightens_until_the_residual_is_met() -> None:
    # A steep relative mismatch: x 1 % off the root gives a 100 % residual.
    def mismatch(x: float) -> float:
        return (x / 2.0) ** 100 - 1.0

    root, converged, residual, iterations = wall_root(mismatch, 1.0, 3.0, 1e-6, 1e-10, 200)
    assert converged and residual <= 1e-6 and abs(root - 2.0) < 1e-7
    with pytest.raises(ValueError, match="tolerance must be positive"):
        event_tolerance(0.0)
