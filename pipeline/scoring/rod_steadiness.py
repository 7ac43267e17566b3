"""Is a DEM rod's speed steady? Its travel over the production and the production's halves
(issue 55, item 2): ``validation/rod_steadiness.csv`` and the rule the intruder scores use.

**The travel.** ``travel_over_d`` is the distance (in grain diameters d, along +x) the rod moved
over its production window: run.json's ``intruder.displacement`` (x(end) - x(start) of the rod's
unwrapped position series over the window, :func:`pipeline.dem.rod_speed.creep_speed`) over d, or
where a record lacks it the speed times the window's duration. Each half's travel is its speed
(``intruder.halves``) times its duration (``halves.first_duration`` / ``second_duration``, recorded
since issue 55; for older records half the window, within one series sample of the exact split).
:func:`rod_travel` computes it for old and new records alike; new runs store its result in
run.json (:mod:`pipeline.dem.intruder_run`).

**The rule** (:func:`classify`). A rod at rest (``arrested``: its speed within twice its error of
zero, or below the rest speed) is its own class, ``at_rest``: no speed to be steady. A moving rod
is **steady** when both hold:

1. it travelled at least :data:`MIN_TRAVEL_OVER_D` (one grain diameter) during its production;
2. its production's two halves agree: ``|z| < HALVES_Z_LIMIT`` (2), ``z`` the halves' speed
   difference over the root sum of squares of their batch-means errors, read as the normal deviate
   of the same two-sided probability (Student's t with the Welch-Satterthwaite degrees of freedom of
   the halves' blocks, as ``validation/creep_halves.csv``; as a normal deviate where a record does
   not say its blocks). Where the halves were not measured (too few samples) the rule rests on the
   travel alone and says so.

Why both. A rod that has not moved a grain has not left the cage of grains it started in: its U is
the creep of one frozen neighbourhood, not the material's response, and another replica's
neighbourhood gives another speed (the default's rods at the creeping pushes travel 0.07-0.65 d
and their replicas differ beyond their time errors; issue 55). The halves cannot see this: they
share the neighbourhood, so they agree whenever the frozen cage creeps evenly
(:func:`pipeline.dem.rod_speed.production_halves`). The travel cannot see a trend: a rod still
slowing from its start-up, or ageing as the bed compacts, travels several d at a speed that is no
steady state (the default's rods at 0.9 F_y travel 2.7-26 d and their replicas differ tenfold). So
either alone passes a rod whose U is not a steady state; both together are what "steady" means: a
speed averaged over more than one neighbourhood that no longer changes. The cost: a steady rod
fails the halves' test 4.6 % of the time by chance (a 2-sigma test), and a slow rod needs a
production of at least ``d / U`` to count.

A rod that is not steady is scored apart, under its own metric
(:data:`pipeline.scoring.intruder_scores.METRIC_UNSTEADY`), and listed here with the reason.

Usage: ``python -m pipeline.scoring.rod_steadiness --intruder-runs RESULTS/dem/intruder/*/run.json
--out RESULTS/validation/rod_steadiness.csv``
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.common import atomic
from pipeline.common.statistics import normal_equivalent, welch_dof

#: Travel (in d) over the production below which a rod's speed is one neighbourhood's creep.
MIN_TRAVEL_OVER_D = 1.0
#: |z| of the halves' difference at or above which the halves disagree (about 95 %).
HALVES_Z_LIMIT = 2.0
#: The classes of a rod: a steady speed, a speed that is not steady, at rest, or not known (a
#: record without what the rule needs).
CLASSES = ("steady", "unsteady", "at_rest", "unknown")

COLUMNS = ["case", "run", "control", "force_sweep", "depth_target_over_d", "depth_over_d", "push_over_yield",
           "speed", "speed_err", "travel_over_d", "travel_first_half_over_d", "travel_second_half_over_d",
           "first_half_speed", "first_half_speed_err", "second_half_speed", "second_half_speed_err",
           "halves_z", "halves_dof", "halves_z_normal", "arrested", "steady", "rod_class", "reason",
           "push_per_area", "top_wall_shear_stress", "push_budget_share"]


def split_durations(time: np.ndarray) -> tuple[float, float]:
    """Durations (s) of the first and second half of a window as
    :func:`pipeline.dem.rod_speed.production_halves` splits it (at the sample where the window's
    middle time falls, shared by both halves)."""
    time = np.asarray(time, dtype=float)
    middle = int(np.searchsorted(time, 0.5 * (time[0] + time[-1])))
    middle = min(middle, time.size - 1)
    return float(time[middle] - time[0]), float(time[-1] - time[middle])


def _grain(run: dict[str, Any]) -> float:
    d = run.get("d")
    return float(d) if d is not None else math.nan


def rod_travel(run: dict[str, Any]) -> dict[str, Any]:
    """The rod's travel over its production and over each half, in d (module docstring), from a
    run record (run.json: top-level ``d``, and ``intruder``). NaN where the record does not hold
    what a travel needs. ``travel_source``: ``position series`` (the recorded displacement) or
    ``speed x window``."""
    rod, d = run["intruder"], _grain(run)
    window = rod.get("window")
    duration = float(window[1] - window[0]) if window is not None else math.nan
    if rod.get("displacement") is not None:
        travel, source = float(rod["displacement"]) / d, "position series"
    elif rod.get("speed") is not None and math.isfinite(duration):
        travel, source = float(rod["speed"]) * duration / d, "speed x window"
    else:
        travel, source = math.nan, "not known"
    halves = rod.get("halves") or {}
    first = second = math.nan
    if halves:
        t1 = float(halves.get("first_duration", 0.5 * duration))
        t2 = float(halves.get("second_duration", 0.5 * duration))
        first, second = float(halves["first"]) * t1 / d, float(halves["second"]) * t2 / d
    return {"travel_over_d": travel, "travel_first_half_over_d": first, "travel_second_half_over_d": second,
            "travel_source": source}


def halves_deviate(halves: dict[str, Any] | None) -> tuple[float, float, float]:
    """(z, dof, z_normal) of the second half's speed against the first's: ``z = (second - first) /
    sqrt(err_1^2 + err_2^2)``, its Welch-Satterthwaite dof from the halves' ``blocks`` and the normal
    deviate of the same two-sided probability (``z`` itself where ``blocks`` is not recorded).
    NaNs where the halves are missing or an error is not positive."""
    if not halves:
        return math.nan, math.nan, math.nan
    a, ea, b, eb = (float(halves[k]) for k in ("first", "first_err", "second", "second_err"))
    if not (ea > 0 and eb > 0 and all(map(math.isfinite, (a, ea, b, eb)))):
        return math.nan, math.nan, math.nan
    z = (b - a) / math.hypot(ea, eb)
    blocks = float(halves.get("blocks", math.nan))
    if not blocks >= 2:
        return z, math.nan, z
    dof = welch_dof(ea ** 2, eb ** 2, blocks, blocks)
    z_normal, _ = normal_equivalent(z, dof)
    return z, dof, z_normal


def classify(run: dict[str, Any]) -> dict[str, Any]:
    """The rule (module docstring) on one run record: ``steady`` (bool), ``rod_class`` (one of
    :data:`CLASSES`), ``reason`` (a sentence), the travel (:func:`rod_travel`) and the halves'
    deviate (:func:`halves_deviate`)."""
    rod = run["intruder"]
    travel = rod_travel(run)
    z, dof, z_normal = halves_deviate(rod.get("halves"))
    out = travel | {"halves_z": z, "halves_dof": dof, "halves_z_normal": z_normal}
    if rod.get("arrested"):
        return out | {"steady": False, "rod_class": "at_rest",
                      "reason": "at rest: its speed is within twice its error of zero or below the rest speed; "
                                "scored as no motion, not as a speed"}
    moved = travel["travel_over_d"]
    if not math.isfinite(moved):
        return out | {"steady": False, "rod_class": "unknown",
                      "reason": "travel not known: the record has neither the displacement nor the speed, window and d"}
    why = []
    if abs(moved) < MIN_TRAVEL_OVER_D:
        why.append(f"travel {moved:.3g} d < {MIN_TRAVEL_OVER_D:g} d: the creep of one neighbourhood")
    if math.isfinite(z_normal) and abs(z_normal) >= HALVES_Z_LIMIT:
        h = rod["halves"]
        why.append(f"halves differ: {float(h['first']):.3g} then {float(h['second']):.3g} m/s, z = {z_normal:.2f}")
    if why:
        return out | {"steady": False, "rod_class": "unsteady", "reason": "; ".join(why)}
    halves = (f"halves agree (z = {z_normal:.2f})" if math.isfinite(z_normal)
              else "halves not measured (too few samples): travel alone")
    return out | {"steady": True, "rod_class": "steady",
                  "reason": f"travel {moved:.3g} d >= {MIN_TRAVEL_OVER_D:g} d and {halves}"}


def is_steady(run: dict[str, Any]) -> bool:
    """Whether the rod's speed is steady (:func:`classify`)."""
    return bool(classify(run)["steady"])


def _push(rod: dict[str, Any]) -> float:
    if rod.get("push_over_yield") is not None:
        return float(rod["push_over_yield"])
    if rod.get("force") is not None and rod.get("yield_force_here"):
        return float(rod["force"]) / float(rod["yield_force_here"])
    return math.nan


def steadiness_row(run: dict[str, Any]) -> dict[str, Any]:
    """One row of ``validation/rod_steadiness.csv`` (:data:`COLUMNS`)."""
    rod = run["intruder"]
    halves = rod.get("halves") or {}
    verdict = classify(run)
    return {"case": run.get("case", ""), "run": run.get("run", ""), "control": bool(rod.get("control", False)),
            "force_sweep": bool(rod.get("force_sweep", False)),
            "depth_target_over_d": float(rod.get("depth_target_over_d", math.nan)),
            "depth_over_d": float(rod.get("depth_over_d", math.nan)), "push_over_yield": _push(rod),
            "speed": float(rod.get("speed", math.nan)), "speed_err": float(rod.get("speed_err", math.nan)),
            "first_half_speed": float(halves.get("first", math.nan)),
            "first_half_speed_err": float(halves.get("first_err", math.nan)),
            "second_half_speed": float(halves.get("second", math.nan)),
            "second_half_speed_err": float(halves.get("second_err", math.nan)),
            "arrested": bool(rod.get("arrested", False)),
            # the push's share of the cell's shear-stress budget (NaN in records before issue 55)
            "push_per_area": float(rod.get("push_per_area", math.nan)),
            "top_wall_shear_stress": float(rod.get("top_wall_shear_stress", math.nan)),
            "push_budget_share": float(rod.get("push_budget_share", math.nan))} | {k: verdict[k] for k in COLUMNS if k in verdict}


def steadiness_table(runs: list[dict[str, Any]]) -> pd.DataFrame:
    """Every rod of ``runs`` (run records), one row each, in :data:`COLUMNS`, ordered by case and run."""
    rows = [steadiness_row(r) for r in runs]
    table = pd.DataFrame(rows, columns=COLUMNS)
    return table.sort_values(["case", "run"], kind="stable").reset_index(drop=True) if rows else table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="validation/rod_steadiness.csv: each rod's travel over its "
                                     "production, its halves, and whether its speed is steady")
    parser.add_argument("--intruder-runs", nargs="*", default=[], type=Path, help="run.json of the intruder runs")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    runs = [json.loads(p.read_text()) for p in args.intruder_runs]
    table = steadiness_table(runs)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic.write_csv(table, args.out)
    if len(table):
        print(table[["case", "run", "push_budget_share", "travel_over_d", "halves_z_normal", "rod_class",
                     "reason"]].to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
