"""Benchmark (issue 55, item 1): does the rod's speed feel the periodic cell's length?

Reads one output root that holds the same rod (depth, push F) in two intruder cases whose cells
differ in length only (``config/studies/rod_cell_length.yaml``: ``intruder``, 12 d, its force-sweep
rods ``D5.5-F0.11``; ``intruder_long``, 24 d, its ``D5.5`` rods at the same push). A local push gives
the same speed in both: the push's share of the wall's shear-stress budget halves with L_x.

DEM: per cell, the replicas' mean of log10 U with its standard error (their scatter), the push's
share of the budget (run.json ``push_budget_share``) and the rods' travel; the difference of the
two means against its combined error (Welch's t, two-sided p). Models: each model's own 2D solve
in each cell (``models/<case>/<model>.nc``; the 12 d cell's force-sweep speed at the push, the
24 d cell's depth-sweep speed), log10 of their ratio, and the same for the drift at F = 0 where
the files hold it. Run as::

    .venv/bin/python benchmarks/rod_cell_length.py results-rod-cell
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from scipy import stats

SHORT = ("intruder", "D5.5-F0.11")
LONG = ("intruder_long", "D5.5")


def dem_rods(root: Path, case: str, scene: str) -> pd.DataFrame:
    """The rods of one scene (its replicas' run.json) in a case: speed, share, travel, class."""
    rows = []
    for path in sorted((root / "dem" / case).glob(f"{scene}-r*/run.json")):
        run = json.loads(path.read_text())
        rod = run["intruder"]
        rows.append({"case": case, "run": run["run"], "cell_x_over_d": run["cell"][0] / run["d"],
                     "speed": rod["speed"], "speed_err": rod["speed_err"], "arrested": rod["arrested"],
                     "travel_over_d": rod.get("travel_over_d", math.nan),
                     "push_budget_share": rod.get("push_budget_share", math.nan),
                     "rod_class": (rod.get("steadiness") or {}).get("rod_class", "unknown")})
    if not rows:
        raise FileNotFoundError(f"{root}/dem/{case}: no runs {scene}-r<k>")
    return pd.DataFrame(rows)


def log_mean(speeds: np.ndarray) -> tuple[float, float]:
    """Mean of log10 U over the replicas and its standard error (their scatter)."""
    logs = np.log10(np.asarray(speeds, dtype=float))
    err = float(logs.std(ddof=1) / math.sqrt(logs.size)) if logs.size >= 2 else math.nan
    return float(logs.mean()), err


def model_speed(root: Path, case: str, model_file: Path, push: float, depth: float) -> tuple[float, float]:
    """(U, U_drift) of a model in one cell at the study's rod: the force sweep's speed at ``push``
    where the case has a sweep there, else the depth sweep's at ``depth``."""
    with xr.open_dataset(model_file) as ds:
        if case == SHORT[0]:
            u = float(ds["sweep_speed"].sel(push_over_yield=push, method="nearest"))
            drift = (float(ds["sweep_drift_speed"].sel(push_over_yield=push, method="nearest"))
                     if "sweep_drift_speed" in ds else math.nan)
        else:
            u = float(ds["speed"].sel(depth_over_d=depth, method="nearest"))
            drift = float(ds["drift_speed"].sel(depth_over_d=depth, method="nearest")) if "drift_speed" in ds else math.nan
    return u, drift


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--push", type=float, default=0.11, help="the rods' push over the yield force at their depth")
    parser.add_argument("--depth", type=float, default=5.5, help="the rods' depth below the top wall, in d")
    args = parser.parse_args(argv)
    try:
        short, long_ = dem_rods(args.root, *SHORT), dem_rods(args.root, *LONG)
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    pd.set_option("display.width", 200)
    print("DEM rods:")
    both = pd.concat([short, long_], ignore_index=True)
    print(both.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    moving = [g[~g["arrested"] & (g["speed"] > 0)] for g in (short, long_)]
    (m1, e1), (m2, e2) = (log_mean(g["speed"].to_numpy()) for g in moving)
    n1, n2 = len(moving[0]), len(moving[1])
    diff, err = m2 - m1, math.hypot(e1, e2)
    t_stat = diff / err if err > 0 else math.nan
    dof = (e1 ** 2 + e2 ** 2) ** 2 / (e1 ** 4 / max(n1 - 1, 1) + e2 ** 4 / max(n2 - 1, 1)) if err > 0 else math.nan
    p = float(2 * stats.t.sf(abs(t_stat), dof)) if math.isfinite(t_stat) else math.nan
    print(f"\nDEM log10 U: {SHORT[0]} (12 d) {m1:.3f} +- {e1:.3f} ({n1} rods, share {short['push_budget_share'].mean():.3f}); "
          f"{LONG[0]} (24 d) {m2:.3f} +- {e2:.3f} ({n2} rods, share {long_['push_budget_share'].mean():.3f})")
    print(f"DEM 24 d - 12 d: {diff:+.3f} +- {err:.3f} decade, Welch t = {t_stat:.2f} ({dof:.1f} dof), p = {p:.3f}: "
          f"{'the same speed within the replicas scatter (p >= 0.05)' if p >= 0.05 else 'the speed depends on the cell length (p < 0.05)'}")
    rows = []
    for path in sorted((args.root / "models" / SHORT[0]).glob("*.nc")):
        model = path.stem
        other = args.root / "models" / LONG[0] / path.name
        if not other.exists():
            continue
        try:
            u1, d1 = model_speed(args.root, SHORT[0], path, args.push, args.depth)
            u2, d2 = model_speed(args.root, LONG[0], other, args.push, args.depth)
        except KeyError:
            continue
        rows.append({"model": model, "U_12d": u1, "U_24d": u2,
                     "log10_U24_over_U12": math.log10(u2 / u1) if u1 > 0 and u2 > 0 else math.nan,
                     "drift_12d": d1, "drift_24d": d2})
    if rows:
        print("\nModels (each its own 2D solve in each cell, m/s):")
        print(pd.DataFrame(rows).to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
