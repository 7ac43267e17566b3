"""The yield-stress models around the rod in 2D (issue 43, items 3-4; docs/intruder_models.md):
without the rod each reproduces its own 1D planar solution; the regularisation limit; critical
state's limit load bounded (rigid below its onset, refused above its limit load). Default
calibration (mu_s 0.374, mu_2 1.023, I_0 0.637, nu_c 0.5868, a 0.141, l = 1.165 d,
sigma_zz / p = 1.058) on the intruder case's bed (21.6 d, L_x = 12 d, rod 3 d)."""
from __future__ import annotations

import numpy as np
import pytest

import continuum
from continuum.errors import OutOfRangeError
from continuum.geometry import PlanarShear
from continuum.intruder import GridOptions, RodIntruder, intruder_speed
from continuum.intruder.critical_state2d import CriticalStateRodSolver
from continuum.intruder.mu_i2d import MuIRodSolver
from continuum.intruder.volume_averaged2d import VolumeAveragedRodSolver
from continuum.parameters import (CriticalStateLine, CriticalStateParameters, LocalMuIParameters, MuIParameters,
                                  SolidFractionLaw, VolumeAveragedParameters)

D = 0.002
GEO = PlanarShear(depth=21.6 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                  normal_stress_ratio=1.058)
LX = 12 * D
CS = CriticalStateParameters(0.374, CriticalStateLine(0.5868, 0.005, 300.0))
LOCAL = LocalMuIParameters(MuIParameters(0.374, 1.023, 0.637), SolidFractionLaw(0.5868, 0.141))
VA = VolumeAveragedParameters(CS, 1.165 * D)
#: The cell without the rod is x-independent: a narrow periodic cell (d / 2, four columns) is the
#: same problem.
NARROW = 0.5 * D


def no_rod_error(solver_type: type, params: object, cells_per_d: float, regularisations: tuple[float, ...]):
    """Largest |u_x - u_1D| / V over the cell centres, the x variation of u_x, and the 2D and 1D
    top-wall shear stresses."""
    sol = solver_type(GEO, params, NARROW, None, GridOptions(cells_per_d=cells_per_d),
                      regularisations=regularisations).solve()
    ref = continuum.solve(solver_type.model, GEO, params, n_grid=4001)
    ux = sol.fields.u_x.values
    u1 = np.interp(sol.fields.z.values, ref.z.values, ref.u_x.values)
    err = float(np.max(np.abs(ux.mean(axis=1) - u1))) / GEO.wall_speed
    return err, float(np.ptp(ux, axis=1).max()) / GEO.wall_speed, sol.attrs["tau_top"], ref.attrs["tau"]


def test_critical_state_without_rod_is_its_1d_band() -> None:
    # 1D: rigid below a band on the top wall (tau = sin_phi P_wall / r). The regularised creep
    # below is ~ eps mu / (sin_phi - mu) d: at 1e-5 V / d it stays under 1e-3 V.
    err, spread, tau2, tau1 = no_rod_error(CriticalStateRodSolver, CS, 4, (1e-1, 1e-2, 1e-3, 1e-4, 1e-5))
    assert err <= 1e-3 and spread <= 1e-9
    assert tau2 == pytest.approx(tau1, rel=1e-3)


def test_local_mu_i_without_rod_is_its_1d_flow() -> None:
    # The 3.5 d flowing layer under the top wall is resolved to 1e-3 V at 8 cells per d
    # (second order: 2.6e-3 V at 4 cells per d).
    err, spread, tau2, tau1 = no_rod_error(MuIRodSolver, LOCAL, 8, (1e-1, 1e-2, 1e-3, 1e-4, 1e-5))
    assert err <= 1e-3 and spread <= 1e-9
    assert tau2 == pytest.approx(tau1, rel=1e-3)


def test_volume_averaged_without_rod_converges_to_its_1d_creep() -> None:
    # The exponential creep exp(-(H - z) / l) under the top wall's band, with the wall condition
    # l dD/dn = -D: the error falls as h^2 (ratio 4 from 4 to 8 cells per d, within 25 %), so the
    # 2D solution converges to the 1D one; the extrapolated error is below 1e-3 V.
    regs = (1e-1, 1e-2, 1e-3, 1e-4)
    e4, s4, tau4, tau1 = no_rod_error(VolumeAveragedRodSolver, VA, 4, regs)
    e8, s8, tau8, _ = no_rod_error(VolumeAveragedRodSolver, VA, 8, regs)
    assert 3.0 <= e4 / e8 <= 5.0
    assert e8 - (e4 - e8) / 3.0 <= 1e-3 and max(s4, s8) <= 1e-9
    assert tau8 == pytest.approx(tau1, rel=1e-3)


def test_critical_state_rod_below_its_onset_is_rigid_in_the_limit() -> None:
    """A rod pushed at 0.3 of the DEM's yield force at 6.5 d: the regularised U is the creep of
    a rigid zone, proportional to eps (to 1 %) over two decades, so the model's U -> 0."""
    rod = RodIntruder.below_top(GEO, 3 * D, 6.5 * D, 1.096)
    res = intruder_speed("critical_state", GEO, CS, rod, LX, GridOptions(cells_per_d=2))
    u = [res.attrs[f"speed_at_eps_{e:.0e}"] for e in (1e-2, 1e-3, 1e-4, 1e-5)]
    assert all(a / b == pytest.approx(10.0, rel=1e-2) for a, b in zip(u, u[1:]))
    # the model's answer: at rest, with the last stage's creep (~ 10 eps d next to the rod,
    # where mu is close to sin_phi) as the bound
    assert res.speed == 0.0 and res.attrs["rigid_in_limit"] == 1
    assert 0.0 < res.attrs["speed_bound"] < 20.0 * 1e-5 * GEO.wall_speed
    assert res.attrs["rod_force"] == pytest.approx(1.096, rel=1e-9)


def test_critical_state_refuses_a_push_above_its_limit_load() -> None:
    """Above the limit load no stress field within the yield surface balances the push: refused,
    with the computed limit load, which lies above the onset push of the test before."""
    solver = CriticalStateRodSolver(GEO, CS, LX, RodIntruder.below_top(GEO, 3 * D, 6.5 * D, 20.0),
                                    GridOptions(cells_per_d=2), regularisations=(1e-1, 1e-2))
    with pytest.raises(OutOfRangeError, match="limit load"):
        solver.solve()
    loads = solver.last_limit_load
    # the force the material resists with no longer depends on the rod's speed once it outruns
    # the wall (3 V against 10 V within 1 %): that plateau is the limit load
    assert loads["limit_force_3V"] == pytest.approx(loads["limit_force_10V"], rel=1e-2)
    assert 1.096 < loads["limit_force_10V"] < 20.0


def test_a_solve_told_not_to_compute_the_limit_load_reports_the_failure_as_it_is() -> None:
    """``limit_load=False`` (the parameter draws): the same push above the limit load fails as the
    Newton failure it is, a ConvergenceError and not OutOfRangeError, with no limit load computed
    (its two driven solves are what the switch saves)."""
    from continuum.errors import ConvergenceError
    solver = CriticalStateRodSolver(GEO, CS, LX, RodIntruder.below_top(GEO, 3 * D, 6.5 * D, 20.0),
                                    GridOptions(cells_per_d=2), regularisations=(1e-1, 1e-2))
    with pytest.raises(ConvergenceError) as failure:
        solver.solve(limit_load=False)
    assert not isinstance(failure.value, OutOfRangeError)
    assert solver.last_limit_load == {}


def test_regrid_carries_a_linear_state_exactly() -> None:
    """Bilinear interpolation, periodic in x, with the walls' values as rows: a field linear in z
    (the planar shear u = V z / H, w = 0, a hydrostatic pi; Cosserat's corner spin, here linear in
    z, walls included) is carried onto another grid exactly."""
    from continuum.intruder.mac import MacGrid
    from continuum.intruder.regrid import regrid_state
    h, lx, V = 10 * D, 4 * D, 0.1
    old, new = MacGrid(8, 20, lx / 8, h / 20), MacGrid(12, 30, lx / 12, h / 30)
    zu = np.repeat(old.z_centres, old.nx)
    zk = np.repeat(np.arange(old.nz + 1) * old.hz, old.nx)
    state = {"u": V * zu / h, "w": np.zeros(old.n_w), "pi": 200.0 + 30.0 * (h - zu), "U": np.array([0.05]),
             "omega": 3.0 + 40.0 * zk / h}
    out = regrid_state(state, old, new, V)
    zk_new = np.repeat(np.arange(new.nz + 1) * new.hz, new.nx)
    assert np.allclose(out["omega"], 3.0 + 40.0 * zk_new / h, rtol=1e-12)
    z_new = np.repeat(new.z_centres, new.nx)
    assert np.allclose(out["u"], V * z_new / h, rtol=0, atol=1e-12 * V)
    assert np.allclose(out["pi"], 200.0 + 30.0 * (h - z_new), rtol=1e-12) and not out["w"].any()
    assert out["U"][0] == 0.05


def test_a_finer_grid_started_from_the_coarse_solution_reaches_the_cold_solution() -> None:
    """The grid study's warm start (``predict_draws``): mu(I) around the rod at 2 cells per d,
    carried onto 3 cells per d, converges to the cold 3-cells-per-d speed (same equations, same
    convergence test: to 1e-6 relative) in fewer Newton iterations."""
    geo = PlanarShear(depth=14 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                      normal_stress_ratio=1.058)
    f_y = 1.5 * (200 + 0.6 * 2500 * 9.81 * 7 * D) * 3 * D
    rod = RodIntruder.below_top(geo, 3 * D, 7 * D, 0.5 * f_y)
    coarse = intruder_speed("local_mu_i", geo, LOCAL, rod, 8 * D, GridOptions(cells_per_d=2))
    cold = intruder_speed("local_mu_i", geo, LOCAL, rod, 8 * D, GridOptions(cells_per_d=3))
    warm = intruder_speed("local_mu_i", geo, LOCAL, rod, 8 * D, GridOptions(cells_per_d=3), warm=coarse)
    assert 0.01 * geo.wall_speed < cold.speed < geo.wall_speed  # a creeping rod, not one carried with the wall
    assert warm.speed == pytest.approx(cold.speed, rel=1e-6)
    assert warm.iterations < cold.iterations


def test_a_state_of_another_bed_on_another_grid_is_no_start() -> None:
    """The nominal sweep starts a scene from the last one at its depth, whose bed may be a fraction
    of a grain deeper (another replica's run: 21.56 d against 21.47 d in the default of
    2026-12-05), so another nz: that state is not carried (another cell), the solve starts cold
    and gives the cold speed."""
    deeper = PlanarShear(depth=14.3 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                         normal_stress_ratio=1.058)
    geo = PlanarShear(depth=14 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                      normal_stress_ratio=1.058)
    f_y = 1.5 * (200 + 0.6 * 2500 * 9.81 * 7 * D) * 3 * D
    other = intruder_speed("local_mu_i", deeper, LOCAL, RodIntruder.below_top(deeper, 3 * D, 7 * D, 0.5 * f_y), 8 * D,
                           GridOptions(cells_per_d=2))
    rod = RodIntruder.below_top(geo, 3 * D, 7 * D, 0.5 * f_y)
    cold = intruder_speed("local_mu_i", geo, LOCAL, rod, 8 * D, GridOptions(cells_per_d=2))
    started = intruder_speed("local_mu_i", geo, LOCAL, rod, 8 * D, GridOptions(cells_per_d=2), warm=other)
    assert other.state["u"].size != cold.state["u"].size
    assert started.speed == cold.speed and started.iterations == cold.iterations


def test_a_stage_that_makes_no_progress_stops_at_the_stall_window(monkeypatch: pytest.MonkeyPatch) -> None:
    """A Newton stage whose residual does not halve in STALL_ITERATIONS iterations raises a
    ConvergenceError naming the stall after STALL_ITERATIONS + 1 residuals, not after MAX_NEWTON
    (a linear solve that returns no step: the residual stays where it is)."""
    from continuum.intruder import yield2d

    solver = CriticalStateRodSolver(GEO, CS, NARROW, None, GridOptions(cells_per_d=2), regularisations=(1e-1,))
    planar = solver.planar_solution()
    disc = solver._discretisation()
    evaluations = []
    real = solver._evaluate

    def counted(y, disc_, eps, jacobian):
        if jacobian:
            evaluations.append(eps)
        return real(y, disc_, eps, jacobian)

    monkeypatch.setattr(solver, "_evaluate", counted)
    monkeypatch.setattr(solver, "_linear_solve", lambda jac, rhs, res, eps: np.zeros_like(rhs))
    y0 = solver._initial(planar, disc)
    y0[: solver.grid.n_cells] *= 0.5  # far from the band's solution: a residual above the floor
    with pytest.raises(continuum.ConvergenceError, match="stalled"):
        solver._newton(y0, disc, 1e-1)
    assert len(evaluations) == yield2d.STALL_ITERATIONS + 1 < yield2d.MAX_NEWTON


def test_a_failed_solve_from_a_state_it_could_not_use_is_not_repeated(monkeypatch: pytest.MonkeyPatch) -> None:
    """A warm state the volume-averaged solver cannot carry onto its grid (it does not regrid)
    leaves the first attempt a cold one; when that fails (here forced: every Newton stage raises),
    the cold solve is not run a second time as if it had been a warm start's failure. The pushed
    rod's own solve runs once; what follows is the limit-load check's own solves (other solver
    objects)."""
    rod = RodIntruder.below_top(GEO, 3 * D, 6.5 * D, 100.0)
    solver = VolumeAveragedRodSolver(GEO, VA, LX, rod, GridOptions(cells_per_d=2))
    calls: list[object] = []
    real = VolumeAveragedRodSolver.solve_regularised

    def counted(self, warm=None):
        calls.append(self)
        return real(self, warm)

    def fails(self, y, disc, eps_rel, stall=True):
        raise continuum.ConvergenceError(self.model, 1.0, "forced", self.case)

    monkeypatch.setattr(VolumeAveragedRodSolver, "solve_regularised", counted)
    monkeypatch.setattr(VolumeAveragedRodSolver, "_newton", fails)
    other_grid = {k: np.zeros(7) for k in solver.state_keys} | {"grid": np.array([3.0, 5.0, 4 * D, 4 * D])}
    with pytest.raises(continuum.ConvergenceError):
        solver.solve(other_grid)
    assert sum(1 for c in calls if c is solver) == 1


def test_a_volume_averaged_draw_started_from_the_nominal_solution_is_the_cold_solution() -> None:
    """A parameter draw started from the nominal solution's last two regularisation stages
    converges, from that start and no cold restart (so the warm path is the one tested), to the
    draw's own cold solution: the answer does not depend on where Newton starts (to the stages'
    tolerance, a scaled residual of 1e-6: rel 1e-6 on U). The draw is benchmarks/intruder_solve.py's
    first (seed 43: mu_s +0.2 error, l -2 errors); a larger change (mu_s 0.377, l 1.22 d) is no
    start there and falls back to the cold solve. 2 cells per d, the rod 3 d at 7 d under the wall at
    half the 5 d yield force."""
    # the default's yield force at 5 d: F_y = 1.5 p D, p hydrostatic with nu 0.6 (pipeline/dem/intruder_run.py)
    yield_force = 1.5 * (GEO.wall_pressure + 0.6 * GEO.rho_s * GEO.gravity * 5 * D) * 3 * D
    rod = RodIntruder.below_top(GEO, 3 * D, 6.5 * D, 0.5 * yield_force)
    nominal = VolumeAveragedRodSolver(GEO, VA, LX, rod, GridOptions(cells_per_d=2)).solve()
    draw = VolumeAveragedParameters(CriticalStateParameters(0.37468, CriticalStateLine(0.5868, 0.005, 300.0)), 1.0455 * D)
    starts: list[bool] = []
    warm_solver = VolumeAveragedRodSolver(GEO, draw, LX, rod, GridOptions(cells_per_d=2))
    real = warm_solver.solve_regularised
    warm_solver.solve_regularised = lambda warm=None: starts.append(warm is not None) or real(warm)  # type: ignore[method-assign]
    warm = warm_solver.solve(nominal.state)
    cold = VolumeAveragedRodSolver(GEO, draw, LX, rod, GridOptions(cells_per_d=2)).solve()
    assert starts == [True]
    assert warm.speed == pytest.approx(cold.speed, rel=1e-6)
    assert abs(warm.speed / nominal.speed - 1.0) > 1e-3  # the draw is another solution, not the nominal's
