"""The walls' Navier slip in the 2D solves around the rod (``PlanarShear.slip_length`` b;
continuum/intruder/mac.py ``build_operators``, docs/intruder_models.md "Wall slip"): u = V - b du/dz
on the top wall and u = b du/dz on the bottom wall.

Without the rod each model's 2D solve reproduces its own 1D solution with the same slip length,
to the tolerances of the no-slip tests (tests/continuum/test_intruder.py,
test_intruder_yield_models.py, test_intruder_cosserat.py); the law holds in the 2D fields alone
(exactly in Couette flow, to discretisation accuracy under gravity) with the wall stress of the
force balance; critical state's band of zero width is the slip (b changes nothing); b = 0 is
today's discretisation, and the analytical Jacobians carry the new wall terms. b = 0.45 d
throughout (a rough DEM wall's order of magnitude)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

import continuum
from continuum.geometry import PlanarShear
from continuum.intruder import GridOptions, RodIntruder, intruder_speed, solve_2d
from continuum.intruder.cosserat2d import CosseratRodSolver
from continuum.intruder.critical_state2d import CriticalStateRodSolver
from continuum.intruder.local import layer_sliding_speed
from continuum.intruder.mac import MacGrid, build_operators
from continuum.intruder.mu_i2d import MuIRodSolver
from continuum.intruder.ngf2d import NGFRodSolver
from continuum.intruder.regrid import regrid_state
from continuum.intruder.scene import disc_average
from continuum.intruder.volume_averaged2d import VolumeAveragedRodSolver
from continuum.parameters import (CosseratParameters, CriticalStateLine, CriticalStateParameters, LocalMuIParameters,
                                  MuIParameters, NGFParameters, SolidFractionLaw, VolumeAveragedParameters)

from .jacobian_check import assert_jacobian_is_the_residuals_derivative

D = 0.002
B = 0.45 * D
V = 0.1
# NGF: the bed of tests/continuum/test_intruder.py (20 d, sigma_zz / p = 1.058)
NGF = NGFParameters(MuIParameters(0.3819, 0.6435, 0.279), A=0.48, nu=0.6)
GEO_NGF = PlanarShear(depth=20 * D, wall_speed=V, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                      normal_stress_ratio=1.058)
# the yield-stress and Cosserat models: the bed and calibration of their own 2D tests
GEO = PlanarShear(depth=21.6 * D, wall_speed=V, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                  normal_stress_ratio=1.058)
CS = CriticalStateParameters(0.374, CriticalStateLine(0.5868, 0.005, 300.0))
LOCAL = LocalMuIParameters(MuIParameters(0.374, 1.023, 0.637), SolidFractionLaw(0.5868, 0.141))
VA = VolumeAveragedParameters(CS, 1.165 * D)
COSSERAT = CosseratParameters(CS, 1.94 * D, 1.0, 0.5)
#: Without the rod the cell is x-independent: a narrow periodic cell (d / 2) is the same problem.
NARROW = 0.5 * D


def slipping(geo: PlanarShear, b: float = B) -> PlanarShear:
    return replace(geo, slip_length=b)


def planar(model: str, geo: PlanarShear, params: object) -> xr.Dataset:
    """The model's 1D solution on 4001 nodes, which must honour the slip (continuum/<model>.py)."""
    ref = continuum.solve(model, geo, params, n_grid=4001)
    assert ref.u_x.values[-1] < 0.99 * geo.wall_speed, f"the 1D {model} solver does not honour slip_length"
    return ref


def error_to_1d(fields: xr.Dataset, ref: xr.Dataset) -> tuple[float, float]:
    """Largest |<u_x>_x - u_1D| / V over the cell centres, and the x variation of u_x over V."""
    ux = fields.u_x.values
    u1 = np.interp(fields.z.values, ref.z.values, ref.u_x.values)
    return float(np.max(np.abs(ux.mean(axis=1) - u1))) / V, float(np.ptp(ux, axis=1).max()) / V


# ---- 1. without the rod, each model's 2D solve is its 1D solution with the same slip ---------

def test_ngf_without_rod_is_its_1d_solution_with_slip() -> None:
    """As test_no_rod_ngf_2d_reproduces_its_1d_solution (3 cells per d, 1e-3 V, tau to 1e-3), with
    the top wall slipping by 0.15 V. Measured: 7.2e-4 V (2.5e-4 at 6 cells per d: second order,
    with the wall corners' viscosity taken to the wall plane, mac.wall_fluidity), tau 2.4e-4, the
    slip 2.3e-4 relative. The frozen shortcut (one Stokes solve on the 1D viscosity) gives the
    1D velocity too (measured 4.7e-4 V)."""
    geo = slipping(GEO_NGF)
    ref = planar("ngf", geo, NGF)
    out = solve_2d(geo, NGF, 16 * D, None, GridOptions(cells_per_d=3), coupling="coupled")
    err, spread = error_to_1d(out["fields"], ref)
    assert err <= 1e-3 and spread <= 1e-9
    assert out["tau_top"] == pytest.approx(ref.attrs["tau"], rel=1e-3)
    assert ref.attrs["top_wall_slip"] > 0.1 * V
    assert out["top_wall_slip"] == pytest.approx(ref.attrs["top_wall_slip"], rel=1e-3)
    assert all(v < 1.0 for k, v in out["residuals"].items() if k.endswith("_over_tol"))
    frozen = solve_2d(geo, NGF, 16 * D, None, GridOptions(cells_per_d=3), coupling="frozen")
    assert error_to_1d(frozen["fields"], ref)[0] <= 1e-3
    assert frozen["top_wall_slip"] == pytest.approx(ref.attrs["top_wall_slip"], rel=5e-3)


def _no_rod(solver_type: type, params: object, cells_per_d: float, regularisations: tuple[float, ...] | None,
            geo: PlanarShear = GEO):
    kw = {} if regularisations is None else {"regularisations": regularisations}
    return solver_type(geo, params, NARROW, None, GridOptions(cells_per_d=cells_per_d), **kw).solve()


def test_local_mu_i_without_rod_is_its_1d_flow_with_slip() -> None:
    # As test_local_mu_i_without_rod_is_its_1d_flow (8 cells per d, 1e-3 V; measured 4.9e-4, and
    # 2.1e-3 at 4 cells per d: second order), the top wall slipping by 0.26 V.
    geo = slipping(GEO)
    ref = planar("local_mu_i", geo, LOCAL)
    sol = _no_rod(MuIRodSolver, LOCAL, 8, (1e-1, 1e-2, 1e-3, 1e-4, 1e-5), geo)
    err, spread = error_to_1d(sol.fields, ref)
    assert err <= 1e-3 and spread <= 1e-9
    assert sol.attrs["tau_top"] == pytest.approx(ref.attrs["tau"], rel=1e-3)
    assert sol.attrs["top_wall_slip"] == pytest.approx(ref.attrs["top_wall_slip"], rel=1e-3)


def test_volume_averaged_without_rod_converges_to_its_1d_creep_with_slip() -> None:
    # As test_volume_averaged_without_rod_converges_to_its_1d_creep: the error falls as h^2 from 4
    # to 8 cells per d (measured 2.5e-3 and 6.6e-4 V, ratio 3.8). With slip the wall's error is
    # smaller and the regularisation's creep floor (~7e-4 V at eps = 1e-4 V/d, 17-19 d above the
    # bottom, on any grid) would dominate the 8-cells error: one more stage, eps = 1e-5 V/d.
    geo = slipping(GEO)
    ref = planar("volume_averaged", geo, VA)
    regs = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5)
    sols = {c: _no_rod(VolumeAveragedRodSolver, VA, c, regs, geo) for c in (4, 8)}
    (e4, s4), (e8, s8) = (error_to_1d(sols[c].fields, ref) for c in (4, 8))
    sol8 = sols[8]
    assert 3.0 <= e4 / e8 <= 5.0
    assert e8 <= 1e-3 and max(s4, s8) <= 1e-9
    assert sol8.attrs["tau_top"] == pytest.approx(ref.attrs["tau"], rel=1e-3)
    assert sol8.attrs["top_wall_slip"] == pytest.approx(ref.attrs["top_wall_slip"], rel=1e-2)


def test_cosserat_without_the_rod_converges_to_its_1d_solution_with_slip() -> None:
    # As test_without_the_rod_the_2d_solve_converges_to_the_1d_solution: the velocity error falls
    # as h^2 (measured 4.9e-3 and 1.0e-3 V at 4 and 8 cells per d), the wall stress to 1e-3.
    geo = slipping(GEO)
    ref = planar("cosserat", geo, COSSERAT)
    out = {c: _no_rod(CosseratRodSolver, COSSERAT, c, None, geo) for c in (4, 8)}
    e4, e8 = (error_to_1d(out[c].fields, ref)[0] for c in (4, 8))
    assert 3.0 <= e4 / e8 <= 5.0 and e8 <= 2e-3
    assert out[8].attrs["tau_top"] == pytest.approx(ref.attrs["tau"], rel=1e-3)
    assert out[8].attrs["top_wall_slip"] == pytest.approx(ref.attrs["top_wall_slip"], rel=1e-2)


def test_critical_state_band_is_the_slip() -> None:
    """Critical state's wall layer is a band of zero width: b changes nothing, in 1D and in 2D (the
    same solve, bit for bit, and u = V in the top wall's plane), and the 2D solve is the 1D band
    as in test_critical_state_without_rod_is_its_1d_band."""
    geo = slipping(GEO)
    ref = continuum.solve("critical_state", geo, CS, n_grid=4001)
    regs = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5)
    sol = _no_rod(CriticalStateRodSolver, CS, 4, regs, geo)
    still = _no_rod(CriticalStateRodSolver, CS, 4, regs, GEO)
    assert np.array_equal(sol.fields.u_x.values, still.fields.u_x.values)
    assert sol.attrs["tau_top"] == still.attrs["tau_top"] and sol.attrs["top_wall_slip"] == 0.0
    err, spread = error_to_1d(sol.fields, ref)
    assert err <= 1e-3 and spread <= 1e-9
    assert sol.attrs["tau_top"] == pytest.approx(ref.attrs["tau"], rel=1e-3)


# ---- 2. the law in the 2D fields, independent of the 1D solvers -------------------------------

def test_couette_flow_with_slip_is_exact() -> None:
    """Without gravity NGF's bed is uniform: u = gammadot (z + b), gammadot = V / (H + 2 b), both
    walls slipping by b gammadot (the ghosts are exact for a linear profile), and the stress is
    NGF's local law at that rate, tau / p = mu_s + b_mu I (NGF's linearised mu(I))."""
    geo = PlanarShear(depth=10 * D, wall_speed=V, wall_pressure=200.0, gravity=0.0, d=D, rho_s=2500.0,
                      normal_stress_ratio=1.058, slip_length=B)
    solver = NGFRodSolver(geo, NGF, NARROW, None, GridOptions(cells_per_d=2))
    sol = solver.solve()
    z = sol.fields.z.values
    gammadot = V / (geo.depth + 2.0 * B)
    assert np.max(np.abs(sol.fields.u_x.values - (gammadot * (z + B))[:, None])) <= 1e-9 * V
    bottom, top = solver.ops.wall_velocities(sol.flow.u, V, solver.grid.nx)
    assert np.allclose(bottom, B * gammadot, rtol=1e-9) and np.allclose(top, V - B * gammadot, rtol=1e-9)
    assert sol.attrs["top_wall_slip"] == pytest.approx(B * gammadot, rel=1e-9)
    p = geo.top_pressure
    inertial = gammadot * D / np.sqrt(p / geo.rho_s)
    assert sol.attrs["tau_top"] == pytest.approx(p * (NGF.mu_i.mu_s + NGF.mu_i.b * inertial), rel=1e-6)


def _wall_law(cells_per_d: float) -> tuple[float, float, float, float, float]:
    """NGF under gravity without the rod: (u_wall - (V - b gammadot_wall)) / V with u_wall and
    gammadot_wall extrapolated from the top three cell centres (a quadratic), the slip V - u_wall
    over V, the stress's spread over the corner rows and its bottom-to-top mismatch (over tau_top),
    and (slip - b g_wall tau_top / p_wall) / V, NGF's law gammadot = g mu at the wall (g_wall
    log-quadratic from the same cells)."""
    geo = slipping(GEO_NGF)
    sol = NGFRodSolver(geo, NGF, NARROW, None, GridOptions(cells_per_d=cells_per_d)).solve()
    f = sol.fields
    h = geo.depth / f.z.size
    below = -np.array([0.5, 1.5, 2.5]) * h  # the top three cell centres, relative to the wall
    cu = np.polyfit(below, f.u_x.values.mean(axis=1)[:-4:-1], 2)
    u_wall, rate_wall = np.polyval(cu, 0.0), np.polyval(np.polyder(cu), 0.0)
    g_wall = np.exp(np.polyval(np.polyfit(below, np.log(f.fluidity.values.mean(axis=1)[:-4:-1]), 2), 0.0))
    tau = sol.attrs["tau_top"]
    rows = sol.flow.s_xz_corners.reshape(-1, f.x.size).mean(axis=1)  # bottom wall ... top wall
    return ((u_wall - (V - B * rate_wall)) / V, (V - u_wall) / V, float(np.ptp(rows)) / tau,
            abs(rows[0] - tau) / tau, (sol.attrs["top_wall_slip"] - B * g_wall * tau / geo.top_pressure) / V)


def test_the_top_wall_slips_by_b_times_its_shear_rate() -> None:
    """The fields alone, no 1D solve: the grains' velocity in the top wall plane is V - b gammadot
    there to discretisation accuracy (measured 1.8e-3 and 6.1e-4 V at 3 and 6 cells per d, against
    a slip of 0.15 V), the shear stress is the same on both walls and on every plane between (the
    force balance along x, to round-off), and the slip is b times NGF's wall rate g mu at that
    stress (measured 4.6e-4 and 8e-6 V)."""
    m3, slip3, spread3, walls3, law3 = _wall_law(3)
    m6, slip6, spread6, walls6, law6 = _wall_law(6)
    assert slip3 > 0.1 and slip6 > 0.1
    assert abs(m3) <= 2.5e-3 and abs(m6) <= 1e-3 and abs(m6) <= 0.5 * abs(m3)
    assert max(spread3, spread6, walls3, walls6) <= 1e-9
    assert abs(law3) <= 1e-3 and abs(law6) <= 1e-4


# ---- 3. b = 0 is today's discretisation ------------------------------------------------------

def test_zero_slip_is_the_no_slip_ghost_bit_for_bit() -> None:
    """build_operators without slip: the no-slip ghosts (du/dz = 2 (U_wall - u_1) / hz) exactly,
    the default; the wall velocities are 0 and V exactly."""
    grid = MacGrid(6, 10, 0.1, 0.02)
    default, zero = build_operators(grid), build_operators(grid, 0.0)
    assert (default.dzu != zero.dzu).nnz == 0 and np.array_equal(default.lift_top, zero.lift_top)
    dzu = default.dzu.toarray()
    nx, nz, hz = grid.nx, grid.nz, grid.hz
    assert np.array_equal(np.diag(dzu[:nx, :nx]), np.full(nx, 2.0 / hz))
    assert np.array_equal(np.diag(dzu[nz * nx:, (nz - 1) * nx:]), np.full(nx, -2.0 / hz))
    assert np.array_equal(default.lift_top[nz * nx:], np.full(nx, 2.0 / hz)) and not default.lift_top[:nz * nx].any()
    u = np.random.default_rng(0).normal(size=grid.n_cells)
    bottom, top = default.wall_velocities(u, V, nx)
    assert not bottom.any() and np.all(top == V)
    slipping_ops = build_operators(grid, 0.01)
    assert np.allclose(slipping_ops.lift_top[nz * nx:], 1.0 / (0.01 + 0.5 * hz), rtol=1e-15)


def _rod_solves(geo: PlanarShear) -> dict[str, np.ndarray]:
    """Rod speeds and fields of the 2D solves that impose the wall condition, on a 14 d bed (2 cells
    per d, L_x = 8 d, the rod 5 d under the top): NGF (coupled and frozen) and local mu(I) with the
    rod, the volume-averaged model and Cosserat without."""
    out = {}
    small = replace(geo, depth=14 * D)
    rod = RodIntruder.below_top(small, 3 * D, 5 * D, 0.25)
    grid = GridOptions(cells_per_d=2)
    for model in ("ngf", "ngf_frozen"):
        r = intruder_speed(model, small, NGF, rod, 8 * D, grid)
        out[model] = np.append(r.fields.u_x.values.ravel(), [r.speed, r.attrs["tau_top"]])
    sol = MuIRodSolver(small, LOCAL, 8 * D, rod, grid, regularisations=(1e-1, 1e-2)).solve()
    out["local_mu_i"] = np.append(sol.fields.u_x.values.ravel(), sol.speed)
    for name, solver_type, params, regs in (("volume_averaged", VolumeAveragedRodSolver, VA, (1e-1, 1e-2)),
                                            ("cosserat", CosseratRodSolver, COSSERAT, (1e-1, 1e-2, 1e-3))):
        sol = _no_rod(solver_type, params, 2, regs, small)
        out[name] = np.append(sol.fields.u_x.values.ravel(), sol.attrs["tau_top"])
    return out


def test_zero_slip_reproduces_the_default_and_a_vanishing_slip_tends_to_it() -> None:
    """slip_length = 0 given explicitly is the default geometry's solve, bit for bit, for every
    kind of 2D solve; and a slip of 1e-9 d moves nothing by more than 1e-6 (relative to V for
    velocities): the wall viscosity's move to the wall plane (only with slip) is continuous at 0."""
    geo = GEO_NGF  # slip_length left at its default
    default = _rod_solves(geo)
    zero = _rod_solves(replace(geo, slip_length=0.0))
    tiny = _rod_solves(replace(geo, slip_length=1e-9 * D))
    for name, values in default.items():
        assert np.array_equal(values, zero[name]), name
        assert np.allclose(tiny[name], values, rtol=1e-6, atol=1e-6 * V), name


# ---- the analytical Jacobians carry the wall terms; the warm start carries the slip -----------

@pytest.mark.parametrize("solver_type, params", [(MuIRodSolver, LOCAL), (VolumeAveragedRodSolver, VA),
                                                 (CosseratRodSolver, COSSERAT)])
def test_the_jacobian_with_slip_is_the_derivative_of_the_residual(solver_type: type, params: object) -> None:
    """As test_the_jacobian_is_the_derivative_of_the_residual (Cosserat), with the walls slipping,
    for the yield-stress equations (plastic2d.equations: mu(I), and the volume-averaged l > 0)
    and Cosserat's: central differences on a coarse bed with the rod at a perturbed state."""
    geo = slipping(GEO)
    solver = solver_type(geo, params, 6 * D, RodIntruder.below_top(geo, 3 * D, 6.5 * D, 1.0),
                         GridOptions(cells_per_d=1))
    assert solver.ops.slip_length == B
    assert_jacobian_is_the_residuals_derivative(solver)


def test_regrid_carries_a_slipping_linear_state_exactly() -> None:
    """The warm start's wall rows are the Navier wall velocities: the slipping Couette profile
    u = gammadot (z + b), gammadot = V / (H + 2 b), is carried onto another grid exactly."""
    h, lx = 10 * D, 4 * D
    old, new = MacGrid(8, 20, lx / 8, h / 20), MacGrid(12, 30, lx / 12, h / 30)
    gammadot = V / (h + 2.0 * B)
    state = {"u": gammadot * (np.repeat(old.z_centres, old.nx) + B), "w": np.zeros(old.n_w),
             "pi": np.full(old.n_cells, 200.0), "U": np.array([0.05])}
    out = regrid_state(state, old, new, V, B)
    assert np.allclose(out["u"], gammadot * (np.repeat(new.z_centres, new.nx) + B), rtol=0, atol=1e-12 * V)


def test_layer_sliding_without_push_is_the_1d_flow_with_slip() -> None:
    """The local_mu_i_layer_sliding shortcut: with F = 0 its profile is the 1D solution, slip
    included (the top-wall stress to 1e-6, the rod's disc average of u to 1e-5)."""
    geo = slipping(GEO)
    ref = planar("local_mu_i", geo, LOCAL)
    rod = RodIntruder.below_top(geo, 3 * D, 2.5 * D, 0.0)
    speed, tau_top = layer_sliding_speed(ref, LOCAL.mu_i, geo, rod, 12 * D)
    assert tau_top == pytest.approx(ref.attrs["tau"], rel=1e-6)
    assert speed == pytest.approx(disc_average(ref.z.values, ref.u_x.values, rod.depth_from_bottom, rod.radius),
                                  rel=1e-5)
