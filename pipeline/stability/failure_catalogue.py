"""Failure catalogue: where each continuum solver and the DEM stage fail, and with what message.

Run on demand (not part of the default workflow). Two parts:

* **Continuum**: each solver over parameter ranges where it may not converge (mu(I) with the
  wall stress ratio pushed towards mu_2, NGF with tiny A on coarse grids, volume-averaged with
  l -> 0 on coarse grids, critical state with loose packings or a too-compressible line,
  Cosserat with l against grid spacing). Every attempt is a row: ``converged`` with a one-line
  summary, or the exception class (``ConvergenceError``, ``OutOfRangeError``, ...) and its message.
* **DEM**: settings the config schema rejects (recorded with the ``ConfigError`` message), and
  valid-but-bad settings run with the real LIGGGHTS on tiny rheometer configs derived from the
  given config (a few hundred grains, one state, seconds each, one LIGGGHTS at a time), each of
  which must end in a :class:`pipeline.dem.liggghts_log.DEMRunError` naming the run and the cause:
  time step too large (overridden after validation, see :class:`LargeTimeStepRun`), walls and
  grains too soft (design overlap next to the overlap bound), too few grains to build the walls.

Columns: ``component, setting, value, outcome, message``.

Usage: ``python -m pipeline.stability.failure_catalogue --config CONFIG --params params.json
--out stability/failure_catalogue.csv [--fields fields/shear_gravity/r1.nc ...] [--no-dem]``
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import shutil
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd
import xarray as xr

import continuum
from continuum.geometry import PlanarShear
from continuum.mesh_study import band_width, weak_plane_packing
from continuum.parameters import CriticalStateLine
from pipeline.calibration.parameter_sets import CalibrationError, model_parameters
from pipeline.common.config import ConfigError, mean_grain_volume, validate_config
from pipeline.dem.planar_run import PlanarShearRun
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.models.planar import case_geometry

COLUMNS = ["component", "setting", "value", "outcome", "message"]
#: Solid fraction assumed to estimate the depth of a layer from its grain count (no fields given).
ASSUMED_SOLID_FRACTION = 0.6


@dataclass
class Attempt:
    """One row of the catalogue."""

    component: str
    setting: str
    value: float
    outcome: str
    message: str

    def as_dict(self) -> dict[str, Any]:
        return {"component": self.component, "setting": self.setting, "value": self.value,
                "outcome": self.outcome, "message": self.message}


def attempt(component: str, setting: str, value: float, action: Callable[[], str]) -> Attempt:
    """Run ``action``; its return value is the summary of a success, an exception is the outcome.

    Only exceptions that a bad setting produces are caught (continuum errors, the validation
    errors of parameter dataclasses and configs, DEM run errors, floating-point overflow or
    invalid operations); anything else is a bug and propagates.
    """
    try:
        # Underflow to zero is harmless (creep below 1e-308 of V); overflow, 0/0 and x/0 are
        # recorded as failures whatever the caller's numpy error settings.
        with np.errstate(under="ignore", over="raise", invalid="raise", divide="raise"):
            summary = action()
    except (continuum.ContinuumError, DEMRunError, ConfigError, ValueError, RuntimeError,
            FloatingPointError) as exc:
        return Attempt(component, setting, float(value), type(exc).__name__, " ".join(str(exc).split()))
    return Attempt(component, setting, float(value), "converged" if component != "dem" else "ok", summary)


# ----------------------------------------------------------------------------------- continuum
def config_geometry(config: dict[str, Any]) -> PlanarShear:
    """shear_gravity cell of a config, its depth estimated from the grain count (solid fraction
    ``ASSUMED_SOLID_FRACTION``, both wall layers included: the estimate only sets the scale)."""
    mat, case = config["material"], config["cases"]["shear_gravity"]
    area = case["cell_x"] * case["cell_y"] * mat["d"] ** 2
    volume = case["n_grains"] * mean_grain_volume(mat["d"], mat["polydispersity"], mat["n_sizes"])
    return PlanarShear(depth=volume / (ASSUMED_SOLID_FRACTION * area), wall_speed=float(case["wall_speed"]),
                       wall_pressure=float(case["wall_pressure"]), gravity=float(case["gravity"]),
                       d=mat["d"], rho_s=mat["rho_s"])


def _summary(ds: xr.Dataset) -> str:
    """One line describing a converged solution."""
    parts = [f"tau = {ds.attrs['tau']:.4g} Pa", f"iterations {ds.attrs['iterations']}"]
    if "u_x" in ds:
        z = ds.z.values
        w = band_width(z, ds.u_x.values, float(ds.attrs["wall_speed"]))
        # in units of d and of the largest node spacing: w ~ 1 dx means the grid sets the band
        parts.append(f"band width {w / float(ds.attrs['d']):.3g} d = {w / float(np.max(np.diff(z))):.3g} dx")
    if "mu" in ds:
        parts.append(f"top-wall stress ratio {float(ds.mu.values[-1]):.4g}")
    return ", ".join(parts)


def _solver(model: str, geometry: PlanarShear, params: Any, n_grid: int, **options: Any) -> Callable[[], str]:
    return lambda: _summary(continuum.solve(model, geometry, params, n_grid=n_grid, case="catalogue", **options))


def continuum_attempts(geometry: PlanarShear, params: dict[str, Any]) -> list[Attempt]:
    """The continuum half of the catalogue on the shear_gravity cell ``geometry`` (see module doc)."""
    rows: list[Attempt] = []
    d = geometry.d
    sqrt_gd = math.sqrt(max(geometry.gravity, 9.81) * d)

    def build(model: str) -> Any | None:
        try:
            return model_parameters(params, model)
        except CalibrationError as exc:
            rows.append(Attempt(model, "calibrated parameters", float("nan"), type(exc).__name__, str(exc)))
            return None

    local = build("local_mu_i")
    if local is not None:
        # The top-wall stress ratio rises towards mu_2 with the wall speed; nu(I) = nu_c - a I
        # reaches zero first (I = nu_c / a) for the usual a; the solver must say which.
        for factor in (1e-3, 1.0, 10.0, 30.0, 100.0, 300.0):
            g = replace(geometry, wall_speed=factor * sqrt_gd)
            rows.append(attempt("local_mu_i", "shear_gravity wall speed / sqrt(g d)", factor,
                                _solver("local_mu_i", g, local, 200)))
        rheometer = replace(geometry, gravity=0.0)
        i_max = local.solid_fraction.I_max
        for fraction in (0.5, 0.99, 1.01):
            # homogeneous shear at I = fraction * I_max (the range end of the nu(I) law)
            speed = fraction * i_max * math.sqrt(geometry.wall_pressure / geometry.rho_s) / d * geometry.depth
            g = replace(rheometer, wall_speed=speed)
            rows.append(attempt("local_mu_i", "rheometer I / I_max (nu(I) = 0 at I_max)", fraction,
                                _solver("local_mu_i", g, local, 200)))
        rows.append(attempt("local_mu_i", "mu_2 - mu_s (friction law collapses)", 0.0,
                            lambda: str(replace(local.mu_i, mu_2=local.mu_i.mu_s))))

    ngf = build("ngf")
    if ngf is not None:
        for A in (1e-4, 1e-2, ngf.A):
            for n in (16, 1024):
                rows.append(attempt("ngf", f"A on a {n}-node grid", A, _solver("ngf", geometry, replace(ngf, A=A), n)))
        for factor in (10.0, 1e3):
            g = replace(geometry, wall_speed=factor * sqrt_gd)
            rows.append(attempt("ngf", "shear_gravity wall speed / sqrt(g d)", factor, _solver("ngf", g, ngf, 400)))
        rows.append(attempt("ngf", "wall speed (m/s)", 0.0,
                            _solver("ngf", replace(geometry, wall_speed=0.0), ngf, 200)))

    cs = build("critical_state")
    if cs is not None:
        p_top = geometry.wall_pressure
        for looser in (0.01, 0.05, 0.2):
            # uniform packing looser than critical at the top-wall pressure by `looser`
            nu0 = float(cs.line.nu_cs(p_top)) - looser
            rows.append(attempt("critical_state", "initial nu below critical at P_wall (loose)", looser,
                                _solver("critical_state", geometry, cs, 200, nu_initial=lambda z, v=nu0: np.full_like(z, v))))
        rows.append(attempt("critical_state", "uniform pressure and packing (g = 0)", 0.0,
                            lambda: _undetermined(replace(geometry, gravity=0.0), cs)))
        for kappa in (0.1, 1.0):
            steep = replace(cs, line=replace(cs.line, kappa=kappa))
            rows.append(attempt("critical_state", "kappa of the critical-state line", kappa,
                                _solver("critical_state", geometry, steep, 200)))

    va = build("volume_averaged")
    if va is not None:
        layer = replace(geometry, gravity=0.0)
        packing = weak_plane_packing(layer, va.critical.line)
        for l_over_d in (1e-3, 0.05, va.l / d):
            for n in (16, 1024):
                rows.append(attempt("volume_averaged", f"l / d on a {n}-node weak-plane layer", l_over_d,
                                    _solver("volume_averaged", layer, replace(va, l=l_over_d * d), n, nu_initial=packing)))
        for looser in (0.05, 0.2):
            nu0 = float(va.critical.line.nu_cs(geometry.wall_pressure)) - looser
            rows.append(attempt("volume_averaged", "initial nu below critical at P_wall (loose)", looser,
                                _solver("volume_averaged", geometry, va, 200, nu_initial=lambda z, v=nu0: np.full_like(z, v))))

    cos = build("cosserat")
    if cos is not None:
        for l_over_d in (0.25, 1.0, 2.0, 4.0):
            for n in (16, 1024):
                rows.append(attempt("cosserat", f"l / d on a {n}-node grid", l_over_d,
                                    _solver("cosserat", geometry, replace(cos, l=l_over_d * d), n)))
    return rows


def _undetermined(geometry: PlanarShear, params: Any) -> str:
    ds = continuum.solve("critical_state", geometry, params, n_grid=200, case="catalogue")
    if "u_x" not in ds:
        return "every plane yields at once: velocity not determined by the model (u_x not returned)"
    return _summary(ds)


# ----------------------------------------------------------------------------------------- DEM
def tiny_config(config: dict[str, Any], n_grains: int = 200, inertial_number: float = 0.2) -> dict[str, Any]:
    """A rheometer-only config from ``config``: one state at a high inertial number (fewest steps
    per unit strain), ``n_grains`` grains in a 5 x 5 d cell, at most two short shear chunks.
    Material and DEM rules unchanged, so a failure here is the failure of those rules."""
    tiny = copy.deepcopy(config)
    rheo = tiny["cases"].get("rheometer") or {}
    tiny["cases"] = {"rheometer": {
        "geometry": "planar_shear", "cell_x": 5.0, "cell_y": 5.0, "n_grains": n_grains,
        "wall_pressure": float(rheo.get("wall_pressure", 200.0)), "gravity": 0.0,
        "inertial_numbers": [inertial_number], "replicas": 1,
    }}
    tiny["dem"] = tiny["dem"] | {"max_shear_chunks": 2, "steady_window_chunks": 2, "chunk_strain": 0.2,
                                 "mpi_launcher": "", "mpi_ranks": 1}
    for section in ("coarse_grain", "calibration", "models"):
        tiny.pop(section, None)
    return validate_config(tiny, "failure catalogue (tiny config)")


class LargeTimeStepRun(PlanarShearRun):
    """A rheometer run whose time step is multiplied by ``factor`` once the bed has settled.

    The schema caps ``dt_over_contact_time`` at 0.05, so a config cannot ask for this: the
    override after validation is deliberate, to show what the run's own checks (kinetic energy,
    overlap, lost grains) report when the time step is too large. The fill keeps the designed
    step so that the failure shows in shearing, where the checks are.
    """

    factor = 25.0

    def _base_variables(self) -> dict[str, object]:
        variables = super()._base_variables()
        if "fill" in self.state:
            variables["dt"] = float(variables["dt"]) * self.factor
        return variables


def _run_dem(run: PlanarShearRun) -> str:
    record = run.run()
    return f"finished: {record['steps']} steps, max overlap {record['max_overlap_over_d']:.3g} d"


def _run_id(config: dict[str, Any]) -> str:
    case = config["cases"]["rheometer"]
    return f"I{case['inertial_numbers'][0]:g}-P{case['wall_pressure']:g}-r1"


def dem_failure_runs(config: dict[str, Any], work: Path) -> list[tuple[str, float, PlanarShearRun]]:
    """The valid-but-bad DEM settings, each as (setting, value, the run that should fail), with
    fresh run folders under ``work`` (a failed run must fail again, not resume).

    * time step 25 x the designed one (1 contact time) once the bed has settled
      (:class:`LargeTimeStepRun`);
    * soft grains and walls: design overlap 0.0095 d next to the bound max_overlap = 0.01 d, at
      a wall pressure and design pressure of 2000 Pa (a high design pressure
      keeps the Young's modulus above LIGGGHTS's 5e6 Pa floor for SI units, so the run reaches
      the overlap check instead of being refused by LIGGGHTS);
    * too few grains: 60 grains in a 5 x 5 d cell (a bed about 2 d thick between the walls).
    """
    base = tiny_config(config)
    soft = copy.deepcopy(base)
    soft["material"].update({"design_overlap": 0.0095, "max_overlap": 0.01, "design_pressure": 2000.0})
    soft["cases"]["rheometer"]["wall_pressure"] = 2000.0
    soft = validate_config(soft, "failure catalogue (soft grains)")
    few = tiny_config(config, n_grains=60)
    plans: list[tuple[str, float, dict[str, Any], type[PlanarShearRun], str]] = [
        ("time step / designed time step (after the fill)", LargeTimeStepRun.factor, base, LargeTimeStepRun, "large_time_step"),
        ("material.design_overlap at max_overlap 0.01 and 2000 Pa (soft grains and walls)", 0.0095, soft, PlanarShearRun, "soft_grains"),
        ("cases.rheometer.n_grains in a 5 x 5 d cell", 60.0, few, PlanarShearRun, "too_few_grains"),
    ]
    runs = []
    for setting, value, cfg, cls, name in plans:
        folder = work / name
        shutil.rmtree(folder, ignore_errors=True)
        runs.append((setting, value, cls(cfg, "rheometer", _run_id(cfg), folder)))
    return runs


def dem_attempts(config: dict[str, Any], work: Path) -> list[Attempt]:
    """The DEM half of the catalogue: schema rejections, then the runs of
    :func:`dem_failure_runs`, one LIGGGHTS at a time; run folders (and the logs the messages
    point to) stay under ``work``."""
    rows: list[Attempt] = []
    base = tiny_config(config)

    def rejected(key: str, value: float, change: Callable[[dict[str, Any]], None]) -> None:
        bad = copy.deepcopy(base)
        change(bad)

        def action() -> str:
            validate_config(bad, "failure catalogue")
            return "accepted by the schema"

        rows.append(attempt("dem_config", key, value, action))

    rejected("material.dt_over_contact_time", 0.1, lambda c: c["material"].__setitem__("dt_over_contact_time", 0.1))
    rejected("material.design_overlap", 0.02, lambda c: c["material"].__setitem__("design_overlap", 0.02))
    rejected("cases.rheometer.n_grains", 20, lambda c: c["cases"]["rheometer"].__setitem__("n_grains", 20))
    for setting, value, run in dem_failure_runs(config, work):
        rows.append(attempt("dem", setting, value, lambda r=run: _run_dem(r)))
    return rows


# ------------------------------------------------------------------------------------------ CLI
def catalogue(config: dict[str, Any], params: dict[str, Any], work: Path, geometry: PlanarShear | None = None,
              dem: bool = True) -> pd.DataFrame:
    """The whole catalogue as a table (columns ``COLUMNS``)."""
    geometry = geometry or config_geometry(config)
    rows = continuum_attempts(geometry, params)
    if dem:
        rows += dem_attempts(config, work)
    return pd.DataFrame([r.as_dict() for r in rows], columns=COLUMNS)


def main(argv: list[str] | None = None) -> int:
    from pipeline.common.config import load_config

    parser = argparse.ArgumentParser(description="Where the continuum solvers and the DEM stage fail.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path, help="calibration/params.json")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--fields", nargs="*", type=Path, help="shear_gravity fields (geometry; default: from the config)")
    parser.add_argument("--work", type=Path, help="folder of the DEM runs (default: <out>_runs next to --out)")
    parser.add_argument("--no-dem", action="store_true", help="continuum part only")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    geometry = None
    if args.fields:
        fields = [xr.open_dataset(f) for f in args.fields]
        geometry, _ = case_geometry(fields, params)
        for ds in fields:
            ds.close()
    work = args.work or args.out.with_name(args.out.stem + "_runs")
    start = time.perf_counter()
    table = catalogue(config, params, work, geometry, dem=not args.no_dem)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp")
    table.to_csv(tmp, index=False)
    tmp.replace(args.out)
    with pd.option_context("display.max_colwidth", 120, "display.width", 250):
        print(table.to_string(index=False))
    print(f"{len(table)} attempts in {time.perf_counter() - start:.1f} s")
    return 0
