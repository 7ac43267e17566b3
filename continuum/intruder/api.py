"""``intruder_speed``: each model's steady rod speed in the shear_gravity scene, and the registry
of how each model makes it (``INTRUDER_MODELS``).

A model's prediction is its own converged 2D solution around the rod: a ``framework.RodSolver``
subclass registered with ``solver=``. Anything else is a named approximation with a label of its
own (``ngf_frozen``), or an estimate kept until the model's 2D solver exists (``estimate=``, the
method saying which). To add a model: write its ``RodSolver`` subclass (``framework.py`` says what
it implements) and register it here::

    INTRUDER_MODELS["local_mu_i"] = IntruderModel(LocalMuIParameters, solver=MuIRodSolver)
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import xarray as xr

from .. import solve as solve_planar
from ..errors import OutOfRangeError
from ..geometry import PlanarShear
from ..parameters import (CosseratParameters, CriticalStateParameters, LocalMuIParameters, NGFParameters,
                          VolumeAveragedParameters)
from .framework import RodSolver
from .local import kinematic_speed, layer_sliding_speed, rod_in_static_zone, yield_force
from .cosserat2d import CosseratRodSolver
from .critical_state2d import CriticalStateRodSolver
from .mu_i2d import MuIRodSolver
from .ngf2d import FROZEN, NGFRodSolver, solve_frozen
from .volume_averaged2d import VolumeAveragedRodSolver
from .scene import GridOptions, IntruderSpeed, RodIntruder
from .yield2d import YieldRodSolver

Estimate = Callable[[PlanarShear, Any, RodIntruder, float, GridOptions, dict, "str | None"], IntruderSpeed]


@dataclass(frozen=True)
class IntruderModel:
    """How one label's intruder speed is made.

    Attributes:
        params_type: the parameter class it takes.
        solver: the model's 2D solver (its own prediction), or None.
        estimate: a function (geometry, params, intruder, L_x, grid, planar_options, case) ->
            IntruderSpeed, for a named approximation or a model without a 2D solver yet.
        approximates: for an approximation, the model whose parameters it uses (else "").
    """

    params_type: type
    solver: type[RodSolver] | None = None
    estimate: Estimate | None = None
    approximates: str = ""

    def __post_init__(self) -> None:
        if (self.solver is None) == (self.estimate is None):
            raise ValueError("an IntruderModel has exactly one of solver and estimate")


def _ngf_frozen(geometry: PlanarShear, params: NGFParameters, intruder: RodIntruder, cell_length_x: float,
                grid: GridOptions, planar_options: dict, case: str | None) -> IntruderSpeed:
    out = solve_frozen(geometry, params, cell_length_x, intruder, grid, case)
    attrs = {k: out[k] for k in ("tau_top", "top_wall_slip", "vertical_force", "torque", "mu_max", "p_min",
                                 "fluidity_floor", "floor_at_rod") if k in out}
    attrs["nx"], attrs["nz"] = out["fields"].attrs["nx"], out["fields"].attrs["nz"]
    return IntruderSpeed(FROZEN, out["speed"], out["converged"], out["iterations"], out["residual"],
                         out["solve_seconds"], out["n_grid"], "frozen", out["drift_speed"], out["mobility"],
                         planar_solve_seconds=out["planar_solve_seconds"], fields=out["fields"], attrs=attrs)


def _local_estimate(model: str) -> Estimate:
    """The 1D estimates of the local and volume-averaged models (``local.py``; docs/intruder.md)."""

    def estimate(geometry: PlanarShear, params: Any, intruder: RodIntruder, cell_length_x: float,
                 grid: GridOptions, planar_options: dict, case: str | None) -> IntruderSpeed:
        t0 = time.perf_counter()
        planar = solve_planar(model, geometry, params, **planar_options)
        planar_seconds = time.perf_counter() - t0
        sin_phi = {"local_mu_i": lambda q: q.mu_i.mu_s, "critical_state": lambda q: q.sin_phi,
                   "volume_averaged": lambda q: q.critical.sin_phi}[model](params)
        yf = yield_force(planar, sin_phi, intruder, cell_length_x)
        if model == "local_mu_i" and intruder.force_per_length < yf.bearing:
            speed, tau_top = layer_sliding_speed(planar, params.mu_i, geometry, intruder, cell_length_x, case)
            attrs = {"yield_force_bearing": yf.bearing, "yield_force_layer": yf.layer_sliding,
                     "tau_top": tau_top, "tau_top_without_rod": float(planar.attrs["tau"])}
            if intruder.force_per_length >= yf.layer_sliding:
                method = "layer_sliding"
            else:
                method = "1d_flow" if speed > 0.0 else "yield_check"
            return IntruderSpeed(model, speed, True, 0, 0.0, time.perf_counter() - t0, int(planar.sizes["z"]), method,
                                 yield_force=yf.value, planar_solve_seconds=planar_seconds, attrs=attrs)
        if intruder.force_per_length >= yf.value:
            raise OutOfRangeError(model, f"F = {intruder.force_per_length:.3g} N/m is above the yield-force "
                                  f"estimate {yf.value:.3g} N/m: the rod fails; no 2D plastic solve here", case)
        attrs = {"yield_force_bearing": yf.bearing, "yield_force_layer": yf.layer_sliding,
                 "tau_top": float(planar.attrs["tau"])}
        if model == "volume_averaged":
            if "u_x" not in planar:
                raise OutOfRangeError(model, "planar velocity undetermined (tied yielding planes)", case)
            speed, method = kinematic_speed(planar, intruder), "kinematic"
        else:
            if "u_x" in planar and not rod_in_static_zone(planar, intruder):
                raise OutOfRangeError(model, "the rod reaches the flowing layer of the 1D solution; "
                                      "the local models are not solved in 2D", case)
            speed, method = 0.0, "yield_check"
        return IntruderSpeed(model, speed, True, 0, 0.0, time.perf_counter() - t0, 0, method,
                             drift_speed=speed, mobility=0.0, yield_force=yf.value,
                             planar_solve_seconds=planar_seconds, attrs=attrs)

    return estimate


#: label -> how its intruder speed is made. The models' own 2D solvers register with ``solver=``
#: (every model's own 2D solver; the former 1D estimates stay under labels of their own).
INTRUDER_MODELS: dict[str, IntruderModel] = {
    "ngf": IntruderModel(NGFParameters, solver=NGFRodSolver),
    FROZEN: IntruderModel(NGFParameters, estimate=_ngf_frozen, approximates="ngf"),
    # the yield-stress models' own 2D solves (docs/intruder_models.md), and their former 1D
    # estimates under labels of their own
    "local_mu_i": IntruderModel(LocalMuIParameters, solver=MuIRodSolver),
    "critical_state": IntruderModel(CriticalStateParameters, solver=CriticalStateRodSolver),
    "volume_averaged": IntruderModel(VolumeAveragedParameters, solver=VolumeAveragedRodSolver),
    "cosserat": IntruderModel(CosseratParameters, solver=CosseratRodSolver),
    "local_mu_i_layer_sliding": IntruderModel(LocalMuIParameters, estimate=_local_estimate("local_mu_i"),
                                              approximates="local_mu_i"),
    "critical_state_yield_check": IntruderModel(CriticalStateParameters, estimate=_local_estimate("critical_state"),
                                                approximates="critical_state"),
    "volume_averaged_kinematic": IntruderModel(VolumeAveragedParameters, estimate=_local_estimate("volume_averaged"),
                                               approximates="volume_averaged"),
}


def intruder_speed(model: str, geometry: PlanarShear, params: Any, intruder: RodIntruder,
                   cell_length_x: float, grid: GridOptions = GridOptions(),
                   planar_options: dict | None = None, case: str | None = None,
                   warm: IntruderSpeed | None = None, limit_load: bool = True,
                   fallback: IntruderSpeed | None = None) -> IntruderSpeed:
    """Steady speed U (m s-1, along +x) of a rod under force F (N m-1, along +x) held at height
    z_i in the periodic planar shear cell of period ``cell_length_x`` (m), by the label's entry
    in ``INTRUDER_MODELS``.

    ``warm``: an earlier result of the same label on the same grid (its converged fields and
    pressure start the iteration; e.g. the nominal parameters' solution for a parameter draw), or
    on another grid of the same cell, which the local yield-stress laws carry onto this one
    (``YieldRodSolver.regrids``). ``fallback``: the start to use when ``warm`` cannot start this
    solve (a state of another grid that the model does not carry: NGF's, the volume-averaged
    model's), e.g. this grid's solution at the same depth under another push; without it such a
    solve starts from the planar solution.
    ``limit_load``: where a yield-stress solver finds no steady state, compute the 2D limit load
    to report a push above it as ``OutOfRangeError`` (the rod fails); False leaves every failure
    a ``ConvergenceError`` and skips those two driven solves (a parameter draw needs only whether
    it has a speed).
    ``planar_options`` go to ``continuum.solve`` (estimates only).

    Raises KeyError (unknown label), TypeError (wrong parameters), ``OutOfRangeError`` (the model
    refuses the scene: e.g. the bed opens in tension next to the rod), ``ConvergenceError``.
    """
    if model not in INTRUDER_MODELS:
        raise KeyError(f"unknown intruder model {model!r}; known: {sorted(INTRUDER_MODELS)}")
    entry = INTRUDER_MODELS[model]
    if not isinstance(params, entry.params_type):
        raise TypeError(f"{model} needs {entry.params_type.__name__}, got {type(params).__name__}")
    intruder.check_inside(geometry, cell_length_x)
    if entry.estimate is not None:
        return entry.estimate(geometry, params, intruder, cell_length_x, grid, dict(planar_options or {}), case)
    solver = entry.solver(geometry, params, cell_length_x, intruder, grid, case)
    state = next((start.state for start in (warm, fallback)
                  if start is not None and start.state is not None and _starts(solver, start.state)), None)
    sol = solver.solve(state, limit_load=limit_load)
    attrs = dict(sol.attrs)
    attrs.update({f"residual_{k}": float(v) for k, v in sol.residuals.items()})
    return IntruderSpeed(model, sol.speed, sol.converged, sol.iterations, sol.residual, sol.solve_seconds,
                         sol.n_grid, "2d", attrs.pop("drift_speed"), attrs.pop("mobility"),
                         planar_solve_seconds=sol.planar_seconds, fields=sol.fields, attrs=attrs, state=sol.state)


def _starts(solver: RodSolver, state: dict[str, np.ndarray]) -> bool:
    """Whether ``state`` can start ``solver``: a state of its own grid (the first entry has the
    cells' size), or one of another grid that the solver carries onto its own (a yield-stress
    law without averaging: ``YieldRodSolver.regrids``)."""
    if np.size(next(iter(state.values()))) == solver.grid.n_cells:
        return True
    return "grid" in state and isinstance(solver, YieldRodSolver) and solver.regrids


def intruder_fields(model: str, geometry: PlanarShear, params: Any, intruder: RodIntruder, cell_length_x: float,
                    grid: GridOptions, state: dict[str, np.ndarray], case: str | None = None) -> xr.Dataset:
    """The 2D fields of a converged solve of the label's 2D solver, rebuilt from its ``state``
    (``IntruderSpeed.state``, e.g. a stored warm start) on the same
    scene and grid, without solving again: the state's own flow (NGF: one Stokes solve with the
    state's fluidity and pressure, the flow the converged solve ended on; the Newton solvers: the
    flow of the state's unknowns at the last regularisation).

    Returns the solve's Dataset on (z, x) (cell centres, m; x in the cell, the rod's centre at
    ``cell_length_x / 2``; z above the bottom contact plane), as ``IntruderSpeed.fields``: u_x,
    u_z (m s-1, lab frame; the rod's rigid motion inside it), shear_rate, p, mu (tau / p, tau the
    in-plane deviatoric stress magnitude), solid, the model's own fields (NGF: fluidity; Cosserat:
    spin), and besides them: the stresses ``sigma_xx``, ``sigma_zz``, ``sigma_xz`` (Pa,
    compressive positive, the DEM's convention: sigma_xz the x force across z planes), ``mu_xz``
    (|sigma_xz| / p, the DEM's fields' stress ratio) and ``nu`` where the model has a solid
    fraction (local mu(I): nu(I) of the local inertial number; Cosserat: nu_cs(p); critical state
    and the volume-averaged model: the 1D solution's packing at that height, which their 2D solve
    carries unchanged; NGF: none), with the method in its ``nu_method`` attribute. NaN inside the
    rod except u_x, u_z, solid. Attributes: ``rod_speed`` (the rod's speed in these fields, m s-1:
    for a rate-independent model whose speed is 0 in the limit, the last regularisation's bound).

    Raises KeyError (unknown label), ValueError (a label without a 2D solver, or a state of
    another grid).
    """
    if model not in INTRUDER_MODELS:
        raise KeyError(f"unknown intruder model {model!r}; known: {sorted(INTRUDER_MODELS)}")
    entry = INTRUDER_MODELS[model]
    if entry.solver is None:
        raise ValueError(f"{model} has no 2D solver: no fields to rebuild")
    solver = entry.solver(geometry, params, cell_length_x, intruder, grid, case)
    size = np.size(state.get("u", state.get("p", np.empty(0))))
    if size != solver.grid.n_cells:
        raise ValueError(f"{model}: the state has {size} cells, the grid {solver.grid.n_cells} "
                         f"({solver.grid.nx} x {solver.grid.nz}): another grid")
    with np.errstate(under="ignore"):
        if isinstance(solver, YieldRodSolver):
            disc = solver._discretisation()
            y = solver._vector({k: np.asarray(v, dtype=float) for k, v in state.items()}, disc)
            ev = solver._evaluate(y, disc, solver.regularisations[-1], False)
            flow = solver._flow(y, ev, disc)
            fields: dict[str, np.ndarray] = {}
        else:
            fields = {k: np.asarray(state[k], dtype=float) for k in solver.field_tolerances}
            flow = solver._flow_of(fields, np.asarray(state["p"], dtype=float))
        ds = solver._dataset(flow, fields)
    nz, nx = solver.grid.nz, solver.grid.nx
    solid = solver.mask.solid_cells

    def add(name: str, values: np.ndarray, units: str, long_name: str) -> None:
        ds[name] = (("z", "x"), np.where(solid, np.nan, values).reshape(nz, nx), {"units": units, "long_name": long_name})

    add("sigma_xx", flow.pi - flow.s_xx, "Pa", "normal stress xx, compressive positive (NaN inside the rod)")
    add("sigma_zz", flow.pi + flow.s_xx, "Pa", "normal stress zz, compressive positive (NaN inside the rod)")
    add("sigma_xz", -flow.s_xz, "Pa", "shear stress xz (x force across z planes), compressive-positive sign "
        "(NaN inside the rod)")
    add("mu_xz", np.abs(flow.s_xz) / flow.p_eff, "1", "stress ratio |sigma_xz| / p, the DEM fields' definition "
        "(NaN inside the rod)")
    nu, method = _solid_fraction(model, solver, flow)
    if nu is not None:
        add("nu", nu, "1", f"solid fraction: {method} (NaN inside the rod)")
        ds.attrs["nu_method"] = method
    ds.attrs["rod_speed"] = float(flow.rod_speed)
    return ds


def _solid_fraction(model: str, solver: RodSolver, flow: Any) -> tuple[np.ndarray | None, str]:
    """The model's solid fraction on the cells and how it is obtained (``intruder_fields``)."""
    params, geo = solver.params, solver.geometry
    if model == "local_mu_i":
        inertial = flow.shear_rate * geo.d / np.sqrt(flow.p_eff / geo.rho_s)
        return params.solid_fraction.nu(inertial), "nu(I) = nu_c - a I of the local inertial number"
    if model == "cosserat":
        return params.critical.line.nu_cs(flow.p_eff), "nu_cs(p), the critical state (steady flow at alpha = 1)"
    if isinstance(solver, YieldRodSolver):
        planar = solver.planar_solution()
        return (np.interp(solver.z_cells, planar.z.values, planar.nu.values),
                "the 1D solution's packing at that height (the 2D solve carries it unchanged)")
    return None, ""
