"""The rod speed's parameter derivatives by the implicit-function theorem
(``continuum.intruder.sensitivity``, issue 57 item 1) against the derivative of the model's own
solutions, ``speed_secants`` (NGF's derivative): a central difference of two full solves at theta +- 1e-3 theta, each converged to a
scaled residual of 1e-6 (rel ~1e-6 on U, so the difference's noise is ~1e-3 relative at this step
and its truncation error ~1e-6). Measured agreement 2e-6 to 2e-4; the tolerance 2e-3 covers the
difference's noise. Volume-averaged and Cosserat, the rod 3 d at 6.5 d under the wall at half the
5 d yield force (as test_intruder_yield_models' warm-start test), 2 cells per d."""
from __future__ import annotations

import pytest

from continuum.intruder import GridOptions, RodIntruder, intruder_speed
from continuum.intruder.sensitivity import parameter_values, speed_secants, speed_sensitivities, with_parameter
from continuum.parameters import CosseratParameters, MuIParameters, NGFParameters, VolumeAveragedParameters

from .test_intruder_yield_models import CS, GEO, LX, D

GRID = GridOptions(cells_per_d=2)
YIELD_FORCE = 1.5 * (GEO.wall_pressure + 0.6 * GEO.rho_s * GEO.gravity * 5 * D) * 3 * D
ROD = RodIntruder.below_top(GEO, 3 * D, 6.5 * D, 0.5 * YIELD_FORCE)


def central_difference(model: str, params: object, path: str, nominal) -> float:
    """``speed_secants`` (NGF's derivative) over +- 1e-3 of the value: two full warm solves."""
    h = 1e-3 * abs(parameter_values(params)[path])
    return speed_secants(model, GEO, params, ROD, LX, GRID, nominal, {path: h})[path]


@pytest.mark.parametrize("model, params, paths", [
    ("volume_averaged", VolumeAveragedParameters(CS, 1.165 * D), ["critical.sin_phi", "l"]),
    ("cosserat", CosseratParameters(CS, 1.94 * D, 1.0, 0.5), ["l"]),
])
def test_implicit_derivative_is_the_derivative_of_the_solutions(model: str, params: object, paths: list[str]) -> None:
    nominal = intruder_speed(model, GEO, params, ROD, LX, GRID)
    assert nominal.speed > 0.0 and not nominal.attrs["rigid_in_limit"]  # a moving rod: U has a derivative
    implicit = speed_sensitivities(model, GEO, params, ROD, LX, GRID, nominal.state, paths)
    for path in paths:
        fd = central_difference(model, params, path, nominal)
        assert implicit[path] == pytest.approx(fd, rel=2e-3), path
        assert abs(fd) * abs(parameter_values(params)[path]) > 1e-3 * nominal.speed  # not a derivative at round-off


def test_parameter_paths_reach_nested_fields_and_only_floats() -> None:
    params = CosseratParameters(CS, 1.94 * D, 1.0, 0.5)
    values = parameter_values(params)
    assert values["critical.line.nu_ref"] == 0.5868 and values["l"] == 1.94 * D
    moved = with_parameter(params, "critical.line.kappa", 0.007)
    assert moved.critical.line.kappa == 0.007 and params.critical.line.kappa == 0.005  # a copy
    assert parameter_values(moved)["critical.sin_phi"] == values["critical.sin_phi"]
    with pytest.raises(KeyError, match="no parameter 'mu_s'"):
        with_parameter(params, "mu_s", 0.3)


def test_unknown_parameter_and_non_newton_model_are_refused() -> None:
    params = VolumeAveragedParameters(CS, 1.165 * D)
    with pytest.raises(KeyError, match="no float parameter"):
        speed_sensitivities("volume_averaged", GEO, params, ROD, LX, GRID, {}, ["critical.line.p_ref_typo"])
    ngf = NGFParameters(MuIParameters(0.374, 1.023, 0.637), A=0.48, nu=0.6)
    with pytest.raises(TypeError, match="not a Newton yield-stress solver"):
        speed_sensitivities("ngf", GEO, ngf, ROD, LX, GRID, {}, ["A"])
    with pytest.raises(ValueError, match="step of A must be positive"):
        speed_secants("ngf", GEO, ngf, ROD, LX, GRID, None, {"A": 0.0})
