"""An intruder model's u_input propagated through its speed's parameter sensitivities, not solved
per draw (issue 57, item 1): ``model_draws/intruder/{model}/sensitivities.nc``, a part that
``intruder-draws merge`` takes in place of the solved draws' parts.

For each scene the nominal solve's converged state gives dU/dtheta by the implicit-function
theorem for the Newton yield-stress solvers (``continuum.intruder.sensitivity``: one LU and two
residual evaluations per parameter, no Newton solve), and for NGF (a fixed-point map, no Jacobian)
as central secants of its own warm solves over +- each parameter's spread in the ensemble (two
solves per parameter). Every draw k of the calibration's ensemble (``calibration/draws.json``, all of
them, with the non-local lengths refitted per draw) is carried to a speed to first order in ln U:

    U_k = U_0 exp(s_k),      s_k = (dU/dtheta / U_0) . (theta_k - theta_0),

so that a speed keeps its sign and the spread is a relative one, as the scores read it (log
errors, log-log slopes). Each scene has one real solve beside it, the check: the draw whose |s| is
nearest the spread of s (``check_draw_index``), solved warm from the nominal; its distance from
the propagated speed (``check_dln_linear`` = ln(U_solved / U_0) - s) is the file's own measure of
the propagation's error at a typical draw. A scene whose check fails (:func:`check_passes`: more
than a quarter of the predicted change off) is not propagated: its first draws are solved as
before (``models.intruder_plastic_draws`` / ``intruder_draws``) and the file says why. The check
is not used to correct the draws: on the default
root of 2026-12-06 (docs/dem_cost.md section 25, ``benchmarks/intruder_sensitivities.py``) a
curvature along s fitted through one check draw made the volume-averaged draws worse against
their own solves (largest |d ln U| 0.13 -> 0.14-0.16), the curvature not lying along s alone;
and a check far out is the slowest solve of all.

A scene whose nominal speed is a rigid zone's creep (the model's U is 0) keeps U = 0 in every
draw: a derivative cannot say whether a draw far from the nominal values would yield. The file
says so per scene (``rigid_nominal``) and names its method (``u_input_method = "sensitivities"``).

The draws' parameters are the model's own (``model_parameters`` of each draw); the scenes' cells
(sigma_zz / p, the walls' slip) are the nominal calibration's, as in the solved draws.

Usage: ``python -m pipeline.models intruder-sensitivities --config ... --params ... --model M
--runs ... --fields ... --states models/intruder/M.states.npz --draws calibration/draws.json --out F``.
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

import continuum
from continuum.intruder import GridOptions, IntruderSpeed
from continuum.intruder.sensitivity import has_jacobian, parameter_values, speed_secants, speed_sensitivities
from pipeline.calibration.parameter_sets import model_parameters, params_of_draw
from pipeline.common import atomic
from pipeline.common.config import load_config
from pipeline.common.provenance import provenance_attrs
from pipeline.models.intruder import (CARRIED_TOLERANCE, NOMINAL_REFUSED, Scene, intruder_draws, pushed_runs,
                                     scenes_of, solve_scene)
from pipeline.models.intruder_states import load_states


def draw_parameters(params: dict[str, Any], ensemble: dict[str, Any], model: str
                    ) -> tuple[list[int], np.ndarray, list[str], dict[str, str]]:
    """Every draw of the ensemble: their indices, their parameter offsets from the calibration's
    (draws x parameters, only the parameters some draw moves; a row of NaN for a draw without
    parameters for ``model``, kept so that draw k is row k in every model's file, as the solved
    draws keep it: the verdict pairs models draw by draw), those parameters' dotted paths, and the
    draws without parameters with why (a failed refit)."""
    nominal = parameter_values(model_parameters(params, model))
    indices, rows, failures = [], [], {}
    for draw in ensemble["draws"]:
        k = int(draw["draw"])
        indices.append(k)
        if model in draw.get("failed", {}):
            failures[str(k)] = draw["failed"][model]
            rows.append([np.nan] * len(nominal))
            continue
        drawn = parameter_values(model_parameters(params_of_draw(params, draw), model))
        rows.append([drawn[p] - nominal[p] for p in nominal])
    offsets = np.asarray(rows, dtype=float).reshape(len(rows), len(nominal))
    moved = np.any(np.nan_to_num(offsets) != 0.0, axis=0)
    return indices, offsets[:, moved], [p for p, m in zip(nominal, moved) if m], failures


def log_offsets(speed0: float, gradient: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """s_k = (dU/dtheta / U_0) . (theta_k - theta_0): each draw's first-order change of ln U."""
    return offsets @ (gradient / speed0)


def linearised_speeds(speed0: float, s: np.ndarray) -> np.ndarray:
    """Each draw's speed from the nominal ``speed0`` (m s-1) and its first-order log change ``s``
    (``log_offsets``): U_0 exp(s). A rigid nominal (U_0 = 0) stays 0."""
    if speed0 == 0.0:
        return np.zeros_like(s)
    return speed0 * np.exp(s)


def check_draw_index(s: np.ndarray) -> int:
    """The draw whose |s| is nearest the ensemble's spread of s: a typical draw, whose warm solve
    converges as a draw's does (a draw far out restarts cold: on the default root the
    volume-averaged check at twice the spread cost 3.4 mean draws' CPU time)."""
    finite = np.isfinite(s)
    spread = float(np.std(s[finite], ddof=1)) if finite.sum() > 1 else 0.0
    return int(np.argmin(np.where(finite, np.abs(np.abs(s) - spread), np.inf)))


def gradient_of(model: str, scene: Scene, parameters: Any, result: IntruderSpeed, paths: list[str],
                offsets: np.ndarray, cells_per_d: float) -> dict[str, float]:
    """dU/dtheta of one scene at the nominal ``result``: the implicit-function derivatives of a
    Newton solver, else central secants over +- the draws' own spread of each parameter."""
    grid = GridOptions(cells_per_d=cells_per_d)
    if has_jacobian(model):
        return speed_sensitivities(model, scene.geometry, parameters, scene.rod, scene.cell_length_x, grid,
                                   result.state, paths, case=scene.label)
    usable = offsets[np.all(np.isfinite(offsets), axis=1)]
    if usable.shape[0] == 0:
        raise ValueError("no draw has parameters for the model")
    spread = np.std(usable, axis=0, ddof=1) if usable.shape[0] > 1 else np.abs(usable[0])
    # a secant over +- the spread, held to a quarter of the value: a wide spread (a poorly fixed
    # I_0 or mu_2) would otherwise step out of the law's domain (I_0 <= 0, mu_2 <= mu_s)
    values = parameter_values(parameters)
    steps = {p: float(min(h, 0.25 * abs(values[p]))) for p, h in zip(paths, spread)}
    return speed_secants(model, scene.geometry, parameters, scene.rod, scene.cell_length_x, grid, result, steps,
                         case=scene.label)


def _solve_draw(model: str, params: dict[str, Any], ensemble: dict[str, Any], draw: int, scene: Scene,
                result: IntruderSpeed, cells_per_d: float) -> tuple[float | None, str | None]:
    """The draw's own solve of one scene (warm from the nominal): the check, or a fallback draw."""
    entry = next(d for d in ensemble["draws"] if int(d["draw"]) == draw)
    solved, reason = solve_scene(model, model_parameters(params_of_draw(params, entry), model), scene, cells_per_d,
                                 result, limit_load=False)
    if solved is None:
        return None, reason
    return float(solved.speed), None


#: The check a scene's propagation must pass: |ln(U_solved / U_0) - s| <= 0.25 |s| + 0.01 at the
#: check draw. A quarter of the change it predicts at a typical draw is what the 8 solved draws it
#: replaces could tell (their u_input's sampling error, 1 / sqrt(2 x 7) = 27 %); 0.01 in ln U is ten
#: times the solves' own tolerance on U. On the default root of 2026-12-06 every moving scene
#: passed (the largest |d ln U| / |s|: 0.14 volume-averaged, 0.17 NGF, 0.003 Cosserat); in the
#: reduced run local mu(I)'s fast rods did not (0.117 at s = 0.023: a rod carried near V).
CHECK_RELATIVE, CHECK_FLOOR = 0.25, 0.01


def check_passes(dln: float, s: float) -> bool:
    """Whether the propagation's error ``dln`` at a check draw of first-order change ``s`` is within
    :data:`CHECK_RELATIVE` |s| + :data:`CHECK_FLOOR`."""
    return bool(np.isfinite(dln) and abs(dln) <= CHECK_RELATIVE * abs(s) + CHECK_FLOOR)


def _solve_draws_of_scene(model: str, params: dict[str, Any], ensemble: dict[str, Any], indices: list[int],
                          usable: np.ndarray, scene: Scene, result: IntruderSpeed, cells_per_d: float,
                          n_solved: int) -> tuple[np.ndarray, dict[str, str]]:
    """The first ``n_solved`` usable draws of one scene solved (warm from the nominal), NaN for the
    others: a scene whose propagation failed its check or has no sensitivities."""
    speeds = np.full(len(indices), np.nan)
    reasons: dict[str, str] = {}
    for i in [i for i, ok in enumerate(usable) if ok][:n_solved]:
        solved, reason = _solve_draw(model, params, ensemble, indices[i], scene, result, cells_per_d)
        if solved is None:
            reasons[str(indices[i])] = str(reason)[:300]
        else:
            speeds[i] = solved
    return speeds, reasons


def sensitivities(model: str, params: dict[str, Any], ensemble: dict[str, Any], scenes: list[Scene],
                  nominal: list[IntruderSpeed | None], cells_per_d: float, check: bool = True,
                  fallback_draws: int = 8) -> xr.Dataset:
    """The propagated draws of every scene (``speed``: dims ``draw``, ``run``, as a solved draws
    part), the gradients they came from (``sensitivity``: dims ``run``, ``parameter``) and, with
    ``check``, each scene's check solve: the draw of ``check_draw_index`` solved (warm from the
    nominal), which says how far the propagated speed is from a solution there
    (``check_dln_linear``). A scene whose check fails :func:`check_passes` (or whose check or
    sensitivities have no solution) is not propagated: its first ``fallback_draws`` usable draws
    are solved, as without this method, and the others are NaN with the reason
    (``propagated`` 0, ``sensitivity_failures``)."""
    t0 = time.perf_counter()
    indices, offsets, paths, failures = draw_parameters(params, ensemble, model)
    parameters = model_parameters(params, model)
    n_draws, n_runs = len(indices), len(scenes)
    speed = np.full((n_draws, n_runs), np.nan)
    refused = np.zeros((n_draws, n_runs), dtype=np.int8)
    gradient = np.full((n_runs, len(paths)), np.nan)
    rigid = np.zeros(n_runs, dtype=np.int8)
    first_order = np.full((n_draws, n_runs), np.nan)
    check_draw = np.full(n_runs, -1, dtype=np.int64)
    check_dln, check_speed = np.full(n_runs, np.nan), np.full(n_runs, np.nan)
    propagated = np.zeros(n_runs, dtype=np.int8)
    usable = np.all(np.isfinite(offsets), axis=1)
    seconds = np.zeros(n_runs)
    reasons: dict[str, str] = {}
    for j, (scene, result) in enumerate(zip(scenes, nominal)):
        if result is None or result.state is None:
            refused[:, j] = 1
            reasons[scene.run["run"]] = NOMINAL_REFUSED
            continue
        t1 = time.perf_counter()
        if result.speed == 0.0:
            # the nominal is a rigid zone's creep in the limit: U = 0, and 0 in every draw (module docstring)
            rigid[j], gradient[j] = 1, 0.0
            speed[:, j] = first_order[:, j] = np.where(usable, 0.0, np.nan)
            refused[np.isnan(speed[:, j]), j] = 1
            seconds[j] = time.perf_counter() - t1
            continue
        failed: str | None = None
        try:
            g = gradient_of(model, scene, parameters, result, paths, offsets, cells_per_d)
        except (continuum.ContinuumError, ValueError) as exc:
            # (ValueError: a secant's side outside the law's domain, or no usable draw)
            failed = f"no sensitivities: {exc}"
        else:
            gradient[j] = [g[p] for p in paths]
            s = first_order[:, j] = log_offsets(result.speed, gradient[j], offsets)
            if check and usable.any():
                k = check_draw_index(s)
                solved, reason = _solve_draw(model, params, ensemble, indices[k], scene, result, cells_per_d)
                check_draw[j] = indices[k]
                check_speed[j] = np.nan if solved is None else solved
                if solved is not None and solved * result.speed > 0.0:
                    check_dln[j] = float(np.log(solved / result.speed) - s[k])
                if not check_passes(check_dln[j], s[k]):
                    failed = (f"the propagation failed its check at draw {indices[k]}: ln(U_solved / U_0) - s = "
                              f"{check_dln[j]:.3g} at s = {s[k]:.3g}" if solved is not None else
                              f"the check solve of draw {indices[k]} has no speed: {reason}")
        if failed is None:
            speed[:, j] = linearised_speeds(result.speed, s)
            fastest = float(np.nanmax(np.abs(speed[:, j]), initial=0.0))
            if fastest > scene.geometry.wall_speed * (1.0 + CARRIED_TOLERANCE):
                # a solved draw faster than the wall is refused (pipeline.models.intruder): a
                # propagation that reaches it is not one to trust at this scene
                failed = f"the propagation carries a draw past the wall speed ({fastest:.3g} m/s)"
        if failed is None:
            propagated[j] = 1
        else:
            speed[:, j], draw_reasons = _solve_draws_of_scene(model, params, ensemble, indices, usable, scene, result,
                                                             cells_per_d, fallback_draws)
            reasons[scene.run["run"]] = (f"{failed}; the first {fallback_draws} draws solved instead"
                                         + (f" (not solved: {draw_reasons})" if draw_reasons else ""))[:600]
        refused[np.isnan(speed[:, j]), j] = 1  # a draw without parameters, or not solved
        seconds[j] = time.perf_counter() - t1
    run = ("run", [s.run["run"] for s in scenes], {"long_name": "sheared intruder run"})
    out = xr.Dataset(coords={"draw": ("draw", np.asarray(indices, dtype=np.int64),
                                      {"units": "1", "long_name": "parameter draw"}),
                             "run": run,
                             "parameter": ("parameter", paths, {"long_name": "the model's parameter (dotted path)"})})
    out["speed"] = (("draw", "run"), speed, {"units": "m s-1", "long_name": "steady rod speed along +x per draw, "
                                             "propagated from the nominal solution's sensitivities (first order in ln U)"})
    out["log_offset"] = (("draw", "run"), first_order, {"units": "1", "long_name": "s: the draw's first-order change "
                                                        "of ln U, (dU/dtheta / U_0) . (theta_k - theta_0)"})
    out["refused"] = (("draw", "run"), refused, {"units": "1", "long_name": "1 where the draw has no speed: the "
                                                 "calibration's parameters have none there, or no sensitivities"})
    out["iterations"] = (("draw", "run"), np.zeros_like(refused, dtype=np.int64),
                         {"units": "1", "long_name": "Newton iterations of the draw (none: propagated)"})
    out["solve_seconds"] = (("draw", "run"), np.zeros(speed.shape),
                            {"units": "s", "long_name": "solve time of the draw's scene (none: propagated)"})
    out["speed_nominal"] = ("run", np.array([r.speed if r is not None else np.nan for r in nominal]),
                            {"units": "m s-1", "long_name": "the calibration's speed the draws are propagated from"})
    out["sensitivity"] = (("run", "parameter"), gradient,
                          {"units": "m s-1 per unit of the parameter", "long_name": "dU/dtheta at the nominal solution "
                           "(implicit-function theorem at its last regularisation)"})
    out["propagated"] = ("run", propagated, {"units": "1", "long_name": "1 where the scene's draws are propagated; "
                                             "0 where its check failed and its first draws were solved instead "
                                             "(or the nominal has no speed, or is rigid)"})
    out["rigid_nominal"] = ("run", rigid, {"units": "1", "long_name": "1 where the nominal U is a rigid zone's creep "
                                           "(U = 0): 0 in every draw, not a derivative's statement"})
    out["check_draw"] = ("run", check_draw, {"units": "1", "long_name": "the draw solved to check the propagation "
                                             "(|s| nearest the spread of s; -1: none)"})
    out["check_speed"] = ("run", check_speed, {"units": "m s-1", "long_name": "the check draw's own solve"})
    out["check_dln_linear"] = ("run", check_dln, {"units": "1", "long_name": "ln(U_solved / U_0) - s at the check "
                                                  "draw: the linear form's error in ln U there"})
    out["sensitivity_seconds"] = ("run", seconds, {"units": "s", "long_name": "time of the scene's sensitivities "
                                                   "and check solve"})
    out.attrs.update({"failures": json.dumps(failures), "draws_seconds": time.perf_counter() - t0,
                      "cells_per_d": cells_per_d, "u_input_method": "sensitivities",
                      "sensitivity_failures": json.dumps(reasons)})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="An intruder model's u_input from its speed's parameter sensitivities.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path)
    parser.add_argument("--model", required=True)
    parser.add_argument("--runs", nargs="+", required=True, type=Path, help="run.json of the intruder runs")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="their fields files, same order")
    parser.add_argument("--states", required=True, type=Path, help="the nominal solve's states (models/intruder/MODEL.states.npz)")
    parser.add_argument("--draws", required=True, type=Path, help="calibration/draws.json")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    params = json.loads(args.params.read_text())
    runs, fields = pushed_runs(args.runs, args.fields)
    scenes = scenes_of(runs, fields, params)
    try:
        nominal, cells = load_states(args.states, args.model, len(scenes))
        out = sensitivities(args.model, params, json.loads(args.draws.read_text()), scenes, nominal, cells,
                            fallback_draws=intruder_draws(config, args.model))
    except (ValueError, TypeError, KeyError) as exc:
        print(f"intruder-sensitivities: {args.model}: {exc}", file=sys.stderr)
        return 2
    out.attrs.update(provenance_attrs(config))
    atomic.write_netcdf(out, args.out)
    print(f"{args.model} sensitivities: {int(out.sizes['draw'])} draws propagated over {', '.join(map(str, out.parameter.values))} "
          f"in {out.attrs['draws_seconds']:.1f} s; written {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
