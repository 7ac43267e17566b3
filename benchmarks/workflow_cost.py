"""The DEM bill of two designs side by side: particle-steps, core-seconds and DEM noise per case.

Reads the run records (``dem/<case>/<run>/run.json`` and ``state.json``, and the shared fills'
``dem/<case>/fill-r<k>/fill.json``, counted once) and the fields (``fields/<case>/r<k>.nc``: the
DEM noise of each scored metric, the metric between replica pairs as ``scores.csv`` defines it,
recomputed by this code for both roots, with the number of pairs and their scatter) of two
output roots made from the same cases: one with fixed-length production (``dem.precision``
absent, 0.5-strain chunks: the design before issue 19) and one with production to a target
precision. Particle-steps (grains x time steps, fill included) count the work without machine
noise; core-seconds (LIGGGHTS wall time x ranks) are what the machine paid. The noise of the
rheometer is that of the calibration it feeds (the errors of mu_s, mu_2, I_0 in
``calibration/params.json``). Ratios are targeted / fixed.

A root's bill (its per-run costs and its noise, what this benchmark reads from it) can be saved
with ``--save-bill FILE.json`` and given in place of the root (``--fixed FILE.json``), so a
comparison outlives the output root it was measured on. ``benchmarks/records/`` keeps the bills
of the measured designs; a bill transcribed from an earlier report says so in its ``source`` and
may hold per-case totals (``run`` = ``all``) and noise without its standard error.

With ``--timeline ROOT`` it reports instead how one finished run used its slots and its DEM
against the engine alone (``benchmarks/workflow_timeline.py``). The run records are read by
``benchmarks/dem_records.py``.

Usage: ``python benchmarks/workflow_cost.py --fixed /work/results-default --targeted results``,
``python benchmarks/workflow_cost.py --timeline results [--slots 2] [--bare 4.95 | --bare rheometer=5.6 intruder=5.1 ...]``
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.intruder_run import is_arrested, rest_speed_of  # noqa: E402
from pipeline.scoring import intruder_scores, scores  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from dem_records import run_costs  # noqa: E402
from workflow_timeline import parse_bare, print_timeline  # noqa: E402

#: The cases of the goal (issue 19): rheometer, shear_gravity's replicas, intruder.
GOAL_CASES = ("rheometer", "shear_gravity", "intruder")


def pair_scatter(root: Path) -> pd.DataFrame:
    """Per (case, metric), recomputed by this code from the root's fields and run records: the
    DEM noise (the scores' definition: the metric between replica pairs, their mean; the
    intruder's, the RMS of |log10 U_a / U_b| at one depth), the number of pairs behind it and the
    standard error of their mean (nan with one pair). Recomputing puts both designs under the same
    code (a root's scores.csv is as old as its run). The pairs share replicas (3 replicas give 3
    pairs, 2 of them independent), so the error is a lower bound of the estimate's own scatter."""
    params = json.loads((root / "calibration" / "params.json").read_text())
    rows = []
    for case_dir in sorted(p for p in (root / "fields").iterdir() if p.is_dir() and p.name not in ("rheometer", "intruder")):
        files = sorted(f for f in case_dir.glob("r*.nc") if f.stem[1:].isdigit())
        if len(files) < 2:
            continue
        reps = scores.with_microscopic_fluidity(scores.replica_profiles(files), params)
        mask = scores.interior(reps[0])
        table = scores.metric_table(reps[0].z.values[mask], float(reps[0].attrs["wall_speed"]))
        for metric, (variable, fn) in table.items():
            observed = scores.DEM_VARIABLE.get(metric, variable)
            if observed in reps[0]:
                rows.append(_scatter_row(case_dir.name, metric, scores.pair_values(reps, observed, fn, mask)))
    runs = [json.loads(p.read_text()) for p in sorted((root / "dem" / "intruder").glob("D*/run.json"))]
    rest = rest_speed_of(json.loads((root / "config.effective.json").read_text()), "intruder")
    for r in runs:
        # The arrest rule of this code (the speed alone), whatever rule the run's own code applied.
        rod = r["intruder"]
        rod["arrested"] = is_arrested(rod["speed"], rod["speed_err"], rest)
    squares = list(np.square(intruder_scores.intruder_noise_terms(intruder_scores.moving_rod_speeds(runs))))
    row = _scatter_row("intruder", "intruder_speed_log_err", squares)
    if squares:  # the RMS of the terms, and its error from that of their mean square
        rms = math.sqrt(row["dem_noise"])
        row |= {"dem_noise": rms, "noise_se": row["noise_se"] / (2.0 * rms)}
    rows.append(row)
    return pd.DataFrame(rows)


def _scatter_row(case: str, metric: str, values: list[float]) -> dict[str, object]:
    n = len(values)
    return {"case": case, "metric": metric, "pairs": n, "dem_noise": float(np.mean(values)) if n else math.nan,
            "noise_se": float(np.std(values, ddof=1) / math.sqrt(n)) if n > 1 else math.nan}


def noise(root: Path) -> pd.DataFrame:
    """DEM noise per (case, metric): the replica scatter recomputed (:func:`pair_scatter`), the
    calibration's errors for the rheometer. Where the root's scores.csv says otherwise, a line."""
    out = pair_scatter(root)
    recorded = pd.read_csv(root / "scores.csv").groupby(["case", "metric"], as_index=False)["dem_noise"].first()
    both = out.merge(recorded, on=["case", "metric"], suffixes=("", "_scores_csv"))
    differ = both[~np.isclose(both["dem_noise"], both["dem_noise_scores_csv"], rtol=1e-9, atol=0.0)]
    for row in differ.itertuples():
        print(f"note: {root}/scores.csv has {row.case} {row.metric} noise {row.dem_noise_scores_csv:.3g}, "
              f"this code {row.dem_noise:.3g} (the root's scores are older than its fields' reading here)")
    params = json.loads((root / "calibration" / "params.json").read_text())
    extra = [{"case": "rheometer", "metric": f"{name}_err", "dem_noise": params["local"][name]["error"]}
             for name in ("mu_s", "mu_2", "I_0", "nu_c", "a") if name in params["local"]]
    return pd.concat([out, pd.DataFrame(extra)], ignore_index=True)


def load_bill(path: Path) -> dict[str, object]:
    """A design's bill: from an output root (its run records and fields) or a saved ``.json`` bill.
    Returns ``runs`` (one row per run, :func:`run_costs`), ``noise`` (:func:`noise`) and
    ``source`` (empty for a root, else what the saved bill says it was made from)."""
    if path.suffix != ".json":
        return {"runs": run_costs(path), "noise": noise(path), "source": ""}
    try:
        saved = json.loads(path.read_text())
        runs, noise_rows, source = pd.DataFrame(saved["runs"]), pd.DataFrame(saved["noise"]), str(saved["source"])
    except (OSError, ValueError, KeyError) as err:
        raise SystemExit(f"{path}: not a bill written by --save-bill ({err})") from None
    for column in ("pairs", "noise_se"):
        if column not in noise_rows:
            noise_rows[column] = math.nan
    return {"runs": runs, "noise": noise_rows.astype({"noise_se": float}), "source": f"bill {path} ({source})"}


def save_bill(root: Path, bill: dict[str, object], path: Path) -> None:
    """Write ``root``'s bill as JSON (written under a temporary name, then renamed)."""
    config = json.loads((root / "config.effective.json").read_text())
    saved = {"source": f"output root {root}, measured by benchmarks/workflow_cost.py", "config_seed": config.get("seed"),
             "runs": bill["runs"].to_dict("records"), "noise": bill["noise"].to_dict("records")}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(saved, indent=1, allow_nan=True) + "\n")
    tmp.replace(path)
    print(f"bill of {root} written to {path}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixed", type=Path, help="output root (or saved bill, .json) of the fixed-length design")
    parser.add_argument("--targeted", type=Path, help="output root (or saved bill, .json) of the precision-targeted design")
    parser.add_argument("--save-bill", type=Path, metavar="FILE.json", help="also write the targeted root's bill (per-run costs, noise) here")
    parser.add_argument("--timeline", type=Path, metavar="ROOT", help="instead: the slots' use of one finished run (busy fraction)")
    parser.add_argument("--slots", type=int, default=2, help="with --timeline: jobs the run kept at once (--cores; default 2)")
    parser.add_argument("--bare", nargs="+", metavar="M|CASE=M",
                        help="with --timeline: the engine's particle-steps per core-second alone on the same bed, in "
                             "millions (benchmarks/engine_speed.py on the root's runs): one rate for every case, or "
                             "CASE=M for each case (then each case's DEM against its own bed)")
    args = parser.parse_args(argv)
    if args.timeline is not None:
        try:
            bare = parse_bare(args.bare)
        except ValueError as err:
            parser.error(f"--bare: {err}")
        print_timeline(args.timeline, args.slots, bare)
        return 0
    if args.fixed is None or args.targeted is None:
        parser.error("give --fixed and --targeted (or --timeline ROOT)")
    bills = {name: load_bill(path) for name, path in (("fixed", args.fixed), ("targeted", args.targeted))}
    if args.save_bill is not None:
        if args.targeted.suffix == ".json":
            raise SystemExit(f"--save-bill: {args.targeted} is already a bill; give the output root")
        save_bill(args.targeted, bills["targeted"], args.save_bill)
    costs = {name: bill["runs"] for name, bill in bills.items()}
    for name, bill in bills.items():
        if bill["source"]:
            print(f"{name}: {bill['source']}")
    sums = {name: c.groupby("case")[["particle_steps", "core_seconds"]].sum() for name, c in costs.items()}
    by_case = sums["fixed"].merge(sums["targeted"], left_index=True, right_index=True, how="outer",
                                  suffixes=("_fixed", "_targeted"))
    by_case["steps_ratio"] = by_case["particle_steps_targeted"] / by_case["particle_steps_fixed"]
    by_case["seconds_ratio"] = by_case["core_seconds_targeted"] / by_case["core_seconds_fixed"]
    pd.set_option("display.width", 200)
    print("DEM work per case (particle-steps = grains x steps, fill included; core-seconds of LIGGGHTS)")
    print(by_case.to_string(float_format=lambda v: f"{v:.3g}"))
    for name, c in costs.items():
        goal = c[c["case"].isin(GOAL_CASES)]
        print(f"\n{name}: all {c['particle_steps'].sum():.3g} particle-steps, {c['core_seconds'].sum():.0f} core-s; "
              f"goal cases {goal['particle_steps'].sum():.3g} particle-steps, {goal['core_seconds'].sum():.0f} core-s")
        if (c["run"] == "all").any():
            print("  (per-case totals transcribed: no per-run records)")
            continue
        stages = {k: c[f"particle_steps_{k}"].sum() / c["particle_steps"].sum() for k in ("fill", "shear", "production")}
        secs = {k: c[f"core_seconds_{k}"].sum() for k in ("fill", "shear", "production")}
        print("  share of particle-steps: " + ", ".join(f"{k} {v:.0%}" for k, v in stages.items())
              + "; core-s: " + ", ".join(f"{k} {v:.0f}" for k, v in secs.items()))
        windows = c[c["window_chunks"] > 0]
        print(f"  mean strain per run: shear to steady {c['shear_strain'].mean():.2f}, production {c['production_strain'].mean():.2f} "
              f"(of it the steady window's: {len(windows)} runs, {int(windows['window_chunks'].sum())} chunks); "
              "stops: " + "; ".join(f"{k}: {v}" for k, v in c["stop"].value_counts().items()))
    goal = {name: c[c["case"].isin(GOAL_CASES)] for name, c in costs.items()}
    common = set(zip(goal["fixed"]["case"], goal["fixed"]["run"])) & set(zip(goal["targeted"]["case"], goal["targeted"]["run"]))
    # A shared fill belongs to the common runs it was poured for.
    same = {name: g[[(a, b) in common or b.startswith("fill-") for a, b in zip(g["case"], g["run"])]] for name, g in goal.items()}
    parts = [("all their runs", goal)] + ([(f"the {len(common)} runs both designs have", same)] if common else [])
    for label, part in parts:
        steps = part["targeted"]["particle_steps"].sum() / part["fixed"]["particle_steps"].sum()
        secs = part["targeted"]["core_seconds"].sum() / part["fixed"]["core_seconds"].sum()
        print(f"\ngoal cases (rheometer, shear_gravity replicas, intruder), {label}: targeted / fixed "
              f"particle-steps = {steps:.3f}, core-seconds = {secs:.3f}")
    noises = bills["fixed"]["noise"].merge(bills["targeted"]["noise"], on=["case", "metric"], how="outer", suffixes=("_fixed", "_targeted"))
    noises["ratio"] = noises["dem_noise_targeted"] / noises["dem_noise_fixed"]
    diff_se = np.hypot(noises["noise_se_fixed"], noises["noise_se_targeted"])
    diff = noises["dem_noise_targeted"] - noises["dem_noise_fixed"]
    # A transcribed bill may lack its standard errors: the other design's alone then judges (a lower bound of the combined).
    diff_se = diff_se.where(np.isfinite(diff_se), noises["noise_se_fixed"].fillna(noises["noise_se_targeted"]))
    noises["verdict"] = np.where(~np.isfinite(diff_se), "undecided (one pair)",
                                 np.where(diff > 2.0 * diff_se, "higher", np.where(diff < -2.0 * diff_se, "lower", "equal within 2 se")))
    noises.loc[noises["case"] == "rheometer", "verdict"] = np.where(
        noises.loc[noises["case"] == "rheometer", "ratio"] <= 1.0, "lower or equal", "higher")
    missing = ~np.isfinite(noises["dem_noise_fixed"]) | ~np.isfinite(noises["dem_noise_targeted"])
    noises.loc[missing, "verdict"] = "not in both bills"
    print("\nDEM noise of each scored metric (replica scatter; rheometer: calibration errors); pairs and se: the")
    print("replica pairs behind each noise and the standard error of their mean (a lower bound: pairs share replicas);")
    print("verdict: targeted - fixed against twice the combined se")
    print(noises.to_string(index=False, float_format=lambda v: f"{v:.3g}" if math.isfinite(v) else "nan"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
