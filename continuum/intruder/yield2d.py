"""The yield-stress models around the rod (local mu(I), critical state, volume-averaged), solved
by Newton's method on the framework's grid, with a viscoplastic regularisation taken to zero.

``YieldRodSolver`` is a ``framework.RodSolver``: it takes the framework's grid, rod, pressure
convention (pi with P_wall on the top wall, p = pi / normal_stress_ratio), planar far field and
output Dataset, and replaces the fixed-point iteration by Newton on the discrete equations of
``plastic2d`` (why: see that module). The regularisation eps (a rate, in units of V / d) is
lowered along ``regularisations``; each stage starts from the previous one's solution (a
continuation: the first stage is smooth, the last is the answer), and the rod speed of every
stage is kept, so the limit eps -> 0 is shown on the sequence (``speed_by_regularisation``).

Convergence, on every unknown: a stage ends when the largest scaled residual of every equation
(momentum over P_wall / d, continuity over V / d, the rod's force balance over P_wall d) is below
``RESIDUAL_TOL`` and the last Newton step moved every velocity and U by less than ``STEP_TOL`` V
and every pressure by less than ``STEP_TOL`` P_wall.
"""
from __future__ import annotations

import time
from abc import abstractmethod
from typing import Any

import numpy as np
import xarray as xr
from scipy.sparse.linalg import LinearOperator, gmres

from .. import solve as solve_planar
from ..errors import ConvergenceError, OutOfRangeError
from ..geometry import PlanarShear
from .flow import Flow, RodSolution
from .framework import P_FLOOR, RodSolver
from .mac import MacGrid
from .regrid import regrid_state, same_cell
from .plastic2d import Discretisation, PlasticLaw, Scales, averaging_operators, corner_xz, equations, fill_map, inside_rod
from .scene import GridOptions, RodIntruder
from . import sparse_lu
from .sparse_lu import SingularMatrixError, factorise

#: Largest scaled residual of a converged stage (equations scaled as in ``plastic2d.equations``;
#: momentum in P_wall / d as NGF's RESIDUAL_TOL, continuity in V / d). Round-off puts a floor
#: near 1e-8 on it where eta spans ten decades (regularisation 1e-5 V / d, 8 cells per d).
RESIDUAL_TOL = 1e-6
#: Largest Newton step of a converged stage, over V (velocities, U) and P_wall (pressure).
STEP_TOL = 1e-7
#: The regularisations eps d / V of the continuation; the last one is the reported solution.
REGULARISATIONS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5)
#: d ln U / d ln eps between the last two stages above which U is the creep of a rigid zone
#: (U proportional to eps): the model's speed is then 0, with U(last eps) kept as its bound.
RIGID_SLOPE = 0.9
#: Stages of a start from a solution on another grid (``regrid``): the interpolated state is
#: not a solution near the new staircase rod, so the continuation restarts where the law is
#: smoother than at the last two stages. Only for the local laws (l = 0): with the averaging
#: operator the interpolated rigid-zone rates set stresses far from balance (measured: the
#: volume-averaged model on a 14 d bed, 2 -> 3 cells per d, starts at a scaled residual 11 and its
#: rod runs away at eps = 1e-3 V/d; cold it converges), so the volume-averaged model's finer grid
#: starts cold.
REGRID_STAGES = 3
#: Largest change of any velocity (the rod's included) in one Newton step, over V: the trust
#: region of ``_newton``. Measured (2026-12-05) on the volume-averaged rod of the reduced run's
#: 6.76 d scene: without it a Newton step at eps = 1.8e-5 V/d threw U from 0.097 m/s to 4e3 m/s
#: (a false "runaway"); with it the solve converges (U = 0.0982 m/s, 98 Newton iterations). On
#: the default's bed (21.6 d, cell 12 d, the issue's calibration) at 7 d and 0.9 F_y, where Newton
#: failed at eps = 0.1 V/d without it, it converges: U = 0.0980 m/s, 19 CPU s.
MAX_VELOCITY_STEP = 0.5
#: Newton iterations allowed per stage.
MAX_NEWTON = 60
#: A stage stalls when its residual's 2-norm has not fallen by ``STALL_FACTOR`` within the last
#: ``STALL_ITERATIONS`` Newton iterations while still above ``STALL_FLOOR`` (scaled units): it then
#: fails at once, and the continuation halves its step in log eps (``_refine_stage``) or restarts
#: cold, instead of spending MAX_NEWTON iterations on it. Measured on the default's beds
#: (2026-12-05, residual histories of every stage of critical state at 5 d and mu(I) at 9 d, 3 and
#: 4 cells per d): every stage that converged fell by 0.3 decade or more in any 12 iterations
#: before its quadratic phase but one (mu(I) at 9 d, 4 cells/d, eps 1e-5 V/d: 60 iterations, flat
#: for 40 of them, which the halved step reaches in about 20); the stages that failed sat within
#: 0.1 decade for their last 30-50 of 60 iterations.
STALL_ITERATIONS = 12
STALL_FACTOR = 0.5
STALL_FLOOR = 1e-4
#: |U| / V beyond which a Newton iterate is taken as a rod with no steady state (runaway).
RUNAWAY = 1e3
#: Relative residual a freshly factorised Newton step may leave: the inexact-Newton forcing term,
#: min(this, the scaled residual), as GMRES's (``sparse_lu`` refines a perturbed factor's solve to
#: it, or refuses: a singular Jacobian).
_NEWTON_SOLVE_CHECK = 1e-2
#: GMRES iterations (one restart cycle) before the Jacobian is factorised anew.
_GMRES_ITERATIONS = 30
#: A stage's first Newton step factorises its Jacobian at once: the last stage's LU (eps ten
#: times larger) preconditions it too poorly (measured: GMRES failed all 30 iterations at the
#: first step of every stage after the first, on the default's volume-averaged and
#: critical-state solves).
FRESH_LU_PER_STAGE = True


class RunawayError(ConvergenceError):
    """The rod's speed grows without bound: no steady state balances its push."""


class YieldRodSolver(RodSolver):
    """Steady yield-stress flow around the rod (``plastic2d.PlasticLaw`` of the model).

    Args (besides ``RodSolver``'s):
        regularisations: the eps d / V sequence (decreasing); the last is the solution's.
        rod_speed: if given, the rod is driven at this speed (m s-1) and the force it needs is
            computed (``attrs["rod_force"]``) instead of U from a given force.
    """

    def __init__(self, geometry: PlanarShear, params: Any, cell_length_x: float, rod: RodIntruder | None,
                 options: GridOptions = GridOptions(), case: str | None = None,
                 regularisations: tuple[float, ...] = REGULARISATIONS, rod_speed: float | None = None) -> None:
        super().__init__(geometry, params, cell_length_x, rod, options, case)
        if not regularisations or any(e <= 0.0 for e in regularisations):
            raise ValueError(f"regularisations must be positive, got {regularisations!r}")
        self.regularisations = tuple(regularisations)
        self.driven_speed = rod_speed
        self._planar: xr.Dataset | None = None
        self._lu = None
        self._lu_eps = None  # the regularisation of the Jacobian ``_lu`` factorises
        self.factorisations = 0
        self.last_limit_load: dict[str, float] = {}  # set when ``solve`` computed the limit load
        self._force_fraction = 1.0
        self._started_warm = False  # whether the last solve_regularised started from a warm state

    # ---- the model's law ------------------------------------------------------------------
    @property
    @abstractmethod
    def law(self) -> PlasticLaw:
        """The model's yield-stress law."""

    def planar_solution(self) -> xr.Dataset:
        if self._planar is None:
            self._planar = solve_planar(self.model, self.geometry, self.params, n_grid=8 * self.grid.nz + 1,
                                        case=self.case)
        return self._planar

    def bulk_density(self, fields: dict[str, np.ndarray]) -> np.ndarray:
        """rho_s nu with nu of the planar solution at the cell's height (the rod's change of the
        packing is left out: for mu(I) it is a I ~ 1e-4 at the rod's creeping I)."""
        planar = self.planar_solution()
        return self.geometry.rho_s * np.interp(self.z_cells, planar.z.values, planar.nu.values)

    # The fixed-point hooks of the framework, kept so the secant iteration can be compared
    # (``RodSolver.solve`` of the base class); ``solve`` below does not use them.
    def initial_fields(self, planar: xr.Dataset) -> dict[str, np.ndarray]:
        rate = np.interp(self.z_cells, planar.z.values, np.gradient(planar.u_x.values, planar.z.values))
        return {"ln_rate": np.log(np.maximum(np.abs(rate), 1e-12 * self.geometry.wall_speed / self.geometry.d))}

    @property
    def field_tolerances(self) -> dict[str, float]:
        return {"ln_rate": self.options.tolerance}

    def viscosity(self, fields: dict[str, np.ndarray], p: np.ndarray) -> np.ndarray:
        eps = self.regularisations[-1] * self.geometry.wall_speed / self.geometry.d
        return self.law.viscosity(np.exp(fields["ln_rate"]), p, eps, self.geometry.d, self.geometry.rho_s)[0]

    def update(self, flow: Flow, fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        floor = 1e-12 * self.geometry.wall_speed / self.geometry.d
        return {"ln_rate": np.log(np.maximum(flow.shear_rate, floor))}

    # ---- Newton -------------------------------------------------------------------------------
    def _discretisation(self) -> Discretisation:
        grid, rod = self.grid, self.rod
        centre = None if rod is None else (0.5 * self.cell_length_x, rod.depth_from_bottom)
        radius = 0.0 if rod is None else rod.radius
        xk, zk = corner_xz(grid)
        solid_k = inside_rod(xk, zk, grid, centre, radius)
        m_c, m_k = averaging_operators(grid, self.mask.solid_cells, solid_k, self.law.length)
        rho = self.bulk_density({}).reshape(grid.nz, grid.nx)
        body = self.geometry.gravity * 0.5 * (rho[1:] + rho[:-1]).ravel()
        return Discretisation(grid, self.ops, self.mask, m_c, m_k, fill_map(grid, self.mask.solid_cells), body,
                              rod is not None)

    def _initial(self, planar: xr.Dataset, disc: Discretisation) -> np.ndarray:
        grid, geo = self.grid, self.geometry
        nc, nw = grid.n_cells, grid.n_w
        y = np.zeros(disc.n)
        zu = np.repeat(grid.z_centres, grid.nx)
        u = np.interp(zu, planar.z.values, planar.u_x.values)
        pi = geo.normal_stress_ratio * np.interp(self.z_cells, planar.z.values, planar.p.values)
        y[:nc], y[nc + nw:2 * nc + nw] = u, pi
        if self.rod is not None:
            U = float(np.interp(self.rod.depth_from_bottom, planar.z.values, planar.u_x.values))
            if self.driven_speed is not None:
                U = self.driven_speed
            y[:nc][self.mask.u_faces] = U
            y[nc + nw:2 * nc + nw][self.mask.pinned_cells] = 0.0
            y[-1] = U
        return y

    #: The model's discrete equations, with ``plastic2d.equations``' signature (law: ``residual_law``).
    equations_of = staticmethod(equations)

    @property
    def residual_law(self) -> Any:
        """The law ``equations_of`` takes (the yield-stress models: ``law``)."""
        return self.law

    def _evaluate(self, y: np.ndarray, disc: Discretisation, eps_rel: float, jacobian: bool) -> dict:
        geo = self.geometry
        force = None if self.rod is None else self.rod.force_per_length * self._force_fraction
        return self.equations_of(y, disc, self.residual_law, eps_rel * geo.wall_speed / geo.d, geo.wall_speed, force,
                         self.driven_speed, geo.normal_stress_ratio, P_FLOOR * self.top_pressure, geo.rho_s,
                         Scales(geo.wall_speed, geo.wall_pressure, geo.d), jacobian=jacobian)

    #: The entries of a solution's ``state`` that make its unknown vector (``_state``, ``_vector``).
    state_keys: tuple[str, ...] = ("u", "w", "pi", "U")

    @property
    def regrids(self) -> bool:
        """Whether a state on another grid of the cell is carried onto this one (``REGRID_STAGES``)."""
        return self.law.length == 0.0

    def _state(self, y: np.ndarray, disc: Discretisation) -> dict[str, np.ndarray]:
        """The unknown vector as named fields (the first entry has the cells' size: the registry's
        warm-start check)."""
        nc, nw = self.grid.n_cells, self.grid.n_w
        return {"u": y[:nc].copy(), "w": y[nc:nc + nw].copy(), "pi": y[nc + nw:2 * nc + nw].copy(),
                "U": np.array([y[-1] if disc.has_rod else np.nan])}

    def _vector(self, state: dict[str, np.ndarray], disc: Discretisation) -> np.ndarray:
        """The unknown vector of a ``_state`` on this grid."""
        return np.concatenate([state["u"], state["w"], state["pi"], state["U"][:1] if disc.has_rod else []])

    def _step_scale(self, disc: Discretisation) -> np.ndarray:
        g, geo = self.grid, self.geometry
        s = np.concatenate([np.full(g.n_cells + g.n_w, geo.wall_speed), np.full(g.n_cells, geo.wall_pressure)])
        return np.append(s, geo.wall_speed) if disc.has_rod else s

    def _linear_solve(self, jac, rhs: np.ndarray, res: float, eps_rel: float) -> np.ndarray:
        """Newton step: GMRES preconditioned by the last LU factorisation of the Jacobian (an
        inexact Newton step, forcing term min(1e-2, |r|)); a new factorisation when GMRES does not
        converge in ``_GMRES_ITERATIONS`` (the LU costs ~10-50 GMRES iterations)."""
        if self._lu is not None and (self._lu_eps == eps_rel or not FRESH_LU_PER_STAGE):
            apply = self._lu.precondition if sparse_lu.PRECONDITION_UNREFINED else self._lu.solve
            op = LinearOperator(jac.shape, matvec=apply, dtype=jac.dtype)
            dy, info = gmres(jac, rhs, M=op, rtol=min(1e-2, max(res, 1e-12)), atol=0.0,
                             restart=_GMRES_ITERATIONS, maxiter=1)
            if info == 0:
                return dy
        try:
            # the previous LU is replaced: its PARDISO analysis serves this Jacobian's pattern
            self._lu = factorise(jac, reuse=self._lu)
            self._lu_eps = eps_rel
        except SingularMatrixError as exc:
            raise ConvergenceError(self.model, res, f"Newton: singular Jacobian at eps = {eps_rel:g} V/d ({exc})",
                                   self.case) from exc
        self.factorisations += 1
        try:
            return self._lu.solve(rhs, check=min(_NEWTON_SOLVE_CHECK, max(res, 1e-12)))
        except SingularMatrixError as exc:
            raise ConvergenceError(self.model, res, f"Newton: singular Jacobian at eps = {eps_rel:g} V/d ({exc})",
                                   self.case) from exc

    def _newton(self, y: np.ndarray, disc: Discretisation, eps_rel: float,
                stall: bool = True) -> tuple[np.ndarray, int, float, float]:
        """One stage: Newton with a backtracking line search on the residual's 2-norm; with
        ``stall``, a stage that stalls (``STALL_ITERATIONS``) fails at once."""
        scale = self._step_scale(disc)
        g = self.grid
        velocity = np.zeros(disc.n, bool)
        velocity[:g.n_cells + g.n_w] = True
        velocity[-1] = disc.has_rod
        step = np.inf
        ev = self._evaluate(y, disc, eps_rel, True)
        best: list[float] = []  # the smallest residual 2-norm reached by each iteration
        for it in range(1, MAX_NEWTON + 1):
            r = ev["residual"]
            res = float(np.max(np.abs(r)))
            if res < RESIDUAL_TOL and step < STEP_TOL:
                return y, it - 1, res, step
            norm0 = float(np.linalg.norm(r))
            best.append(min(norm0, best[-1] if best else np.inf))
            if (stall and len(best) > STALL_ITERATIONS and best[-1] > STALL_FLOOR
                    and best[-1] > STALL_FACTOR * best[-1 - STALL_ITERATIONS]):
                raise ConvergenceError(self.model, res, f"Newton stalled at eps = {eps_rel:g} V/d (residual norm "
                                       f"{best[-1]:.2g}, not halved in {STALL_ITERATIONS} iterations)", self.case)
            dy = self._linear_solve(ev["jacobian"], -r, res, eps_rel)
            # A trust region on the velocities (the rod's included): at small eps the Jacobian of
            # a rod carried near V is so ill-conditioned that a full step can throw U to 1e3 V
            # while the residual, bounded by the yield stress, still falls.
            moved = float(np.max(np.abs(dy[velocity]))) / self.geometry.wall_speed
            lam = min(1.0, MAX_VELOCITY_STEP / moved) if moved > 0.0 else 1.0
            while True:
                trial = y + lam * dy
                try:
                    with np.errstate(over="raise", invalid="raise"):
                        norm = float(np.linalg.norm(self._evaluate(trial, disc, eps_rel, False)["residual"]))
                except FloatingPointError:
                    norm = np.inf  # a step so large the stresses overflow: shorten it
                if norm <= (1.0 - 1e-4 * lam) * norm0:
                    break
                if lam < 1.0 / 512:
                    if not np.isfinite(norm):
                        raise RunawayError(self.model, res, f"Newton steps overflow at eps = {eps_rel:g} V/d "
                                           "(the rod runs away)", self.case)
                    break
                lam *= 0.5
            y = trial
            step = float(np.max(np.abs(lam * dy) / scale))
            if disc.has_rod and abs(y[-1]) > RUNAWAY * self.geometry.wall_speed:
                raise RunawayError(self.model, res, f"the rod runs away (U = {y[-1]:.3g} m/s at eps = {eps_rel:g} V/d): "
                                   "no steady state balances its push", self.case)
            ev = self._evaluate(y, disc, eps_rel, True)
        res = float(np.max(np.abs(ev["residual"])))
        if res < RESIDUAL_TOL and step < STEP_TOL:
            return y, MAX_NEWTON, res, step
        raise ConvergenceError(self.model, res, f"Newton not converged in {MAX_NEWTON} iterations at eps = "
                               f"{eps_rel:g} V/d (last step {step:.2g})", self.case)

    def _start(self, warm: dict[str, np.ndarray] | None, planar: xr.Dataset,
               disc: Discretisation) -> tuple[np.ndarray, tuple[float, ...]]:
        """The first iterate and the regularisation stages to run: from ``warm`` on this grid (the
        last two stages), from ``warm`` carried from another grid of the same cell (the local laws:
        the last ``REGRID_STAGES``), else from the planar solution (every stage)."""
        stages = self.regularisations
        usable = warm is not None and set(warm) >= set(self.state_keys)
        if usable and warm["u"].size != self.grid.n_cells:
            if "grid" not in warm or not self.regrids or not same_cell(warm["grid"], self.grid):
                return self._initial(planar, disc), stages
            nx, nz, hx, hz = warm["grid"]
            warm = regrid_state(warm, MacGrid(int(nx), int(nz), float(hx), float(hz)), self.grid,
                                self.geometry.wall_speed, self.ops.slip_length)
            first = max(len(stages) - REGRID_STAGES, 0)
        elif usable:
            first = max(len(stages) - 2, 0)  # two stages: the limit is read from their U
            previous = warm.get("y_previous_stage")
            if previous is not None and previous.size == disc.n and first < len(stages) - 1:
                # the warm solution's own state at this first stage's eps: the draw's first stage
                # then starts at its own regularisation, not from the sharper last one
                return previous.copy(), stages[first:]
        else:
            return self._initial(planar, disc), stages
        return self._vector(warm, disc), stages[first:]

    @np.errstate(under="ignore")  # products of the rigid zones' tiny rates underflow harmlessly
    def solve_regularised(self, warm: dict[str, np.ndarray] | None = None) -> RodSolution:
        """Converged solution at the last regularisation, with the rod speed at every stage.
        ``warm`` is a previous solution's ``state`` on the same grid (the continuation then starts
        at the last two regularisations, whose speeds give the limit)."""
        t0 = time.perf_counter()
        t1 = time.perf_counter()
        planar = self.planar_solution()
        planar_seconds = time.perf_counter() - t1
        disc = self._discretisation()
        y, stages = self._start(warm, planar, disc)
        started_warm = len(stages) < len(self.regularisations)
        self._started_warm = started_warm
        by_eps: dict[float, float] = {}
        iterations, res, step = 0, np.nan, np.nan
        y_last = y_previous = y
        for k, eps_rel in enumerate(stages):
            try:
                # The stall rule only where a failure has a cheaper way on (a halved eps step, or a
                # cold restart after a warm start): a cold start's first stage may walk far under
                # the trust region (the reduced run's volume-averaged rod at 6.76 d: 98 iterations
                # from a residual norm of 83, which the rule would refuse).
                y, its, res, step = self._newton(y, disc, eps_rel, stall=k > 0 or started_warm)
            except RunawayError:
                raise
            except ConvergenceError:
                if k > 0:
                    # a stage too far from the last: halve the step in log eps (twice at most)
                    y, its, res, step = self._refine_stage(y_last, disc, stages[k - 1], eps_rel, 2)
                    iterations += its
                    by_eps[eps_rel] = float(y[-1]) if disc.has_rod else float("nan")
                    y_previous, y_last = y_last, y
                    continue
                if not disc.has_rod or self.driven_speed is not None or started_warm:
                    raise  # (a warm start's failure: the caller restarts cold, no ramp in F from a guess)
                # a push far from the planar start: reach it in steps of a quarter of F
                its = 0
                for fraction in (0.25, 0.5, 0.75, 1.0):
                    self._force_fraction = fraction
                    y, n, res, step = self._newton(y, disc, eps_rel, stall=False)
                    its += n
            iterations += its
            by_eps[eps_rel] = float(y[-1]) if disc.has_rod else float("nan")
            y_previous, y_last = y_last, y
        ev = self._evaluate(y, disc, stages[-1], False)
        flow = self._flow(y, ev, disc)
        p_min = float(flow.p[self.material].min())
        if p_min < P_FLOOR * self.top_pressure:
            raise OutOfRangeError(self.model, f"pressure {p_min:.3g} Pa next to the rod: the bed opens in tension",
                                  self.case)
        speed = flow.rod_speed
        if disc.has_rod and len(by_eps) >= 2:
            (e1, u1), (e2, u2) = list(by_eps.items())[-2:]
            slope = float(np.log(abs(u1) / abs(u2)) / np.log(e1 / e2)) if u1 * u2 > 0.0 else float("nan")
            rigid = bool(slope >= RIGID_SLOPE)
            if rigid:
                speed = 0.0
        else:
            slope, rigid = float("nan"), False
        residuals = {"residual": res, "residual_over_tol": res / RESIDUAL_TOL, "step": step,
                     "step_over_tol": step / STEP_TOL}
        attrs = {"tau_top": flow.tau_top, "p_min": p_min, "mu_max": float(flow.mu[self.material].max()),
                 "nx": self.grid.nx, "nz": self.grid.nz, "regularisation": stages[-1],
                 "top_wall_slip": self.top_wall_slip(flow),
                 "rod_force": float(-ev["rod_force"]) if disc.has_rod else float("nan"),
                 # the rate-independent models have no linear response to report
                 "drift_speed": float("nan"), "mobility": float("nan"),
                 # the limit eps -> 0: slope d ln U / d ln eps of the last two stages, and whether
                 # it says U is a rigid zone's creep (speed 0, U(last eps) its upper bound)
                 "regularisation_slope": slope, "rigid_in_limit": int(rigid),
                 "speed_bound": float(flow.rod_speed)}
        attrs.update({f"speed_at_eps_{e:.0e}": v for e, v in by_eps.items()})
        state = self._state(y, disc)
        state["grid"] = np.array([self.grid.nx, self.grid.nz, self.grid.hx, self.grid.hz])
        if len(stages) >= 2:
            state["y_previous_stage"] = y_previous.copy()  # the solution at stages[-2] (warm starts)
        return RodSolution(self.model, speed, True, iterations, residuals, time.perf_counter() - t0,
                           self.grid.n_cells, flow, state, self._dataset(flow, {}), planar, planar_seconds, attrs)

    def _reach(self, y: np.ndarray, disc: Discretisation, eps_from: float, eps_to: float,
               depth: int) -> tuple[np.ndarray, int, float, float]:
        """Newton at ``eps_to`` from a solution at ``eps_from``; on a ConvergenceError (not a runaway
        rod) through the geometric midpoint, ``depth`` times at most."""
        try:
            # the last halving runs without the stall rule: nothing cheaper is left after it
            return self._newton(y, disc, eps_to, stall=depth > 1)
        except RunawayError:
            raise
        except ConvergenceError:
            if depth <= 1:
                raise
            return self._refine_stage(y, disc, eps_from, eps_to, depth - 1)

    def _refine_stage(self, y: np.ndarray, disc: Discretisation, eps_from: float, eps_to: float,
                      depth: int) -> tuple[np.ndarray, int, float, float]:
        """Reach ``eps_to`` from a solution at ``eps_from`` through sqrt(eps_from eps_to)."""
        mid = float(np.sqrt(eps_from * eps_to))
        y_mid, n1, _, _ = self._reach(y, disc, eps_from, mid, depth)
        y_end, n2, res, step = self._reach(y_mid, disc, mid, eps_to, depth)
        return y_end, n1 + n2, res, step

    def limit_load(self, speeds_over_v: tuple[float, ...] = (3.0, 10.0)) -> dict[str, float]:
        """The force per length (N m-1) the material resists the rod with when the rod is driven
        at each of ``speeds_over_v`` x V (the rate-independent laws: the limit load once the rod
        outruns the wall, F(U) rising to it as U / V grows; the regularisation of this solver's
        last stage). Keys ``limit_force_<k>V``."""
        out = {}
        for k in speeds_over_v:
            driven = type(self)(self.geometry, self.params, self.cell_length_x, self.rod, self.options, self.case,
                                self.regularisations, rod_speed=k * self.geometry.wall_speed)
            out[f"limit_force_{k:g}V"] = float(driven.solve_regularised().attrs["rod_force"])
        return out

    def _solve_warm_then_cold(self, warm: dict[str, np.ndarray] | None) -> RodSolution:
        """``solve_regularised`` from ``warm``; if that fails, once more from the planar start (a
        warm start is a guess: its failure says nothing of the model)."""
        if warm is None:
            return self.solve_regularised(None)
        try:
            return self.solve_regularised(warm)
        except ConvergenceError:
            if not self._started_warm:
                # the state could not start this grid (another cell, or a model that does not
                # regrid), so that attempt was already the cold one: the same solve again would fail
                # the same way (measured: the volume-averaged model's 6-cells/d grid study solved
                # its failing cold continuation twice, 10 CPU minutes each)
                raise
            self._force_fraction = 1.0
            return self.solve_regularised(None)

    def solve(self, warm: dict[str, np.ndarray] | None = None, limit_load: bool = True) -> RodSolution:
        """``solve_regularised``; where a rod under a given push finds no steady state (it runs
        away, or Newton fails), the limit load is computed (``limit_load``) and, if the push
        exceeds it, ``OutOfRangeError`` reports it as a number (the model's answer: the rod
        fails). A failure below the computed limit load stays a ``ConvergenceError``.
        With ``limit_load`` False every failure stays a ``ConvergenceError`` and no limit load
        is computed (two driven solves, as long as a failed solve: for a caller that only needs
        whether there is a speed, e.g. a parameter draw)."""
        try:
            return self._solve_warm_then_cold(warm)
        except ConvergenceError as exc:
            if (not limit_load or self.rod is None or self.driven_speed is not None
                    or self.law.mu_i is not None):
                raise  # (mu(I) is rate-dependent: no limit load; its failures are failures)
            loads = self.limit_load()
            self.last_limit_load = loads
            f_lim = max(loads.values())
            if self.rod.force_per_length > f_lim:
                raise OutOfRangeError(self.model, f"the rod fails: push F = {self.rod.force_per_length:.4g} N/m is "
                                      f"above the 2D limit load {f_lim:.4g} N/m (force resisted with the rod driven at "
                                      f"3 V, 10 V: {', '.join(f'{v:.4g}' for v in loads.values())} N/m)",
                                      self.case) from exc
            raise

    def _flow(self, y: np.ndarray, ev: dict, disc: Discretisation) -> Flow:
        """The framework's ``Flow`` of a Newton state (for its Dataset and diagnostics)."""
        g, ops = self.grid, self.ops
        nc, nw, nx, nz = g.n_cells, g.n_w, g.nx, g.nz
        u, w, pi = y[:nc], y[nc:nc + nw], y[nc + nw:2 * nc + nw]
        V = self.geometry.wall_speed
        gam_k = ops.dzu @ u + ops.lift_top * V + ops.dxw @ w
        d_xx = ops.dxu @ u
        d_xz = ops.centre_from_corners @ (0.5 * gam_k)
        s_xx = ev["t_xx"]
        s_xz = ops.centre_from_corners @ ev["t_xz_k"]
        tau = np.hypot(s_xx, s_xz)
        return Flow(u=u, w=w, pi=pi, p=ev["p"], p_eff=ev["p_eff"], d_xx=d_xx, d_xz=d_xz,
                    shear_rate=2.0 * np.hypot(d_xx, d_xz), s_xx=s_xx, s_xz=s_xz, tau=tau, mu=tau / ev["p_eff"],
                    eta=ev["eta_c"], d_xz_corners=0.5 * gam_k, s_xz_corners=ev["t_xz_k"], top_speed=V,
                    rod_speed=float(y[-1]) if disc.has_rod else float("nan"),
                    tau_top=float(ev["t_xz_k"][nz * nx:].mean()), rod_force_parts=None, x=y, system=None,
                    rhs_load=None)
