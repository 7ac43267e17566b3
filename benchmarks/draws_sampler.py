"""Benchmark (issue 57, item 1): u_input from fewer, quasi-random parameter draws.

Run as ``python benchmarks/draws_sampler.py ROOT REFERENCE --out OUT [--draws 16] [--scrambles 4]``.
REFERENCE is a root of ROOT's DEM scored with today's draws (``calibration.draws`` pseudo-random, 64
by default; e.g. ``benchmarks/wall_before_after.py``'s ``rheometer`` root). For each of
``--scrambles`` Sobol scrambles (the config's seed + k) the planar post-DEM stages run again with
``calibration.draws`` = ``--draws`` and ``calibration.draw_sampler: sobol``
(:mod:`pipeline.calibration.samplers`), and every planar score's ``u_input`` is set against the
reference's: the ratio per score, and whether the scrambles' mean lies within the two estimates'
sampling errors (the reference's: u / sqrt(2 (n - 1)) for n random draws; the Sobol estimate's: the
scrambles' standard error). Prints the table and the planar model stage's CPU seconds of both.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from wall_before_after import one_law  # noqa: E402


def model_seconds(root: Path) -> float:
    """CPU seconds the planar model solves took (nominal + draws + refined), from the draws files."""
    import xarray as xr

    total = 0.0
    for path in sorted((root / "model_draws").glob("*/*.nc")):
        with xr.open_dataset(path) as ds:
            total += float(np.nansum(ds["solve_seconds"].values))
    return total


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("reference", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--draws", type=int, default=16)
    parser.add_argument("--scrambles", type=int, default=4)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--summary-only", action="store_true")
    args = parser.parse_args(argv)
    config = json.loads((args.root / "config.effective.json").read_text())
    law = config.get("calibration", {}).get("wall_slip", "rheometer")
    roots = [args.out / f"sobol{args.draws}-s{k}" for k in range(args.scrambles)]
    if not args.summary_only:
        for k, out in enumerate(roots):
            one_law(args.root, out, law, args.jobs, {"seed": int(config["seed"]) + k,
                                                      "calibration": {"draws": args.draws, "draw_sampler": "sobol"}})
    key = ["case", "model", "metric"]
    ref = pd.read_csv(args.reference / "scores.csv").set_index(key)
    n_ref = json.loads((args.reference / "calibration" / "draws.json").read_text())["n_draws"]
    runs = pd.concat([pd.read_csv(r / "scores.csv").set_index(key)["u_input"].rename(r.name) for r in roots], axis=1)
    table = pd.DataFrame({"u_input_ref": ref["u_input"]}).join(runs, how="inner")
    cols = [r.name for r in roots]
    table["sobol_mean"] = table[cols].mean(axis=1)
    table["sobol_sem"] = table[cols].std(axis=1, ddof=1) / math.sqrt(len(cols)) if len(cols) > 1 else np.nan
    table["ref_err"] = table["u_input_ref"] / math.sqrt(2 * (n_ref - 1))
    table["ratio"] = table["sobol_mean"] / table["u_input_ref"]
    table["z"] = (table["sobol_mean"] - table["u_input_ref"]) / np.hypot(table["ref_err"], table["sobol_sem"])
    # a u_input at round-off (a score the draws cannot move, e.g. critical state's band) says nothing
    table = table[np.isfinite(table["u_input_ref"]) & (table["u_input_ref"] > 1e-12)]
    pd.set_option("display.width", 220)
    print(table.reset_index().to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    within = (table["z"].abs() <= 2.0).mean()
    print(f"\n{len(table)} scores; sobol ({args.draws} draws, {len(cols)} scrambles) / random ({n_ref} draws): "
          f"u_input ratio median {table['ratio'].median():.3f}, range {table['ratio'].min():.3f}-{table['ratio'].max():.3f}; "
          f"|z| <= 2 for {within:.0%} (largest |z| {table['z'].abs().max():.2f}); "
          f"a single scramble's spread about the scrambles' mean: median {np.median(table[cols].std(axis=1, ddof=1) / table['sobol_mean']):.3f} of u_input")
    seconds = [model_seconds(r) for r in roots]
    print(f"planar model solves, CPU s: random {n_ref} draws {model_seconds(args.reference):.1f}; "
          f"sobol {args.draws} draws {np.mean(seconds):.1f} (per scramble)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
