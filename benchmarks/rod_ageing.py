"""Benchmark (issue 55, item 2): how a creeping rod's speed falls with the length of its production
(its ageing), and what the steady rule's grain of travel costs in strain.

For every moving rod of an output root's intruder cases (run.json and the rod's position series in
``dem/<case>/<run>/series/intruder_*.txt``) it measures, from the production window alone:

- the speed over the production's quarters (``U_q1`` .. ``U_q4``, the displacement over the quarter
  over its duration) and the ageing exponent ``a`` of ``U ~ t^a``, the least-squares slope of
  log10 U_q against log10 of the quarter's middle time, time counted from the start of the rod's
  shear in its bed (the insertion): 0 for a steady rod, negative for a rod that slows as the cage
  around it compacts;
- the speed over the production's first 1/8, 1/4, 1/2 and the whole (``U_f``), over the whole
  production's speed: what a shorter production would have reported;
- the strain (wall displacement over the bed height) after which the rod had travelled one grain
  diameter, ``strain_to_1d``: the production the steady rule asks of it.

Per case and push it prints the median of each over the replicas, with the replicas' range; a group
mean of the ageing exponent with its standard error (the replicas' scatter), and whether it differs
from zero (|mean| > 2 errors). Run as::

    .venv/bin/python benchmarks/rod_ageing.py results [--case intruder] [--out FILE.csv]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.dem.intruder_run import read_intruder_series, unwrap  # noqa: E402

#: Prefixes of the production whose speeds are compared with the whole production's.
PREFIXES = (0.125, 0.25, 0.5, 1.0)
QUARTERS = 4


def rod_series(run_dir: Path, cell_x: float) -> pd.DataFrame:
    """The rod's position series of every chunk of a run, in time order, x unwrapped (m)."""
    files = sorted((run_dir / "series").glob("intruder_*.txt"))
    if not files:
        raise FileNotFoundError(f"{run_dir}/series: no intruder_*.txt position series")
    data = pd.concat([read_intruder_series(f) for f in files], ignore_index=True)
    data = data.sort_values("time", kind="stable").drop_duplicates("time").reset_index(drop=True)
    data["x"] = unwrap(data["x"].to_numpy(), cell_x)
    return data


def _speed(t: np.ndarray, x: np.ndarray, t0: float, t1: float) -> float:
    inside = (t >= t0) & (t <= t1)
    if inside.sum() < 2:
        return math.nan
    ti, xi = t[inside], x[inside]
    return float((xi[-1] - xi[0]) / (ti[-1] - ti[0]))


def rod_ageing(run: dict[str, Any], series: pd.DataFrame) -> dict[str, Any]:
    """The ageing measures of one rod (module docstring) from its run record and position series."""
    d, v = float(run["d"]), float(run["wall_speed"])
    height = float(run.get("settled_gap") or math.nan)
    t0, t1 = (float(s) for s in run["production_window"])
    t, x = series["time"].to_numpy(), series["x"].to_numpy()
    insertion = float(t[0])  # the first shear chunk's first sample: the rod's start in its bed
    duration = t1 - t0
    whole = _speed(t, x, t0, t1)
    out: dict[str, Any] = {"case": run["case"], "run": run["run"], "push_over_yield": run["intruder"].get("push_over_yield"),
                           "push_budget_share": run["intruder"].get("push_budget_share", math.nan),
                           "production_strain": duration * v / height, "U": whole,
                           "travel_over_d": (x[t <= t1][-1] - x[t >= t0][0]) / d}
    mids, speeds = [], []
    for q in range(QUARTERS):
        a, b = t0 + q * duration / QUARTERS, t0 + (q + 1) * duration / QUARTERS
        u = _speed(t, x, a, b)
        out[f"U_q{q + 1}"] = u
        mids.append(0.5 * (a + b) - insertion)
        speeds.append(u)
    speeds_a = np.array(speeds)
    ok = speeds_a > 0
    out["ageing_exponent"] = (float(np.polyfit(np.log10(np.array(mids)[ok]), np.log10(speeds_a[ok]), 1)[0])
                              if ok.sum() >= 3 else math.nan)
    for f in PREFIXES:
        out[f"U_{f:g}_over_U"] = _speed(t, x, t0, t0 + f * duration) / whole if whole else math.nan
    moved = np.abs(x[t >= t0] - x[t >= t0][0])
    reached = np.nonzero(moved >= d)[0]
    out["strain_to_1d"] = (float((t[t >= t0][reached[0]] - t0) * v / height) if reached.size else math.nan)
    return out


def ageing_table(root: Path, cases: list[str]) -> pd.DataFrame:
    rows = []
    for case in cases:
        for path in sorted((root / "dem" / case).glob("*/run.json")):
            run = json.loads(path.read_text())
            rod = run.get("intruder") or {}
            if rod.get("control") or rod.get("arrested"):
                continue
            rows.append(rod_ageing(run, rod_series(path.parent, float(run["cell"][0]))))  # cell: [L_x, L_y] (m)
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per case and push: medians over the rods, and the ageing exponent's mean and standard error."""
    table = table.assign(scene=table["run"].str.replace(r"-r\d+$", "", regex=True))
    out = []
    for (case, scene), g in table.groupby(["case", "scene"], sort=True):
        a = g["ageing_exponent"].dropna()
        err = float(a.std(ddof=1) / math.sqrt(len(a))) if len(a) >= 2 else math.nan
        row = {"case": case, "scene": scene, "rods": len(g), "push_budget_share": g["push_budget_share"].median(),
               "travel_over_d": g["travel_over_d"].median(), "production_strain": g["production_strain"].median(),
               "strain_to_1d": g["strain_to_1d"].median(), "ageing_exponent": float(a.mean()) if len(a) else math.nan,
               "ageing_exponent_err": err,
               "ageing_differs_from_0": bool(len(a) >= 2 and abs(a.mean()) > 2 * err)}
        for f in PREFIXES[:-1]:
            row[f"U_{f:g}_over_U"] = g[f"U_{f:g}_over_U"].median()
        out.append(row)
    return pd.DataFrame(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--case", action="append", help="intruder case(s) (default: every dem/<case> with intruder runs)")
    parser.add_argument("--out", type=Path, help="write the per-rod table here (CSV)")
    args = parser.parse_args(argv)
    cases = args.case or sorted(p.parent.parent.name for p in args.root.glob("dem/*/D*/run.json"))
    cases = sorted(set(cases))
    if not cases:
        print(f"error: {args.root}/dem: no intruder runs (dem/<case>/D*/run.json)", file=sys.stderr)
        return 2
    table = ageing_table(args.root, cases)
    if table.empty:
        print(f"error: {args.root}: no moving rod in {', '.join(cases)}", file=sys.stderr)
        return 2
    pd.set_option("display.width", 200)
    print("Per rod (U in m/s; strain = wall displacement / bed height):")
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    print("\nPer scene (medians over the replicas; ageing exponent a of U ~ t^a: mean +- standard error):")
    print(summary(table).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    a = table["ageing_exponent"].dropna()
    print(f"\nAll {len(table)} moving rods: ageing exponent {a.mean():+.3f} +- {a.std(ddof=1) / math.sqrt(len(a)):.3f} "
          f"(mean +- standard error over the rods); U over the first 1/8, 1/4, 1/2 of the production over U over all of it "
          f"(medians): " + ", ".join(f"{table[f'U_{f:g}_over_U'].median():.2f}" for f in PREFIXES[:-1])
          + f"; rods past 1 d: {int(np.isfinite(table['strain_to_1d']).sum())} of {len(table)}, median travel "
          f"{table['travel_over_d'].median():.2f} d in a median {table['production_strain'].median():.2f} strain units")
    if args.out:
        table.to_csv(args.out, index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
