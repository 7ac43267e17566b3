"""How far down the creep is resolved: per run, per case's replica mean, against the case's target.

A gravity bed's creep speed falls about exponentially below the sheared layer; the laws that tell
the models apart act on that tail (docs/models.md), so a case counts for as many decades of u_x / V
as its replica mean resolves above twice its error, walking down from the fastest point
(:func:`pipeline.common.observables.decades_resolved`). Written to
``validation/creep_resolution.csv`` (:data:`RESOLUTION_COLUMNS`): one row per run, then one per
case's replica mean with what stops its walk and, where the config names targets
(``scoring.creep_decades``), what reaching the case's target would take.

What it would take is read off the mean's own profile: the depth at which the mean has fallen the
target's decades below its fastest point, and the largest ``2 err / u`` between there and the
top, by which the mean's error must fall for every point of that stretch to be resolved. Both of
the mean's errors (the replicas' combined time errors and their scatter, each over sqrt(n)) fall
as one over the square root of the number of replicas, so ``n * (2 err / u)^2`` replicas reach
the target. A longer production lowers the time errors only, and less than one over the root of
its length while the deep creep still slows (docs/dem.md, "The deep creep ages"): the replica
count is the estimate, a production length the same factor would be a lower bound.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common.observables import (creep_speed, decades_resolved, replica_mean_parts, resolution, resolved_walk,
                                         walk_order)
from pipeline.scoring.replicas import interior, top_plane


@dataclass(frozen=True)
class DecadesTargets:
    """Decades of u_x / V a case's replica mean must resolve: the calibration case's (the non-local
    lengths are fitted on its creep) and every held-out case's (``scoring.creep_decades``)."""

    calibration_case: str
    calibration: float
    held_out: float

    def of(self, case: str) -> tuple[str, float]:
        """The case's role (``calibration`` or ``held_out``) and its target. Of the gravity cases only
        ``calibration.nonlocal_case`` feeds the calibration, so this is ``scores.csv``'s role, read
        from the config (this table does not wait for the calibration's ``params.json``)."""
        return ("calibration", self.calibration) if case == self.calibration_case else ("held_out", self.held_out)

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> "DecadesTargets | None":
        """The config's targets, or None where it names none (then no row carries a target)."""
        targets = (config.get("scoring") or {}).get("creep_decades")
        if targets is None:
            return None
        return cls(config["calibration"]["nonlocal_case"], float(targets["calibration"]), float(targets["held_out"]))


#: Columns of ``validation/creep_resolution.csv``: per run, then per case's replica mean.
RESOLUTION_COLUMNS = ["case", "run", *(f"{k}_{s}" for s in ("u_x", "u_x_disp", "best") for k in ("decades", "slowest_over_v")),
                      "deepest_interior_over_d", "decades_in_bed", "limited_by",
                      "role", "decades_target", "target_met", "target_depth_over_d", "error_over_needed",
                      "replicas", "replicas_for_target"]


def creep_resolution(paths: list[Path], targets: DecadesTargets | None = None) -> pd.DataFrame:
    """Per run (gravity cases): decades of u_x / V resolved above 2 sigma inside the walls, from
    the snapshot-averaged ``u_x``, from ``u_x_disp``, and from the pointwise better of the two (the
    scores' choice, :func:`pipeline.common.observables.creep_speed`), with the slowest resolved
    u_x / V of each; then each case's replica mean (:func:`replica_mean_resolution`)."""
    rows = []
    for path in sorted(paths):
        with xr.open_dataset(path) as ds:
            if float(ds.attrs.get("gravity", 0.0)) <= 0 or "u_x_disp" not in ds:
                continue
            mask = interior(ds)
            v = float(ds.attrs["wall_speed"])
            best_u, best_err, _ = creep_speed(ds)
            sources = {"u_x": (ds["u_x"].values, ds["u_x_err"].values),
                       "u_x_disp": (ds["u_x_disp"].values, ds["u_x_disp_err"].values),
                       "best": (best_u, best_err)}
            row = {"case": path.parent.name, "run": path.stem}
            for name, (u, err) in sources.items():
                decades, slowest = decades_resolved(u[mask], err[mask], v)
                row[f"decades_{name}"] = decades
                row[f"slowest_over_v_{name}"] = slowest
            rows.append(row)
    rows.extend(replica_mean_resolution(paths, targets))
    return pd.DataFrame(rows, columns=RESOLUTION_COLUMNS)


def target_reach(mean: np.ndarray, err: np.ndarray, depth_over_d: np.ndarray, target: float) -> dict[str, float]:
    """What resolving ``target`` decades of the profile ``mean`` (error ``err``, at ``depth_over_d``
    below the top contact plane) takes (module docstring).

    Returns ``target_depth_over_d``, the first depth, walking down from the fastest point, where
    the mean is ``target`` decades below it (NaN when the profile never falls that far: the bed
    is too shallow for the target), and ``error_over_needed``, the largest ``err / (u / 2)`` from
    the fastest point to there: below 1 the target is resolved, above it the mean's error must
    fall by this factor."""
    order = walk_order(mean)
    out = {"target_depth_over_d": math.nan, "error_over_needed": math.nan}
    if order.size == 0 or not mean[order[0]] > 0:
        return out
    with np.errstate(divide="ignore", invalid="ignore"):
        below = np.log10(mean[order[0]] / mean[order])
        ratio = 2.0 * err[order] / mean[order]
    reached = np.flatnonzero(np.isfinite(below) & (below >= target))
    if reached.size == 0:
        return out
    stretch = order[:reached[0] + 1]
    # A point with no speed or no error cannot be resolved by any count of replicas.
    ratio = np.where((mean[order] > 0) & np.isfinite(ratio), ratio, np.inf)[:reached[0] + 1]
    return {"target_depth_over_d": float(depth_over_d[stretch[-1]]), "error_over_needed": float(np.max(ratio))}


def replica_mean_resolution(paths: list[Path], targets: DecadesTargets | None = None) -> list[dict[str, object]]:
    """The same for the mean of each case's replicas (run ids ``r<k>``), aligned by depth below
    the top wall: the case's creep profile. Its error is the larger of the combined stated errors
    and the replicas' scatter over sqrt(n) (the replicas differ by more than their stated errors
    where the packing's structure is frozen).

    What stops the resolved stretch, ``limited_by``: ``wall margin`` where it reaches the deepest
    point inside the walls' margin (``deepest_interior_over_d``, d below the top contact plane:
    no precision resolves more of this bed, whose mean there spans ``decades_in_bed``),
    ``stated errors`` where the combined time errors exceed the scatter at the first unresolved
    point (a longer production or more replicas resolve deeper), ``replica scatter`` where the
    scatter does (only more replicas do).

    With ``targets``: the case's ``role`` and ``decades_target``, ``target_met``, and
    :func:`target_reach`'s depth and error factor with the ``replicas_for_target`` it implies,
    ``ceil(n * error_over_needed^2)`` (no fewer than the n there are; NaN where the bed is too
    shallow for the target)."""
    rows = []
    for case in sorted({p.parent.name for p in paths}):
        files = sorted(p for p in paths if p.parent.name == case and p.stem.startswith("r") and p.stem[1:].isdigit())
        if len(files) < 2:
            continue
        sets = [xr.open_dataset(f) for f in files]
        try:
            if float(sets[0].attrs.get("gravity", 0.0)) <= 0 or any("u_x_disp" not in ds for ds in sets):
                continue
            first = sets[0]
            d = float(first.attrs["d"])
            mask = interior(first)
            depth = top_plane(first) - first.z.values[mask]
            n = len(files)
            mean, stated, scatter = replica_mean_parts(depth, [(top_plane(ds) - ds.z.values, *creep_speed(ds)[:2])
                                                               for ds in sets])
            err = np.fmax(stated, scatter)
            top, walked, stop = resolved_walk(mean, err)
            decades, slowest = resolution(mean, top, walked, float(first.attrs["wall_speed"]))
            deepest = int(np.nanargmax(np.where(np.isfinite(mean), depth, -np.inf)))
            if stop < 0:
                limited_by = "wall margin"
            else:
                limited_by = "stated errors" if stated[stop] >= scatter[stop] else "replica scatter"
            in_bed = (float(math.log10(mean[top] / mean[deepest])) if top >= 0 and mean[deepest] > 0 else math.nan)
            row: dict[str, object] = {"case": case, "run": f"mean of {n} replicas", "decades_best": decades,
                                      "slowest_over_v_best": slowest, "deepest_interior_over_d": float(depth[deepest] / d),
                                      "decades_in_bed": in_bed, "limited_by": limited_by, "replicas": n}
            if targets is not None:
                role, target = targets.of(case)
                reach = target_reach(mean, err, depth / d, target)
                factor = reach["error_over_needed"]
                row |= {"role": role, "decades_target": target, "target_met": bool(decades >= target), **reach,
                        "replicas_for_target": (max(n, math.ceil(n * factor**2 - 1e-9)) if math.isfinite(factor)
                                                else math.nan)}
            rows.append(row)
        finally:
            for ds in sets:
                ds.close()
    return rows
