"""Each model's intruder speed at the DEM's depths and pushes: ``models/intruder/{model}.nc``, with
its converged 2D states beside it (``--states-out``: the warm starts of the draws and the grid
study, ``pipeline.models.intruder_draws``, which write ``model_draws/intruder/{model}.nc``).

One scene per target depth and push (the first replica's run: the replicas' scenes differ by a
fraction of a grain in depth): the geometry from its fields file (wall-to-wall depth, load,
gravity, wall speed), the rod from its run.json (diameter, depth below the top wall, push), the
parameters from params.json. ``continuum.intruder.intruder_speed`` solves it with the label's
entry of ``INTRUDER_MODELS``: NGF by its coupled 2D solve (the model as written); beside NGF's
speed the file carries ``ngf_frozen`` (far-field fluidity, one Stokes solve: a named
approximation, never NGF's score) as ``speed_frozen`` / ``sweep_speed_frozen``. A scene the model
refuses (rod in its flowing layer, a push above its yield force, a bed opening in tension) or
whose 2D solve does not converge is not written as a number: it is listed in ``refused``.

Cost (issue 43, item 7): a scene at a depth already solved starts from that solution (the force
sweep is a continuation in F); each parameter draw starts from the nominal solution of its
scene. The nominal 2D solves run at ``CELLS_PER_D``, the draws (u_input) at
``DRAWS_CELLS_PER_D``, the grid study (``speed_refined``: u_num) at ``REFINED_CELLS_PER_D``, each
of its solves started from the nominal solution carried onto the finer grid where the solver can
(the local yield-stress laws); where it cannot, NGF's scene at a depth the grid study has already
solved starts from that solution, as the nominal sweep does (``SAME_DEPTH_FALLBACK``), and the
volume-averaged model's from the planar solution. A scene the nominal parameters give no speed for is solved by neither
the draws nor the grid study (``NOMINAL_REFUSED``).

Usage: ``python -m pipeline.models intruder --config C --params params.json --model ngf
--runs RESULTS/dem/intruder/D5-r1/run.json ... --fields RESULTS/fields/intruder/D5-r1.nc ... --out F.nc
--states-out F.states.npz``
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import continuum
from continuum.intruder import INTRUDER_MODELS, GridOptions, IntruderSpeed, RodIntruder, intruder_speed
from continuum.geometry import PlanarShear
from continuum.intruder.sensitivity import has_jacobian
from pipeline.common.formats import open_fields
from pipeline.common import atomic
from pipeline.calibration.parameter_sets import model_parameters, normal_stress_ratio, slip_length
from pipeline.common.planar_cell import planar_cell
from pipeline.common.config import load_config
from pipeline.common.provenance import provenance_attrs
from pipeline.models.intruder_drift import add_drifts, linear_drifts, solve_drifts
from pipeline.models.intruder_states import save_states


#: Parameter draws solved per intruder model when the config's ``models.intruder_draws`` is absent.
DEFAULT_INTRUDER_DRAWS = 32
#: Cells per d of the 2D solves. NGF coupled at 3 and 4 cells/d differs by 0.04-4 % in U (issue
#: 43; benchmarks/intruder_solve.py), under a tenth of the DEM's 25 % error on U, at half the cost.
CELLS_PER_D = 3.0
#: The grid study's finer grid (u_num = its difference from CELLS_PER_D).
REFINED_CELLS_PER_D = 4.0
#: The parameter draws' grid (u_input is the spread of the draws' speeds). Measured on the default's
#: six scenes with 32 draws (2026-12-04): at 2 cells per d, 9 of the 32 draws at 9 d and one at
#: 7 d / 0.3 F_y did not converge in 400 map evaluations (warm or cold), and the failures cost
#: most of the stage's 454 CPU s; at 3 cells per d every draw of the benchmark converged (8 per
#: scene, warm 34 evaluations, 2.1 CPU s). So the draws share the nominal grid and start from
#: the nominal solutions themselves.
DRAWS_CELLS_PER_D = CELLS_PER_D
#: The reason a draw or the grid study gives for a scene it does not solve: the calibration's own
#: parameters have no prediction there (refused or not converged), so the draws' spread (u_input)
#: and the finer grid's difference (u_num) are uncertainties of no score. Solving them cost most
#: of the plastic models' draw stage (a failed solve, and its limit-load solves, per draw): in the
#: reduced run of 7ec3cc1, 175 of volume_averaged's 206 draw seconds.
NOMINAL_REFUSED = "not solved: the calibration's parameters have no prediction for this scene"
#: Whether a scene of NGF's grid study (a fixed-point solver, which carries no state across grids)
#: starts from the finer grid's own solution at the same depth under the previous push
#: (``solve_scenes``); False: from the planar solution, as before 2026-12-08. Measured side by side
#: (``benchmarks/grid_study_start.py``, the reduced run's root): NGF 20.1 -> 18.4 CPU s. Not for the
#: volume-averaged model: on the same root, alone, its grid study took 61.8 CPU s from the planar
#: solution against 70.6 from the other push (``--newton-too``, two repeats; the same speeds to 8e-13),
#: and in the tests its warm start from another push failed and was retried cold (0.3 and 0.45 ->
#: 0.5 F_y at 6.5 d, 2 cells per d). A switch for that benchmark.
SAME_DEPTH_FALLBACK = True
#: |U| / V up to which a speed is a rod carried with the top wall (the rate-independent models'
#: U -> V, reached from above by the regularised solve within its convergence tolerance) and not
#: the ill-conditioned number the check below refuses. Measured: 1.00004 V for critical state
#: at 3.7 d and 0.8 F_y in the reduced run of 7ec3cc1.
CARRIED_TOLERANCE = 1e-3
#: Labels solved beside a model and written into its file (variables ``speed_<suffix>``,
#: ``sweep_speed_<suffix>``): the registry's approximations of it (``ngf_frozen`` -> ``frozen``).
APPROXIMATIONS = {model: {label: label.removeprefix(model + "_") for label, entry in INTRUDER_MODELS.items()
                          if entry.approximates == model}
                  for model in sorted({entry.approximates for entry in INTRUDER_MODELS.values() if entry.approximates})}


@dataclass
class Scene:
    """One target depth and push: its first replica's run record and fields, the cell and rod."""

    run: dict[str, Any]
    geometry: PlanarShear
    rod: RodIntruder
    cell_length_x: float
    label: str

    @property
    def force_sweep(self) -> bool:
        return bool(self.run["intruder"].get("force_sweep"))

    @property
    def depth_over_d(self) -> float:
        return float(self.run["intruder"]["depth_over_d"])

    @property
    def push_over_yield(self) -> float:
        return float(self.run["intruder"].get("push_over_yield", np.nan))

    @property
    def target(self) -> float:
        return round(float(self.run["intruder"]["depth_target_over_d"]), 6)


def scene_of(run: dict[str, Any], ds: xr.Dataset, params: dict[str, Any]) -> Scene:
    rod = run["intruder"]
    geometry, z0 = planar_cell([ds], normal_stress_ratio(params), slip_length=slip_length(params))
    # run.json gives the rod's depth below the top wall's grain centres; the cell's top is its contact plane.
    rod_z = float(ds.attrs["z_top_wall"]) - rod["depth"]
    intruder = RodIntruder.below_top(geometry, rod["diameter"], z0 + geometry.depth - rod_z, rod["force"] / rod["length"])
    return Scene(run, geometry, intruder, float(run["cell"][0]), f"{run['case']}/{run['run']}")


def scenes_of(runs: list[dict[str, Any]], fields: list[xr.Dataset], params: dict[str, Any]) -> list[Scene]:
    """One scene per target depth and push, ordered by depth and push (so that each depth's
    later pushes continue from the earlier ones)."""
    seen, out = set(), []
    for run, ds in zip(runs, fields, strict=True):
        rod = run["intruder"]
        key = (round(float(rod["depth_target_over_d"]), 6),
               round(float(rod.get("push_over_yield", -1.0)), 6) if rod.get("force_sweep") else None)
        if key not in seen:
            seen.add(key)
            out.append(scene_of(run, ds, params))
    return sorted(out, key=lambda s: (s.target, s.rod.force_per_length))


def solve_scene(model: str, parameters: Any, scene: Scene, cells_per_d: float,
                warm: IntruderSpeed | None = None, limit_load: bool = True,
                fallback: IntruderSpeed | None = None) -> tuple[IntruderSpeed | None, str | None]:
    """The label's result for one scene, or None and why it was refused / not converged.
    ``limit_load`` False: a failed yield-stress solve is not followed by the limit load that
    would tell a failing rod from an unconverged solve (``continuum.intruder_speed``), for the
    parameter draws, whose failure only removes the draw. ``fallback``: the start when ``warm``
    is of a grid the model does not carry a state across (``continuum.intruder_speed``)."""
    where = f"{scene.depth_over_d:.2f} d" + (f", push {scene.push_over_yield:g} F_y" if scene.force_sweep else "")
    try:
        result = intruder_speed(model, scene.geometry, parameters, scene.rod, scene.cell_length_x,
                                GridOptions(cells_per_d=cells_per_d), case=scene.label, warm=warm,
                                limit_load=limit_load, fallback=fallback)
    except continuum.OutOfRangeError as exc:
        return None, f"{where}: {exc}"
    except continuum.ConvergenceError as exc:
        return None, f"{where}: not converged: {exc}"
    if not np.isfinite(result.speed) or abs(result.speed) > scene.geometry.wall_speed * (1.0 + CARRIED_TOLERANCE):
        # A rod pushed below its yield force cannot outrun the wall: such a number comes from an
        # ill-conditioned solve, not physics.
        return None, (f"{where}: solve failed: speed {result.speed:.3g} m/s exceeds the wall speed "
                      f"{scene.geometry.wall_speed:g} m/s")
    return result, None


def solve_scenes(model: str, parameters: Any, scenes: list[Scene], cells_per_d: float,
                 warm: list[IntruderSpeed | None] | None = None, only: list[bool] | None = None,
                 limit_load: bool = True) -> tuple[list[IntruderSpeed | None], list[str | None]]:
    """Every scene (or those where ``only`` is True; the others get None and the reason
    ``NOMINAL_REFUSED``). A scene at a depth already solved on this grid starts from that
    solution (a continuation in the push), unless ``warm`` gives it a start: with ``warm`` (e.g.
    the nominal solutions on another grid, for the grid study) that solution is NGF's fallback,
    whose state ``warm`` cannot carry across grids (``SAME_DEPTH_FALLBACK``); the volume-averaged
    model, which cannot either, starts from the planar solution."""
    results: list[IntruderSpeed | None] = []
    reasons: list[str | None] = []
    last: dict[float, IntruderSpeed] = {}
    continued = SAME_DEPTH_FALLBACK and not has_jacobian(model)  # (SAME_DEPTH_FALLBACK: NGF only)
    for k, scene in enumerate(scenes):
        if only is not None and not only[k]:
            results.append(None)
            reasons.append(NOMINAL_REFUSED)
            continue
        # (a warm start that fails is retried cold by the solver itself: continuum.intruder)
        same_grid = last.get(scene.target)
        start, fallback = (warm[k], same_grid if continued else None) if warm is not None else (same_grid, None)
        result, reason = solve_scene(model, parameters, scene, cells_per_d, start, limit_load, fallback)
        if result is not None and result.state is not None:
            last[scene.target] = result
        results.append(result)
        reasons.append(reason)
    return results, reasons


def _split(scenes: list[Scene], values: list[float]) -> tuple[list[float], list[float], list[float], list[float]]:
    depths = [s.depth_over_d for s in scenes if not s.force_sweep]
    pushes = [s.push_over_yield for s in scenes if s.force_sweep]
    return (depths, [v for s, v in zip(scenes, values) if not s.force_sweep],
            pushes, [v for s, v in zip(scenes, values) if s.force_sweep])


def predict(model: str, params: dict[str, Any], runs: list[dict[str, Any]], fields: list[xr.Dataset],
            cells_per_d: float = CELLS_PER_D) -> tuple[xr.Dataset, list[IntruderSpeed | None]]:
    """The model's speed at each scene (module docstring): the depth sweep on ``depth_over_d``, the
    force sweep on ``push_over_yield``; and the results (warm starts for the draws)."""
    scenes = scenes_of(runs, fields, params)
    parameters = model_parameters(params, model)
    t0 = time.perf_counter()
    results, reasons = solve_scenes(model, parameters, scenes, cells_per_d)
    refused = [r for r in reasons if r is not None]
    speed = [r.speed if r is not None else np.nan for r in results]
    seconds = [r.solve_seconds if r is not None else np.nan for r in results]
    iterations = [r.iterations if r is not None else -1 for r in results]
    bounded = [int(bool(r.attrs.get("floor_at_rod", False))) if r is not None else 0 for r in results]
    depths, d_speed, pushes, p_speed = _split(scenes, speed)
    _, d_sec, _, p_sec = _split(scenes, seconds)
    _, d_it, _, p_it = _split(scenes, iterations)
    _, d_bound, _, _ = _split(scenes, bounded)
    out = xr.Dataset(coords={"depth_over_d": ("depth_over_d", np.asarray(depths, dtype=float),
                                              {"units": "1", "long_name": "rod axis below the top wall, in d"})})
    keep = np.isfinite(np.asarray(d_speed, dtype=float))  # refused depths are listed, not written
    out = out.isel(depth_over_d=np.nonzero(keep)[0])
    out["speed"] = ("depth_over_d", np.asarray(d_speed, dtype=float)[keep],
                    {"units": "m s-1", "long_name": "steady rod speed along +x"})
    out["speed_is_upper_bound"] = ("depth_over_d", np.asarray(d_bound, dtype=np.int8)[keep],
                                   {"units": "1", "long_name": "1 where the fluidity floor reaches the rod: the speed "
                                    "is an upper bound (continuum/intruder/ngf2d.py FLUIDITY_FLOOR)"})
    out["solve_seconds"] = ("depth_over_d", np.asarray(d_sec, dtype=float)[keep], {"units": "s", "long_name": "solve time of the scene"})
    out["iterations"] = ("depth_over_d", np.asarray(d_it, dtype=np.int64)[keep],
                         {"units": "1", "long_name": "fixed-point map evaluations of the 2D solve (0: no 2D solve)"})
    if pushes:
        out = out.assign_coords(push_over_yield=("push_over_yield", np.asarray(pushes, dtype=float),
                                                 {"units": "1", "long_name": "the force sweep's push over the yield force at its depth"}))
        out["sweep_speed"] = ("push_over_yield", np.asarray(p_speed, dtype=float),
                              {"units": "m s-1", "long_name": "steady rod speed of the force sweep (NaN: refused)"})
        out["sweep_solve_seconds"] = ("push_over_yield", np.asarray(p_sec, dtype=float), {"units": "s", "long_name": "solve time"})
        out["sweep_iterations"] = ("push_over_yield", np.asarray(p_it, dtype=np.int64),
                                   {"units": "1", "long_name": "fixed-point map evaluations of the 2D solve"})
    for label, suffix in APPROXIMATIONS.get(model, {}).items():
        approx, _ = solve_scenes(label, parameters, scenes, cells_per_d)
        a_speed = [r.speed if r is not None else np.nan for r in approx]
        _, ad, _, ap = _split(scenes, a_speed)
        out[f"speed_{suffix}"] = ("depth_over_d", np.asarray(ad, dtype=float)[keep],
                                  {"units": "m s-1", "long_name": f"rod speed of the {label} approximation (not {model}'s score)"})
        if pushes:
            out[f"sweep_speed_{suffix}"] = ("push_over_yield", np.asarray(ap, dtype=float),
                                            {"units": "m s-1", "long_name": f"force sweep: rod speed of the {label} approximation"})
    # The drift apart from the push (issue 55, item 3): the model's own F = 0 solve per depth.
    drifts, drift_refused = solve_drifts(model, parameters, scenes, cells_per_d, results, solve_scene)
    out = add_drifts(out, scenes, drifts, linear_drifts(results), drift_refused)
    done = [r for r in results if r is not None]
    out.attrs.update({"model": model, "case": "intruder", "refused": json.dumps(refused),
                      "n_grid": int(max(r.n_grid for r in done)) if done else 0,
                      "solve_seconds": float(time.perf_counter() - t0),
                      "iterations": int(sum(max(r.iterations, 0) for r in done)),
                      "converged": int(not any("not converged" in r for r in refused)),
                      "residual": float(max((r.residual for r in done), default=0.0)),
                      "cells_per_d": cells_per_d,
                      "method": ",".join(sorted({r.method for r in done})),
                      "approximations": json.dumps(APPROXIMATIONS.get(model, {}))})
    return out, results


def intruder_draws(config: dict[str, Any], model: str) -> int:
    """Parameter draws solved for ``model``: ``models.intruder_plastic_draws`` for the 2D plastic
    solvers (regularised yield-stress solves, tens of CPU seconds each: measured 2026-12-04),
    ``models.intruder_draws`` for the others (NGF: seconds a solve)."""
    models = config.get("models") or {}
    if has_jacobian(model) and "intruder_plastic_draws" in models:
        return int(models["intruder_plastic_draws"])
    return int(models.get("intruder_draws", DEFAULT_INTRUDER_DRAWS))


def pushed_runs(run_paths: list[Path], field_paths: list[Path]) -> tuple[list[dict[str, Any]], list[xr.Dataset]]:
    """The run records and fields of the pushed rods (the controls have no scene)."""
    records = [json.loads(p.read_text()) for p in run_paths]
    pairs = [(r, open_fields(f)) for r, f in zip(records, field_paths, strict=True) if not r["intruder"]["control"]]
    return [r for r, _ in pairs], [f for _, f in pairs]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Each model's intruder speed at the DEM's depths.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--model", required=True, choices=sorted(INTRUDER_MODELS))
    parser.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the intruder runs")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--states-out", type=Path, help="the converged 2D states (warm starts of "
                        "`python -m pipeline.models intruder-draws`), e.g. models/intruder/MODEL.states.npz")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    runs, fields = pushed_runs(args.runs, args.fields)
    t0 = time.perf_counter()
    result, nominal = predict(args.model, params, runs, fields)
    result.attrs.update(provenance_attrs(config))
    if args.states_out is not None:
        save_states(nominal, args.states_out, args.model, CELLS_PER_D, provenance_attrs(config))
    atomic.write_netcdf(result, args.out)
    print(f"{args.model}: speeds {result.speed.values} m/s at depths {result.depth_over_d.values} d; "
          + (f"force sweep {result.sweep_speed.values} m/s at {result.push_over_yield.values} F_y; " if "sweep_speed" in result else "")
          + f"refused {json.loads(result.attrs['refused'])}; {time.perf_counter() - t0:.1f} s")
    return 0
