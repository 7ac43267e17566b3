"""The drift and the push apart (issue 55, item 3): each model's own solve at F = 0, and U - U_drift.

A sheared rod moves even unpushed: the creep of the bed carries it. What the push adds is
``U - U_drift``, U_drift the speed of the same rod at the same depth at F = 0. For a model that is
its **own F = 0 solve**: the scene of the rod, pushed by nothing (:func:`zero_force`), solved by
the label's 2D solver like any other scene (:func:`solve_drifts`). It is not the linear response
``IntruderSpeed.drift_speed`` the 2D framework reports (``continuum/intruder/framework.py``
``_rod_outputs``: the rod's speed at F = 0 *with the pushed solve's converged viscosity field*,
``U = U_drift + F / K`` exactly for ``ngf_frozen`` only); that one is kept beside it as
``drift_speed_linear`` (NaN for the rate-independent models, which have no linear response).

Variables in ``models/intruder/{model}.nc`` (written by :func:`add_drifts`, read by
:func:`drift_table`):

- ``drift_speed`` on ``depth_over_d``: the F = 0 solve at each depth of the depth sweep (m s-1;
  NaN where the model refuses or does not converge: ``drift_refused`` attribute, a JSON list);
- ``sweep_drift_speed`` on ``push_over_yield``: the F = 0 solve at each force-sweep scene's depth
  (one solve per depth, shared by its pushes);
- ``drift_speed_linear``, ``sweep_drift_speed_linear``: the linear response, where the solver
  gives one.

A file without them (every file before issue 55) gives no drift: :func:`drift_table` returns
None, and the report says the drift is not stored.
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

#: Variables of a model's intruder file (module docstring).
DRIFT = "drift_speed"
SWEEP_DRIFT = "sweep_drift_speed"
LINEAR = "drift_speed_linear"
SWEEP_LINEAR = "sweep_drift_speed_linear"
DRIFT_COLUMNS = ["model", "sweep", "depth_over_d", "push_over_yield", "speed", "drift_speed", "speed_minus_drift",
                 "drift_speed_linear"]


def zero_force(scene: Any) -> Any:
    """The same scene (:class:`pipeline.models.intruder.Scene`) with the rod pushed by nothing."""
    return dataclasses.replace(scene, rod=dataclasses.replace(scene.rod, force_per_length=0.0),
                               label=f"{scene.label} at F = 0")


def solve_drifts(model: str, parameters: Any, scenes: list[Any], cells_per_d: float,
                 results: list[Any] | None = None, solve_scene: Any = None) -> tuple[dict[float, float], list[str]]:
    """The label's own F = 0 speed (m s-1) at each target depth of ``scenes`` (one solve per depth,
    from its first scene's geometry and rod; warm from that scene's nominal result in ``results``
    where there is one), and the reasons of the depths it refuses (their drift is NaN).
    ``solve_scene(model, parameters, scene, cells_per_d, warm)``: the stage's scene solver
    (``pipeline.models.intruder.solve_scene``, which imports this module: it hands itself in)."""
    if solve_scene is None:
        raise TypeError("solve_drifts needs the stage's solve_scene")

    drifts: dict[float, float] = {}
    refused: list[str] = []
    for k, scene in enumerate(scenes):
        if scene.target in drifts:
            continue
        warm = results[k] if results is not None and results[k] is not None and results[k].state is not None else None
        result, reason = solve_scene(model, parameters, zero_force(scene), cells_per_d, warm)
        drifts[scene.target] = float(result.speed) if result is not None else math.nan
        if reason is not None:
            refused.append(f"F = 0: {reason}")
    return drifts, refused


def linear_drifts(results: list[Any]) -> list[float]:
    """The linear-response drift (``IntruderSpeed.drift_speed``, m s-1) of each nominal
    result, NaN where there is none."""
    return [float(r.drift_speed) if r is not None else math.nan for r in results]


def add_drifts(out: xr.Dataset, scenes: list[Any], drifts: dict[float, float],
               linear: list[float] | None = None, refused: list[str] | None = None) -> xr.Dataset:
    """``out`` (a model's intruder file, :func:`pipeline.models.intruder.predict`) with the drift
    variables of the module docstring: each depth of ``depth_over_d`` and each push of
    ``push_over_yield`` matched to its scene, the scene's target depth to its drift."""
    depth_scenes = [(s, k) for k, s in enumerate(scenes) if not s.force_sweep]
    sweep_scenes = [(s, k) for k, s in enumerate(scenes) if s.force_sweep]

    def pick(coord: np.ndarray, pool: list[tuple[Any, int]], key: str) -> tuple[np.ndarray, np.ndarray]:
        drift, lin = np.full(coord.size, np.nan), np.full(coord.size, np.nan)
        for i, value in enumerate(coord):
            hit = [(s, k) for s, k in pool if np.isclose(getattr(s, key), value, rtol=0.0, atol=1e-9)]
            if hit:
                s, k = hit[0]
                drift[i] = drifts.get(s.target, math.nan)
                lin[i] = linear[k] if linear is not None else math.nan
        return drift, lin

    out = out.copy()
    units = {"units": "m s-1"}
    drift, lin = pick(out.depth_over_d.values, depth_scenes, "depth_over_d")
    out[DRIFT] = ("depth_over_d", drift, units | {"long_name": "rod speed at F = 0: the model's own solve at this "
                                                  "depth (NaN: refused)"})
    if linear is not None:
        out[LINEAR] = ("depth_over_d", lin, units | {"long_name": "linear-response drift of the pushed solve (U at "
                                                     "F = 0 with its converged viscosity; NaN: none)"})
    if "push_over_yield" in out.coords:
        drift, lin = pick(out.push_over_yield.values, sweep_scenes, "push_over_yield")
        out[SWEEP_DRIFT] = ("push_over_yield", drift, units | {"long_name": "rod speed at F = 0 at the force sweep's "
                                                               "depth: the model's own solve"})
        if linear is not None:
            out[SWEEP_LINEAR] = ("push_over_yield", lin, units | {"long_name": "force sweep: linear-response drift "
                                                                  "of the pushed solve"})
    out.attrs["drift_refused"] = json.dumps(list(refused or []))
    return out


def drift_table(path: Path) -> pd.DataFrame | None:
    """A model file's speeds against its drift, one row per scene (:data:`DRIFT_COLUMNS`;
    ``speed_minus_drift`` where both are finite), or None when the file holds no drift (or is
    not there)."""
    path = Path(path)
    if not path.exists():
        return None
    with xr.open_dataset(path) as sol:
        if DRIFT not in sol and SWEEP_DRIFT not in sol:
            return None
        rows = []
        for sweep, coord, speed, drift, lin in ((False, "depth_over_d", "speed", DRIFT, LINEAR),
                                                (True, "push_over_yield", "sweep_speed", SWEEP_DRIFT, SWEEP_LINEAR)):
            if drift not in sol or speed not in sol:
                continue
            for i, x in enumerate(sol[coord].values):
                u, ud = float(sol[speed].values[i]), float(sol[drift].values[i])
                rows.append({"model": str(sol.attrs.get("model", path.stem)), "sweep": sweep,
                             "depth_over_d": math.nan if sweep else float(x),
                             "push_over_yield": float(x) if sweep else math.nan,
                             "speed": u, "drift_speed": ud,
                             "speed_minus_drift": u - ud if math.isfinite(u) and math.isfinite(ud) else math.nan,
                             "drift_speed_linear": float(sol[lin].values[i]) if lin in sol else math.nan})
    return pd.DataFrame(rows, columns=DRIFT_COLUMNS)
