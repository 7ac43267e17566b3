"""Each intruder model's uncertainties: its speed per parameter draw (u_input) and on a finer grid
(u_num), as ``model_draws/intruder/{model}.nc``.

The nominal solve (``pipeline.models.intruder``) writes its converged 2D states beside its file
(``pipeline.models.intruder_states``). The draws and the grid study start from them, so they split into independent
jobs (issue 45: on the 2-core machine the volume-averaged model's 8 draws and grid study ran
serially in one job of about 30 CPU minutes, the last job of the default, alone on one core):

* ``draws``: the draws of one part (``draw_parts``) on the draws' grid, each warm-started from the
  nominal solution of its scene;
* ``refined``: the calibration's values on ``REFINED_CELLS_PER_D`` (started from the nominal
  solution carried onto the finer grid where the solver can);
* ``merge``: the parts into the model's file, the same variables as one job would write.

A scene the nominal parameters give no speed for is solved by neither (``NOMINAL_REFUSED``).

Usage: ``python -m pipeline.models intruder-draws draws --part 1/2 ...``, ``... refined ...``,
``python -m pipeline.models intruder-draws merge --parts A.nc B.nc --out F.nc``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from continuum.intruder import IntruderSpeed
from pipeline.calibration.parameter_sets import model_parameters, params_of_draw
from pipeline.common import atomic
from pipeline.common.config import load_config
from pipeline.common.formats import open_fields
from pipeline.common.provenance import provenance_attrs
from pipeline.models.intruder import (CELLS_PER_D, DRAWS_CELLS_PER_D, NOMINAL_REFUSED, REFINED_CELLS_PER_D, Scene,
                                      intruder_draws, scenes_of, solve_scenes, pushed_runs)
from pipeline.models.intruder_states import load_states

def draw_parts(n_draws: int, parts: int) -> list[list[int]]:
    """The draw indices of each of ``parts`` jobs (contiguous, sizes differing by one at most)."""
    return [chunk.tolist() for chunk in np.array_split(np.arange(n_draws), parts)]


def _scene_coords(scenes: list[Scene]) -> dict[str, Any]:
    return {"run": ("run", [s.run["run"] for s in scenes], {"long_name": "sheared intruder run"})}


def solve_draws(model: str, params: dict[str, Any], ensemble: dict[str, Any], scenes: list[Scene],
                indices: list[int], nominal: list[IntruderSpeed | None],
                draws_cells_per_d: float = DRAWS_CELLS_PER_D) -> xr.Dataset:
    """Rod speed of each scene for the draws ``indices`` of ``ensemble`` (dims ``draw``, ``run``;
    NaN and ``refused`` 1 where the model refuses the scene, the draw has no parameters for it, or
    the nominal parameters have no speed there), each started from ``nominal``'s solution."""
    predicted = [r is not None for r in nominal]
    speed = np.full((len(indices), len(scenes)), np.nan)
    refused = np.zeros((len(indices), len(scenes)), dtype=np.int8)
    iterations = np.zeros((len(indices), len(scenes)), dtype=np.int64)
    seconds = np.zeros((len(indices), len(scenes)))
    failures: dict[str, str] = {}
    t0 = time.perf_counter()
    for i, k in enumerate(indices):
        draw = ensemble["draws"][k]
        if model in draw.get("failed", {}):
            failures[str(k)] = draw["failed"][model]
            continue
        parameters = model_parameters(params_of_draw(params, draw), model)
        # (a draw that fails is only removed: no limit load to word why, docs/dem_cost.md 30)
        results, reasons = solve_scenes(model, parameters, scenes, draws_cells_per_d, nominal, predicted,
                                        limit_load=False)
        for j, (result, reason) in enumerate(zip(results, reasons)):
            if result is None:
                refused[i, j] = 1
                if reason != NOMINAL_REFUSED:
                    failures.setdefault(str(k), reason[:300])
            else:
                speed[i, j] = result.speed
                iterations[i, j] = result.iterations
                seconds[i, j] = result.solve_seconds
    out = xr.Dataset(coords={"draw": ("draw", np.asarray(indices, dtype=np.int64), {"units": "1", "long_name": "parameter draw"}),
                             **_scene_coords(scenes)})
    out["speed"] = (("draw", "run"), speed, {"units": "m s-1", "long_name": "steady rod speed along +x, per draw"})
    out["refused"] = (("draw", "run"), refused, {"units": "1", "long_name": "1 where the draw has no speed: refused, not converged, or not solved because the calibration's parameters have none there"})
    out["iterations"] = (("draw", "run"), iterations,
                         {"units": "1", "long_name": "fixed-point map evaluations of the draw's 2D solve (warm start)"})
    out["solve_seconds"] = (("draw", "run"), seconds, {"units": "s", "long_name": "solve time of the draw's scene"})
    out.attrs.update({"failures": json.dumps(failures), "draws_seconds": time.perf_counter() - t0,
                      "cells_per_d": draws_cells_per_d})
    return out


def solve_refined(model: str, params: dict[str, Any], scenes: list[Scene], nominal: list[IntruderSpeed | None],
                  refined_cells_per_d: float = REFINED_CELLS_PER_D) -> xr.Dataset:
    """The calibration's values on the grid study's finer grid (``speed_refined``, dim ``run``),
    each scene started from ``nominal``'s solution carried onto it (the solvers that can:
    ``continuum.intruder.regrid``; measured on a 14 d bed, 2 -> 3 cells per d, the same U to
    round-off in about half the CPU time of a cold solve, for critical state and mu(I))."""
    t0 = time.perf_counter()
    results, reasons = solve_scenes(model, model_parameters(params, model), scenes, refined_cells_per_d,
                                    warm=nominal, only=[r is not None for r in nominal])
    out = xr.Dataset(coords=_scene_coords(scenes))
    out["speed_refined"] = ("run", np.array([r.speed if r is not None else np.nan for r in results]),
                            {"units": "m s-1", "long_name": f"calibration's values, {refined_cells_per_d:g} cells per d"})
    # why a scene has no refined speed (its score then has no u_num from the grid study)
    failures = {s.run["run"]: reason[:300] for s, reason in zip(scenes, reasons)
                if reason is not None and reason != NOMINAL_REFUSED}
    out.attrs.update({"refined_seconds": time.perf_counter() - t0, "cells_per_d_refined": refined_cells_per_d,
                      "refined_failures": json.dumps(failures)})
    return out


def merge(model: str, scenes: list[Scene], draws: list[xr.Dataset], refined: xr.Dataset, nominal_cells_per_d: float,
          seed: int, warm_start: bool) -> xr.Dataset:
    """The parts as the model's ``model_draws`` file (draws in order, the grid study, the scenes)."""
    out = xr.concat(draws, dim="draw", data_vars="minimal", combine_attrs="drop").sortby("draw") if draws else xr.Dataset(coords=_scene_coords(scenes))
    out["draw"].attrs.update({"units": "1", "long_name": "parameter draw"})
    out["depth_over_d"] = ("run", np.array([s.depth_over_d for s in scenes], dtype=float),
                           {"units": "1", "long_name": "rod axis below the top wall, in d"})
    out["push_over_yield"] = ("run", np.array([s.push_over_yield for s in scenes], dtype=float),
                              {"units": "1", "long_name": "push over the yield force at the rod's depth"})
    out["force_sweep"] = ("run", np.array([int(s.force_sweep) for s in scenes], dtype=np.int8),
                          {"units": "1", "long_name": "1 for a run of the force sweep"})
    out["speed_refined"] = refined["speed_refined"]
    failures: dict[str, str] = {}
    for part in draws:
        failures.update(json.loads(part.attrs["failures"]))
    # how u_input was made: each draw solved, or propagated (pipeline.models.intruder_sensitivities)
    methods = sorted({str(part.attrs.get("u_input_method", "draws")) for part in draws}) or ["draws"]
    out.attrs.update({"model": model, "case": "intruder", "n_draws": int(out.sizes.get("draw", 0)),
                      "cells_per_d": draws[0].attrs["cells_per_d"] if draws else DRAWS_CELLS_PER_D,
                      "cells_per_d_nominal": nominal_cells_per_d,
                      "cells_per_d_refined": refined.attrs["cells_per_d_refined"],
                      "failures": json.dumps(dict(sorted(failures.items(), key=lambda kv: int(kv[0])))),
                      "draws_seed": seed, "draws_seconds": float(sum(p.attrs["draws_seconds"] for p in draws)),
                      "draws_parts": len(draws), "refined_seconds": refined.attrs["refined_seconds"],
                      # a grid-study part written before 2026-12-05 kept no record of its failures:
                      # null (not known), never an empty record that would claim there were none
                      "refined_failures": refined.attrs.get("refined_failures", json.dumps(None)),
                      "warm_start": int(warm_start), "u_input_method": ",".join(methods)})
    if draws and "sensitivity_failures" in draws[0].attrs:
        out.attrs["sensitivity_failures"] = draws[0].attrs["sensitivity_failures"]
    return out


def predict_draws(model: str, params: dict[str, Any], ensemble: dict[str, Any], runs: list[dict[str, Any]],
                  fields: list[xr.Dataset], n_draws: int, nominal: list[IntruderSpeed | None] | None = None,
                  cells_per_d: float = CELLS_PER_D, refined_cells_per_d: float = REFINED_CELLS_PER_D,
                  draws_cells_per_d: float = DRAWS_CELLS_PER_D) -> xr.Dataset:
    """The draws (one part) and the grid study in one call: ``model_draws``' file of ``model``.
    ``nominal`` are ``predict``'s results on ``cells_per_d``; without them, or when the draws' grid
    differs, the nominal scenes are solved here on the draws' grid."""
    scenes = scenes_of(runs, fields, params)
    if draws_cells_per_d != cells_per_d or nominal is None:
        nominal, _ = solve_scenes(model, model_parameters(params, model), scenes, draws_cells_per_d)
    draws = solve_draws(model, params, ensemble, scenes, list(range(min(n_draws, len(ensemble["draws"])))), nominal,
                        draws_cells_per_d)
    refined = solve_refined(model, params, scenes, nominal, refined_cells_per_d)
    return merge(model, scenes, [draws], refined, cells_per_d, int(ensemble.get("seed", -1)), True)


def _inputs(args: argparse.Namespace) -> tuple[dict, dict, list[Scene]]:
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    runs, fields = pushed_runs(args.runs, args.fields)
    return config, params, scenes_of(runs, fields, params)


def main(argv: list[str] | None = None) -> int:
    # The arguments every part reads: the scenes (runs, fields, params), the model, its nominal states.
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--config", required=True)
    common.add_argument("--params", required=True, type=Path)
    common.add_argument("--model", required=True)
    common.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the intruder runs")
    common.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    common.add_argument("--states", required=True, type=Path,
                        help="the nominal solve's states (models/intruder/MODEL.states.npz)")
    common.add_argument("--out", required=True, type=Path)
    parser = argparse.ArgumentParser(description="An intruder model's draws (u_input) and grid study (u_num).")
    sub = parser.add_subparsers(dest="stage", required=True)
    sub.add_parser("refined", parents=[common], help="the grid study's finer grid")
    d = sub.add_parser("draws", parents=[common], help="one part of the parameter draws")
    d.add_argument("--draws", required=True, type=Path, help="calibration/draws.json")
    d.add_argument("--part", required=True, help="K/N: the K-th of N parts of the model's draws")
    m = sub.add_parser("merge", parents=[common], help="the parts into model_draws/intruder/MODEL.nc")
    m.add_argument("--draws", required=True, type=Path, help="calibration/draws.json (its seed)")
    m.add_argument("--parts", nargs="+", required=True, type=Path, help="the draws parts, then the refined part")
    args = parser.parse_args(argv)
    if args.stage == "draws":
        try:
            k, n = (int(v) for v in args.part.split("/"))
            if not 1 <= k <= n:
                raise ValueError
        except ValueError:
            parser.error(f"--part {args.part!r}: K/N with 1 <= K <= N wanted")
    config, params, scenes = _inputs(args)
    nominal, cells = load_states(args.states, args.model, len(scenes))
    if args.stage == "merge":
        parts = [xr.open_dataset(p).load() for p in args.parts]
        draws = [p for p in parts if "speed" in p]
        refined = [p for p in parts if "speed_refined" in p]
        if len(refined) != 1:
            parser.error(f"--parts: {len(refined)} grid-study parts among {', '.join(map(str, args.parts))}; one wanted")
        seed = int(json.loads(args.draws.read_text()).get("seed", -1))
        out = merge(args.model, scenes, draws, refined[0], cells, seed, True)
    elif args.stage == "refined":
        out = solve_refined(args.model, params, scenes, nominal)
    else:
        ensemble = json.loads(args.draws.read_text())
        n_draws = min(intruder_draws(config, args.model), len(ensemble["draws"]))
        if DRAWS_CELLS_PER_D != cells:
            nominal, _ = solve_scenes(args.model, model_parameters(params, args.model), scenes, DRAWS_CELLS_PER_D)
        out = solve_draws(args.model, params, ensemble, scenes, draw_parts(n_draws, n)[k - 1], nominal)
    out.attrs.update(provenance_attrs(config))
    atomic.write_netcdf(out, args.out)
    print(f"{args.model} {args.stage}: written {args.out}", file=sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
