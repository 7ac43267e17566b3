"""One 2D steady solver around the rod that every model plugs into (issue 43).

The framework owns the mechanics; a model owns its constitutive law.

Mechanics (framework): the Stokes-type momentum balance on the periodic MAC cell of ``mac.py``
(x periodic with period L_x, rigid rough walls at z = 0 at rest and z = H moving at V along +x,
with the Navier slip of ``PlanarShear.slip_length`` b at both, u = V - b du/dz at the top and
u = b du/dz at the bottom (``mac.build_operators``; b = 0 is no slip), gravity along -z,
compressive-positive stresses)::

    div(2 eta D + S) - grad(pi) - rho g e_z = 0,     div u = 0,

with a secant viscosity ``eta`` (Pa s) and an optional explicit (lagged) extra stress ``S``
(tensile-positive, Pa) supplied by the model, and the rigid rod translating at the speed U that
balances its push F: F + (force of the material on the rod) = 0. For each viscosity field the
problem is linear, so one factorisation is solved for three right-hand sides (weight and S with
walls and rod at rest; top wall at unit speed; rod at unit speed) and superposed with the top wall
at V and U from the rod's force balance.

One pressure convention for 1D and 2D: ``pi`` is the in-plane mean normal stress of the Stokes
problem, equal to sigma_zz in planar flow (the momentum balance fixes it: P_wall at the top, plus
the weight); the pressure the constitutive laws see is ``p = pi / normal_stress_ratio``, exactly
as the 1D solves use ``p = sigma_zz / normal_stress_ratio`` (``continuum.geometry.PlanarShear``).
Near the rod the ratio sigma_zz / p is taken as the far field's (the models have no normal-stress
law of their own).

The outer nonlinear iteration (framework): the unknowns are the model's own fields (its
``field_tolerances`` keys, e.g. ln g for NGF) and the pressure p (scaled by the far-field p at
each height). One evaluation of the fixed-point map G is: viscosity from the fields and p ->
Stokes solve -> the model's update of its fields from the flow, and p from the flow. The root of
(G(X) - X) / tolerance is found by ``scipy.optimize.anderson`` (Anderson mixing, depth
``GridOptions.anderson_depth``, damping ``GridOptions.relaxation``); a model may limit the step
of a field (``step_limits``: G(X) - X is clipped, which leaves the fixed points unchanged).
Why Anderson: the map is cheap to evaluate (one sparse LU of the Stokes system) but contracts
slowly or not at all along a few global modes (the wall-driven shear stress against the fluidity
level; the stress concentrations at the staircase rod), which Anderson's short history removes;
Newton-Krylov needs several map evaluations per Krylov step for the same effect.

Convergence, on every unknown: after the accelerated iteration reports that every field and p
changes under one more application of G by less than its tolerance, one more plain step
(X -> G(X)) is taken and must move every field, p (relative to the local far-field p), every
velocity (relative to its own size, down to ``VELOCITY_FLOOR`` V) and the rod speed (relative to
|U|) by less than its tolerance; otherwise the iteration resumes from there with a ten times smaller tolerance on the fields and p (at
most ``_ROUNDS`` times) before ``ConvergenceError``.

How a model plugs in: subclass ``RodSolver`` and implement

- ``model`` (class attribute): the contract model name (``"ngf"``, ``"local_mu_i"``...).
- ``planar_solution()`` -> xr.Dataset: the model's own 1D planar solution of the cell without
  the rod, with ``z`` (m), ``u_x`` (m s-1) and ``p`` (Pa, the 1D convention above). It gives the
  far-field p and the first iterate (the solution without the rod must be reproduced in 2D).
- ``bulk_density(fields)`` -> float or array on the cells (kg m-3): rho_s nu, the weight's density.
- ``initial_fields(planar)`` -> dict name -> array on the cells (flat, index j * nx + i).
- ``field_tolerances`` -> dict name -> absolute tolerance on that field's change (its own units,
  e.g. 1e-4 on ln g: 0.01 % in the fluidity).
- ``viscosity(fields, p)`` -> array on the cells (Pa s): the secant viscosity eta = tau / shear
  rate for the current fields and pressure p (Pa, floored at ``P_FLOOR`` x the top p).
- ``update(flow, fields)`` -> dict name -> array on the cells: the constitutive update, the new
  value of each field given the Stokes solution ``flow`` (a ``Flow``: velocities, strain rates,
  stresses, pressure, rod and wall speeds, all on the grid).

and optionally

- ``explicit_stress(fields, p)`` -> ``ExtraStress`` or None: a lagged stress added to the
  momentum balance (for higher-gradient or couple-stress terms the viscosity cannot carry).
- ``step_limits`` -> dict name -> largest change of that field in one step.
- ``output_fields(flow, fields)`` -> dict name -> (array on the cells, units, long_name), added
  to the solution's Dataset.
- ``check(flow, fields)``: raise ``OutOfRangeError`` for a converged state the model refuses.
- ``wall_slip_length`` -> float: the walls' Navier slip length (default ``geometry.slip_length``;
  0 for a model whose wall layer is a band of zero width, where the band is the slip).

Solid (rod) cells: the framework fills every field and p there with the nearest material cell's
value after each update (only corner averages next to the rod surface see them); tolerances are
tested on material cells only.
"""
from __future__ import annotations

import time
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np
import xarray as xr
from scipy.optimize import anderson
from scipy.optimize import NoConvergence

from ..errors import ConvergenceError, OutOfRangeError
from ..geometry import PlanarShear
from .flow import ExtraStress, Flow, RodSolution, fill_solid
from .mac import MacGrid, RodMask, assemble, build_operators, rod_mask
from .scene import GridOptions, RodIntruder

#: Floor on p in the constitutive laws, as a fraction of the top pressure. A granular bed carries
#: no tension; early iterates can dip below it next to the rod. A converged state that still needs
#: it is refused (``OutOfRangeError``: the bed opens next to the rod).
P_FLOOR = 0.05
#: Velocities are compared relative to their own size down to this fraction of V (the DEM's
#: arrest bound for the rod, ``dem.precision.rod_arrest_speed_over_v``): slower is at rest.
VELOCITY_FLOOR = 1e-5
#: Plain-step checks after the accelerated iteration before giving up.
_ROUNDS = 4
#: The Anderson history of a solve's second attempt, over the first's. Measured (2026-12-05) on
#: the default's NGF draws (32 per scene, warm from the nominal solution, 3 cells per d): at 9 d
#: depth 5 left draw 27 unconverged in 400 evaluations, warm and cold, where depth 10 converged
#: in 91 (every draw there: median 30 evaluations against 31); at 7 d and 0.3 F_y depth 10 took
#: up to 294 where depth 5 took at most 73. Neither depth is better everywhere, so the deeper one
#: is the retry, not the default.
RETRY_DEPTH_FACTOR = 2


class RodSolver(ABC):
    """Steady 2D flow around the rod for one model (see the module docstring for how to plug in).

    Args:
        geometry: the planar cell (its ``normal_stress_ratio`` sets the pressure convention).
        params: the model's parameter object (``self.params``).
        cell_length_x: periodic length L_x (m).
        rod: the rod, or None for the cell without it (the 1D planar problem in 2D).
        options: grid and iteration controls.
        case: label used in error messages.
    """

    model: ClassVar[str] = ""

    def __init__(self, geometry: PlanarShear, params: Any, cell_length_x: float, rod: RodIntruder | None,
                 options: GridOptions = GridOptions(), case: str | None = None) -> None:
        if geometry.wall_speed <= 0.0:
            raise OutOfRangeError(self.model, "the 2D solve needs a moving top wall (V > 0)", case)
        if rod is not None:
            rod.check_inside(geometry, cell_length_x)
        self.geometry, self.params, self.rod, self.options, self.case = geometry, params, rod, options, case
        self.cell_length_x = cell_length_x
        nx, nz = options.counts(geometry, cell_length_x)
        self.grid = MacGrid(nx, nz, cell_length_x / nx, geometry.depth / nz)
        self.ops = build_operators(self.grid, self.wall_slip_length)
        self.mask: RodMask = rod_mask(self.grid, rod, 0.5 * cell_length_x)
        self.material = ~self.mask.solid_cells
        self.x_cells, self.z_cells = self.grid.cell_xz()
        self.evaluations = 0

    # ---- the model's part -------------------------------------------------------------------
    @abstractmethod
    def planar_solution(self) -> xr.Dataset:
        """The model's 1D planar solution of this cell (z, u_x, p)."""

    @abstractmethod
    def bulk_density(self, fields: dict[str, np.ndarray]) -> float | np.ndarray:
        """rho_s nu (kg m-3), scalar or on the cells."""

    @abstractmethod
    def initial_fields(self, planar: xr.Dataset) -> dict[str, np.ndarray]:
        """The model's fields on the cells from its planar solution."""

    @property
    @abstractmethod
    def field_tolerances(self) -> dict[str, float]:
        """Absolute tolerance on the change of each field in one plain step."""

    @abstractmethod
    def viscosity(self, fields: dict[str, np.ndarray], p: np.ndarray) -> np.ndarray:
        """Secant viscosity at the cells (Pa s)."""

    @abstractmethod
    def update(self, flow: Flow, fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """New value of every field from the flow."""

    def explicit_stress(self, fields: dict[str, np.ndarray], p: np.ndarray) -> ExtraStress | None:
        return None

    @property
    def step_limits(self) -> dict[str, float]:
        return {}

    def output_fields(self, flow: Flow, fields: dict[str, np.ndarray]) -> dict[str, tuple[np.ndarray, str, str]]:
        return {}

    def check(self, flow: Flow, fields: dict[str, np.ndarray]) -> None:
        return None

    @property
    def wall_slip_length(self) -> float:
        """The Navier slip length b (m) of the walls' condition: ``geometry.slip_length``. A model
        whose wall layer is a band of zero width (no finite wall shear rate) takes 0: the band is
        the slip and b changes nothing (``PlanarShear``)."""
        return self.geometry.slip_length

    # ---- the framework's part ---------------------------------------------------------------
    @property
    def top_pressure(self) -> float:
        """Model pressure under the top wall (Pa): P_wall / normal_stress_ratio."""
        return self.geometry.top_pressure

    def stokes(self, eta: np.ndarray, fields: dict[str, np.ndarray], p_eff: np.ndarray) -> Flow:
        """Solve the momentum balance for the viscosity ``eta`` with the top wall at V and the
        rod free under its push (see the module docstring)."""
        grid, ops, mask, geo = self.grid, self.ops, self.mask, self.geometry
        nc, nw, nx, nz = grid.n_cells, grid.n_w, grid.nx, grid.nz
        V = geo.wall_speed
        system = assemble(grid, ops, mask, eta)
        rho = np.broadcast_to(np.asarray(self.bulk_density(fields), dtype=float), (nc,))
        rho2 = rho.reshape(nz, nx)
        body = geo.gravity * 0.5 * (rho2[1:] + rho2[:-1]).ravel()  # at the interior w-faces
        b_load = system.unconstrained_rhs(0.0, body)
        extra = self.explicit_stress(fields, p_eff)
        if extra is not None:
            zx = extra.xz if extra.zx is None else extra.zx
            # div S at the faces; moved to the right-hand side
            b_load[:nc] -= -ops.dxu.T @ extra.xx + ops.kz @ extra.xz
            b_load[nc:nc + nw] -= -ops.dxw.T @ zx - ops.dzw.T @ extra.zz
        b_top = system.unconstrained_rhs(1.0, None)
        x_load = system.solve_rhs(b_load, 0.0)
        x_top = system.solve_rhs(b_top, 0.0)
        vol = grid.hx * grid.hz
        parts = None
        if self.rod is not None:
            x_rod = system.solve_rhs(np.zeros_like(b_top), 1.0)

            def force(x: np.ndarray, b: np.ndarray) -> float:
                return float(vol * (system.matrix @ x - b)[:nc][mask.u_faces].sum())

            parts = (force(x_load, b_load), force(x_top, b_top), force(x_rod, np.zeros_like(b_top)))
            rod_speed = -(self.rod.force_per_length + parts[0] + parts[1] * V) / parts[2]
            x = x_load + V * x_top + rod_speed * x_rod
        else:
            rod_speed = float("nan")
            x = x_load + V * x_top
        u, w, pi = system.split(x)
        pi = pi.copy()
        top_row = 1.5 * pi[(nz - 1) * nx:] - 0.5 * pi[(nz - 2) * nx:(nz - 1) * nx]
        pi += geo.wall_pressure - top_row.mean()  # the top wall carries P_wall on average (sigma_zz = pi there)
        pi = fill_solid(pi, mask.pinned_cells, grid)
        p = pi / geo.normal_stress_ratio
        p_eff = np.maximum(p, P_FLOOR * self.top_pressure)
        d_xx = ops.dxu @ u
        gam_k = ops.dzu @ u + ops.lift_top * V + ops.dxw @ w
        d_xz_k = 0.5 * gam_k
        s_xz_k = system.eta_corner * gam_k
        s_xx = 2.0 * eta * d_xx
        if extra is not None:
            s_xz_k = s_xz_k + extra.xz
            s_xx = s_xx + extra.xx
        d_xz = ops.centre_from_corners @ d_xz_k
        s_xz = ops.centre_from_corners @ s_xz_k
        tau = np.hypot(s_xx, s_xz)
        return Flow(u=u, w=w, pi=pi, p=p, p_eff=p_eff, d_xx=d_xx, d_xz=d_xz,
                    shear_rate=2.0 * np.hypot(d_xx, d_xz), s_xx=s_xx, s_xz=s_xz, tau=tau, mu=tau / p_eff,
                    eta=eta, d_xz_corners=d_xz_k, s_xz_corners=s_xz_k, top_speed=V, rod_speed=float(rod_speed),
                    tau_top=float(s_xz_k[nz * nx:].mean()), rod_force_parts=parts, x=x, system=system,
                    rhs_load=b_load)

    def top_wall_slip(self, flow: Flow) -> float:
        """V minus the grains' mean velocity along x in the top wall plane (m s-1): b times the
        wall's shear rate, averaged along the wall (0 for b = 0)."""
        _, top = self.ops.wall_velocities(flow.u, flow.top_speed, self.grid.nx)
        return float(flow.top_speed - top.mean())

    def _flow_of(self, fields: dict[str, np.ndarray], p: np.ndarray) -> Flow:
        self.evaluations += 1
        p_eff = np.maximum(p, P_FLOOR * self.top_pressure)
        return self.stokes(self.viscosity(fields, p_eff), fields, p_eff)

    def _step(self, fields: dict[str, np.ndarray], p: np.ndarray) -> tuple[Flow, dict[str, np.ndarray], np.ndarray]:
        """One application of G: the flow of (fields, p), the updated fields and p."""
        flow = self._flow_of(fields, p)
        new = self.update(flow, fields)
        new = {k: fill_solid(v, self.mask.solid_cells, self.grid) for k, v in new.items()}
        return flow, new, fill_solid(flow.p, self.mask.solid_cells, self.grid)

    def solve(self, warm: dict[str, np.ndarray] | None = None, limit_load: bool = True) -> RodSolution:
        """Converged steady solution; ``warm`` is a previous solution's ``state`` on the same
        grid (the iteration starts there instead of the planar solution). ``limit_load`` is the
        yield-stress solvers' (``yield2d``): a rate-dependent law has no limit load to compute.

        Where the iteration does not converge within ``max_iterations``, it is tried again
        (``RETRY_DEPTH_FACTOR``) from the same start with a deeper Anderson history, then from
        the planar solution (a warm start is a guess), the two depths each: only when every one
        fails is the failure the model's. Every attempt ends on the same convergence test, so a
        solution found by any of them is the model's; ``attrs`` say which (``start``,
        ``anderson_depth``). The first attempt is the plain one: a solve that converged before
        this rule gives the same numbers bit for bit."""
        depths = [self.options.anderson_depth]
        if self.options.anderson_depth > 0:
            depths.append(RETRY_DEPTH_FACTOR * self.options.anderson_depth)
        starts = [warm, None] if warm is not None else [None]
        failure: ConvergenceError | None = None
        for start in starts:
            for depth in depths:
                try:
                    return self._solve(start, depth)
                except ConvergenceError as exc:
                    failure = failure or exc  # the plain attempt's failure is the one reported
        assert failure is not None
        raise failure

    def _solve(self, warm: dict[str, np.ndarray] | None, anderson_depth: int) -> RodSolution:
        """``solve`` from one start (``warm``, or the planar solution) with one Anderson depth."""
        t0 = time.perf_counter()
        self.evaluations = 0
        opts, mat = self.options, self.material
        t1 = time.perf_counter()
        planar = self.planar_solution()
        planar_seconds = time.perf_counter() - t1
        p_far = np.interp(self.z_cells, planar.z.values, planar.p.values)
        names = list(self.field_tolerances)
        tol = self.field_tolerances
        if warm is not None:
            fields = {k: np.array(warm[k], dtype=float) for k in names}
            p = np.array(warm["p"], dtype=float)
        else:
            fields = self.initial_fields(planar)
            p = p_far.copy()
        n_mat = int(mat.sum())
        scale = np.concatenate([np.full(n_mat, tol[k]) for k in names] + [np.full(n_mat, opts.pressure_tolerance)])
        limits = np.concatenate([np.full(n_mat, self.step_limits.get(k, np.inf)) for k in names] + [np.full(n_mat, np.inf)])

        def pack(f: dict[str, np.ndarray], pp: np.ndarray) -> np.ndarray:
            return np.concatenate([f[k][mat] for k in names] + [pp[mat] / p_far[mat]]) / scale

        def unpack(y: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
            x = y * scale
            f = {}
            for i, k in enumerate(names):
                v = fields[k].copy()
                v[mat] = x[i * n_mat:(i + 1) * n_mat]
                f[k] = fill_solid(v, self.mask.solid_cells, self.grid)
            pp = p.copy()
            pp[mat] = x[len(names) * n_mat:] * p_far[mat]
            return f, fill_solid(pp, self.mask.solid_cells, self.grid)

        def residual(y: np.ndarray) -> np.ndarray:
            f, pp = unpack(y)
            _, f_new, p_new = self._step(f, pp)
            r = pack(f_new, p_new) - y
            return np.clip(r, -limits / scale, limits / scale)

        y = pack(fields, p)
        last: dict[str, float] = {}
        ok = False
        for round_ in range(_ROUNDS):
            # each round that fails the plain-step test asks ten times less of the fields and p
            f_tol = 10.0 ** -round_
            budget = opts.max_iterations - self.evaluations
            if budget <= 0:
                break
            if anderson_depth > 0:
                try:
                    # scipy's termination test divides by its (infinite) default x_rtol: inf / inf
                    # at the first check, harmless, but an error where floating-point errors raise
                    with np.errstate(invalid="ignore"):
                        y = anderson(residual, y, alpha=opts.relaxation, M=anderson_depth, f_tol=f_tol,
                                     maxiter=budget, line_search=None)
                except NoConvergence as exc:
                    y = np.asarray(exc.args[0])
                except (ValueError, FloatingPointError, np.linalg.LinAlgError):
                    break
            else:  # damped Picard, for comparison
                for _k in range(budget):
                    r = residual(y)
                    if np.max(np.abs(r)) < f_tol:
                        break
                    y = y + opts.relaxation * r
            # one plain step: every unknown must move by less than its tolerance
            f0, p0 = unpack(y)
            flow0, f1, p1 = self._step(f0, p0)
            flow1, _, _ = self._step(f1, p1)
            last = self._changes(names, f0, p0, flow0, f1, p1, flow1, p_far)
            fields, p = f1, p1
            y = pack(f1, p1)
            if all(v < 1.0 for k, v in last.items() if k.endswith("_over_tol")):
                ok = True
                break
        iterations = self.evaluations
        if not ok:
            worst = max(last.items(), key=lambda kv: kv[1] if kv[0].endswith("_over_tol") else -1)[0] if last else "-"
            raise ConvergenceError(self.model, float(max((v for k, v in last.items() if k.endswith("_over_tol")),
                                                          default=np.nan)),
                                   f"2D solve not converged in {iterations} map evaluations (worst: {worst})", self.case)
        flow = flow1
        p_min = float(flow.p[mat].min())
        if p_min < P_FLOOR * self.top_pressure:
            raise OutOfRangeError(self.model, f"pressure {p_min:.3g} Pa next to the rod: the bed opens in tension", self.case)
        self.check(flow, fields)
        state = {k: v.copy() for k, v in fields.items()}
        state["p"] = p.copy()
        ds = self._dataset(flow, fields)
        attrs = {"tau_top": flow.tau_top, "p_min": p_min, "mu_max": float(flow.mu[mat].max()),
                 "nx": self.grid.nx, "nz": self.grid.nz, "start": "warm" if warm is not None else "planar",
                 "anderson_depth": anderson_depth, "top_wall_slip": self.top_wall_slip(flow)}
        attrs.update(self._rod_outputs(flow))
        return RodSolution(self.model, flow.rod_speed, True, iterations, last, time.perf_counter() - t0,
                           self.grid.n_cells, flow, state, ds, planar, planar_seconds, attrs)

    def _changes(self, names: list[str], f0: dict, p0: np.ndarray, flow0: Flow, f1: dict, p1: np.ndarray,
                 flow1: Flow, p_far: np.ndarray) -> dict[str, float]:
        mat, opts, V = self.material, self.options, self.geometry.wall_speed
        out: dict[str, float] = {}
        for k in names:
            ch = float(np.max(np.abs(f1[k][mat] - f0[k][mat])))
            out[k] = ch
            out[k + "_over_tol"] = ch / self.field_tolerances[k]
        dp = float(np.max(np.abs(p1[mat] - p0[mat]) / p_far[mat]))
        out["p_rel"], out["p_over_tol"] = dp, dp / opts.pressure_tolerance
        fluid_u = ~self.mask.u_faces
        fluid_w = ~self.mask.w_faces
        floor = VELOCITY_FLOOR * V

        def rel(a: np.ndarray, b: np.ndarray) -> float:
            return float(np.max(np.abs(b - a) / (np.abs(b) + floor))) if a.size else 0.0

        du = max(rel(flow0.u[fluid_u], flow1.u[fluid_u]), rel(flow0.w[fluid_w], flow1.w[fluid_w]))
        out["velocity_rel"], out["velocity_over_tol"] = du, du / opts.velocity_tolerance
        if self.rod is not None:
            dU = abs(flow1.rod_speed - flow0.rod_speed) / max(abs(flow1.rod_speed), 1e-300)
            out["rod_speed_rel"], out["rod_speed_over_tol"] = dU, dU / opts.rod_speed_tolerance
        return out

    def _rod_outputs(self, flow: Flow) -> dict[str, float]:
        """Drift (U at F = 0), mobility dU/dF at the converged viscosity, vertical force and
        torque of the material on the rod (N m-1 along +z; N about +y)."""
        if self.rod is None:
            return {}
        grid, mask = self.grid, self.mask
        nc, nw, nx, nz = grid.n_cells, grid.n_w, grid.nx, grid.nz
        f_load, f_top, f_rod = flow.rod_force_parts
        vol = grid.hx * grid.hz
        r_all = flow.system.matrix @ flow.x - (flow.rhs_load + flow.system.unconstrained_rhs(flow.top_speed, None))
        r_u, r_w = r_all[:nc][mask.u_faces], r_all[nc:nc + nw][mask.w_faces]
        zu = np.repeat(grid.z_centres, nx)[mask.u_faces]
        xw = np.tile(grid.x_centres, nz - 1)[mask.w_faces]
        return {"mobility": float(-1.0 / f_rod),
                "drift_speed": float(-(f_load + f_top * flow.top_speed) / f_rod),
                "vertical_force": float(vol * r_w.sum()),
                "torque": float(vol * (np.sum((zu - self.rod.depth_from_bottom) * r_u)
                                       - np.sum((xw - 0.5 * self.cell_length_x) * r_w)))}

    def _dataset(self, flow: Flow, fields: dict[str, np.ndarray]) -> xr.Dataset:
        grid, mask = self.grid, self.mask
        nx, nz = grid.nx, grid.nz
        u2 = flow.u.reshape(nz, nx)
        ux = 0.5 * (u2 + np.roll(u2, -1, axis=1))
        w_full = np.zeros((nz + 1, nx))
        w_full[1:nz] = flow.w.reshape(nz - 1, nx)
        uz = 0.5 * (w_full[:-1] + w_full[1:])
        solid = mask.solid_cells

        def var(values: np.ndarray, units: str, name: str, nan_inside: bool = True) -> tuple:
            v = np.where(solid, np.nan, values) if nan_inside else values
            return (("z", "x"), np.asarray(v).reshape(nz, nx), {"units": units, "long_name": name})

        data = {
            "u_x": var(ux.ravel(), "m s-1", "velocity along x (rigid rod speed inside the rod)", False),
            "u_z": var(uz.ravel(), "m s-1", "velocity along z", False),
            "shear_rate": var(flow.shear_rate, "s-1", "shear-rate magnitude 2 sqrt(D_xx^2 + D_xz^2) (NaN inside the rod)"),
            "p": var(flow.p, "Pa", "pressure pi / normal_stress_ratio, compressive positive (NaN inside the rod)"),
            "mu": var(flow.mu, "1", "stress ratio tau / p (NaN inside the rod)"),
            "solid": var(solid.astype(np.int8), "1", "1 inside the rod", False),
        }
        for name, (values, units, long_name) in self.output_fields(flow, fields).items():
            data[name] = var(values, units, long_name)
        return xr.Dataset(data, coords={
            "x": ("x", grid.x_centres, {"units": "m", "long_name": "cell-centre x"}),
            "z": ("z", grid.z_centres, {"units": "m", "long_name": "cell-centre height above the bottom wall"})},
            attrs={"rod_speed": float(flow.rod_speed), "nx": nx, "nz": nz, "model": self.model})
