"""The intruder scene (issue 7): 2D NGF against the 1D planar solution, secondary rheology,
depth dependence, the local models' yield check, grid convergence. Development parameters:
d = 2 mm, depth 20 d, L_x = 16 d, P_wall = 200 Pa, V = 0.1 m/s, rod D = 3 d."""
from __future__ import annotations

import numpy as np
import pytest

import continuum
from continuum.errors import OutOfRangeError
from continuum.geometry import PlanarShear
from continuum.intruder import GridOptions, RodIntruder, intruder_speed, solve_2d
from continuum.parameters import LocalMuIParameters, MuIParameters, NGFParameters, SolidFractionLaw

D = 0.002
GEO = PlanarShear(depth=20 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0)
LX = 16 * D
MU_I = MuIParameters(0.3819, 0.6435, 0.279)
NGF = NGFParameters(MU_I, A=0.48, nu=0.6)
GRID = GridOptions(cells_per_d=4)


def rod(depth_d: float, force: float) -> RodIntruder:
    return RodIntruder.below_top(GEO, 3 * D, depth_d * D, force)


@pytest.mark.parametrize("coupling", ["coupled", "frozen"])
def test_no_intruder_reproduces_planar_solution(coupling: str) -> None:
    out = solve_2d(GEO, NGF, LX, None, GRID, coupling=coupling)
    ux = out["fields"].u_x.values
    assert np.ptp(ux, axis=1).max() <= 1e-9 * GEO.wall_speed  # no x dependence
    ref = continuum.solve("ngf", GEO, NGF, n_grid=4001)
    u1 = np.interp(out["fields"].z.values, ref.z.values, ref.u_x.values)
    assert np.max(np.abs(ux.mean(axis=1) - u1)) / GEO.wall_speed <= 1e-3
    assert out["tau_top"] == pytest.approx(ref.attrs["tau"], rel=1e-3)


def test_speed_is_affine_in_force_with_positive_mobility() -> None:
    speeds = [intruder_speed("ngf", GEO, NGF, rod(7, f), LX, GRID).speed for f in (0.0, 0.25, 0.5)]
    assert speeds[2] - speeds[1] == pytest.approx(speeds[1] - speeds[0], rel=1e-8)
    assert speeds[1] > speeds[0] > 0.0  # drift with the creep plus F / K


def test_mobility_follows_far_field_fluidity_with_depth() -> None:
    ref = continuum.solve("ngf", GEO, NGF, n_grid=4001)
    results = {k: intruder_speed("ngf", GEO, NGF, rod(k, 0.5), LX, GRID) for k in (6, 9)}
    assert results[9].speed < results[6].speed
    mob_ratio = results[6].mobility / results[9].mobility

    def g_over_p(k: float) -> float:
        z = GEO.depth - k * D
        return np.interp(z, ref.z.values, ref.fluidity.values) / np.interp(z, ref.z.values, ref.p.values)

    # eta = p / g: the mobility falls with depth like the far-field g / p (within a factor 2)
    assert 0.5 < mob_ratio / (g_over_p(6) / g_over_p(9)) < 2.0


def test_local_mu_i_zero_below_yield_and_refuses_above() -> None:
    params = LocalMuIParameters(MU_I, SolidFractionLaw(0.6, 0.3))
    below = intruder_speed("local_mu_i", GEO, params, rod(7, 0.5), LX)
    assert below.speed == 0.0 and below.yield_force > 0.5
    with pytest.raises(OutOfRangeError):
        intruder_speed("local_mu_i", GEO, params, rod(7, 1.01 * below.yield_force), LX)


def test_grid_convergence_of_speed() -> None:
    speeds = [intruder_speed("ngf", GEO, NGF, rod(7, 0.5), LX, GridOptions(cells_per_d=c)).speed
              for c in (3, 4, 6)]
    assert abs(speeds[1] - speeds[2]) < abs(speeds[0] - speeds[2])
    assert abs(speeds[1] / speeds[2] - 1.0) < 0.02
