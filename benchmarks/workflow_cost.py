"""The DEM bill of two designs side by side: particle-steps, core-seconds and DEM noise per case.

Reads the run records (``dem/<case>/<run>/run.json`` and ``state.json``, and the shared fills'
``dem/<case>/fill-r<k>/fill.json``, counted once) and the scores
(``scores.csv``: ``dem_noise`` per case and metric, the replica scatter of the metric) of two
output roots made from the same cases: one with fixed-length production (``dem.precision``
absent, 0.5-strain chunks: the design before issue 19) and one with production to a target
precision. Particle-steps (grains x time steps, fill included) count the work without machine
noise; core-seconds (LIGGGHTS wall time x ranks) are what the machine paid. The noise of the
rheometer is that of the calibration it feeds (the errors of mu_s, mu_2, I_0 in
``calibration/params.json``). Ratios are targeted / fixed.

Usage: ``python benchmarks/workflow_cost.py --fixed /work/results-default --targeted results``
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.planar_run import settled_timestep  # noqa: E402

#: The cases of the goal (issue 19): rheometer, shear_gravity's replicas, intruder.
GOAL_CASES = ("rheometer", "shear_gravity", "intruder")


def fill_steps(run_dir: Path, state: dict) -> int:
    """Steps of the fill: recorded since issue 19, else the settled snapshot's time step."""
    if "steps" in state.get("fill", {}):
        return int(state["fill"]["steps"])
    return settled_timestep(run_dir / "settled.dump")


def stage_of(case: str, run: str) -> str:
    """Row label: the size study's runs (L<cell>-r<k>) apart from the case's replicas."""
    return f"{case} size study" if run.startswith("L") else case


def run_costs(root: Path) -> pd.DataFrame:
    """One row per finished DEM run under ``root``: work by stage and wall time."""
    rows = []
    for record_path in sorted((root / "dem").glob("*/*/run.json")):
        run_dir = record_path.parent
        record = json.loads(record_path.read_text())
        state = json.loads((run_dir / "state.json").read_text())
        n = record["particle_count"]
        chunks = state["chunks"]
        steps = {"fill": fill_steps(run_dir, state)}
        for kind in ("shear", "production"):
            steps[kind] = sum(c["steps"] for c in chunks if c["kind"] == kind)
        ranks = record.get("mpi_ranks", 1)
        seconds = {"fill": state["fill"]["wall_seconds"]} | {
            kind: sum(c["wall_seconds"] for c in chunks if c["kind"] == kind) for kind in ("shear", "production")}
        strain = {kind: sum(1 for c in chunks if c["kind"] == kind) * state["fingerprint"]["config"]["dem"]["chunk_strain"]
                  for kind in ("shear", "production")}
        rows.append({"case": stage_of(record["case"], record["run"]), "run": record["run"],
                     "particle_steps": n * sum(steps.values()),
                     **{f"particle_steps_{k}": n * v for k, v in steps.items()},
                     "core_seconds": ranks * sum(seconds.values()),
                     **{f"core_seconds_{k}": ranks * v for k, v in seconds.items()},
                     "shear_strain": strain["shear"], "production_strain": strain["production"],
                     "stop": (record.get("production_stop") or {}).get("reason", "fixed length")})
    # Fills shared by a rheometer replica's states (their runs record a fill of 0 steps): counted once.
    for record_path in sorted((root / "dem").glob("*/fill-*/fill.json")):
        record = json.loads(record_path.read_text())
        n, ranks = record["particle_count"], record.get("mpi_ranks", 1)
        steps, seconds = record["steps_by_stage"]["fill"], record["wall_seconds_by_stage"]["fill"]
        rows.append({"case": record["case"], "run": record["run"], "particle_steps": n * steps,
                     "particle_steps_fill": n * steps, "particle_steps_shear": 0, "particle_steps_production": 0,
                     "core_seconds": ranks * seconds, "core_seconds_fill": ranks * seconds,
                     "core_seconds_shear": 0.0, "core_seconds_production": 0.0,
                     "shear_strain": float("nan"), "production_strain": float("nan"), "stop": "shared fill"})
    if not rows:
        raise SystemExit(f"{root}: no finished DEM runs (dem/*/*/run.json)")
    return pd.DataFrame(rows)


def noise(root: Path) -> pd.DataFrame:
    """DEM noise per (case, metric): the scores' replica scatter, the calibration's errors."""
    scores = pd.read_csv(root / "scores.csv")
    out = scores.groupby(["case", "metric"], as_index=False)["dem_noise"].first()
    params = json.loads((root / "calibration" / "params.json").read_text())
    extra = [{"case": "rheometer", "metric": f"{name}_err", "dem_noise": params["local"][name]["error"]}
             for name in ("mu_s", "mu_2", "I_0", "nu_c", "a") if name in params["local"]]
    return pd.concat([out, pd.DataFrame(extra)], ignore_index=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixed", type=Path, required=True, help="output root of the fixed-length design")
    parser.add_argument("--targeted", type=Path, required=True, help="output root of the precision-targeted design")
    args = parser.parse_args(argv)
    costs = {name: run_costs(root) for name, root in (("fixed", args.fixed), ("targeted", args.targeted))}
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
        stages = {k: c[f"particle_steps_{k}"].sum() / c["particle_steps"].sum() for k in ("fill", "shear", "production")}
        secs = {k: c[f"core_seconds_{k}"].sum() for k in ("fill", "shear", "production")}
        print("  share of particle-steps: " + ", ".join(f"{k} {v:.0%}" for k, v in stages.items())
              + "; core-s: " + ", ".join(f"{k} {v:.0f}" for k, v in secs.items()))
        print(f"  mean strain per run: shear to steady {c['shear_strain'].mean():.2f}, production {c['production_strain'].mean():.2f}; "
              "stops: " + "; ".join(f"{k}: {v}" for k, v in c["stop"].value_counts().items()))
    goal = {name: c[c["case"].isin(GOAL_CASES)] for name, c in costs.items()}
    common = set(zip(goal["fixed"]["case"], goal["fixed"]["run"])) & set(zip(goal["targeted"]["case"], goal["targeted"]["run"]))
    # A shared fill belongs to the common runs it was poured for.
    same = {name: g[[(a, b) in common or b.startswith("fill-") for a, b in zip(g["case"], g["run"])]] for name, g in goal.items()}
    for label, part in (("all their runs", goal), (f"the {len(common)} runs both designs have", same)):
        steps = part["targeted"]["particle_steps"].sum() / part["fixed"]["particle_steps"].sum()
        secs = part["targeted"]["core_seconds"].sum() / part["fixed"]["core_seconds"].sum()
        print(f"\ngoal cases (rheometer, shear_gravity replicas, intruder), {label}: targeted / fixed "
              f"particle-steps = {steps:.3f}, core-seconds = {secs:.3f}")
    noises = noise(args.fixed).merge(noise(args.targeted), on=["case", "metric"], how="outer", suffixes=("_fixed", "_targeted"))
    noises["ratio"] = noises["dem_noise_targeted"] / noises["dem_noise_fixed"]
    print("\nDEM noise of each scored metric (replica scatter; rheometer: calibration errors)")
    print(noises.to_string(index=False, float_format=lambda v: f"{v:.3g}" if math.isfinite(v) else "nan"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
