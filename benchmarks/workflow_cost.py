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

With ``--timeline ROOT`` it reports instead how the workflow used its slots (issue 45): every job's
wall seconds from its Snakemake ``benchmark:`` file (``ROOT/benchmarks/<rule>[/<case>]/<job>.tsv``)
and its end from that file's modification time (written when the job ends), so its start is the
end less its seconds; from them the wall time (first start to last end), the slot-seconds by rule
and case, the **busy fraction** (slot-seconds over slots x wall time) and how long 0, 1, 2, ... jobs
ran at once, with the idle stretch at the end (the last time fewer jobs than slots ran, to the end).
Then issue 57's item 4: the wall time against 1.05 x (the DEM jobs' slot-seconds / slots) plus the
tail after the last DEM job, and the DEM's particle-steps per slot-second of its jobs, beside the
engines' own rate inside their ``run`` loops (``Loop time`` lines of the root's DEM logs) and, with
``--bare M``, the engine's rate alone on the same bed (``benchmarks/engine_speed.py``).

Usage: ``python benchmarks/workflow_cost.py --fixed /work/results-default --targeted results``,
``python benchmarks/workflow_cost.py --timeline results [--slots 2] [--bare 4.95]``
"""
from __future__ import annotations

import argparse
import functools
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.intruder_run import is_arrested, rest_speed_of  # noqa: E402
from pipeline.dem.planar_run import settled_timestep  # noqa: E402
from pipeline.scoring import intruder_scores, scores  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from engine_speed import LOOP  # noqa: E402  (a LIGGGHTS or LAMMPS log's timing of one run command)

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
                     # Production chunks that were the steady-state test's window (none before 2026-12-02).
                     "window_chunks": sum(1 for c in chunks if c.get("from_steady_window")),
                     "stop": (record.get("production_stop") or {}).get("reason", "fixed length")})
    # Fills shared by several runs (their runs record a fill of 0 steps), and the intruder's sheared
    # beds (cases.<case>.shared_bed: a fill and its shear to steady state): counted once.
    for record_path in sorted((root / "dem").glob("*/fill-*/fill.json")):
        record = json.loads(record_path.read_text())
        n, ranks = record["particle_count"], record.get("mpi_ranks", 1)
        steps, seconds = record["steps_by_stage"], record["wall_seconds_by_stage"]
        bed = record.get("bed")
        rows.append({"case": record["case"], "run": record["run"], "particle_steps": n * sum(steps.values()),
                     "particle_steps_fill": n * steps["fill"], "particle_steps_shear": n * steps.get("shear", 0),
                     "particle_steps_production": 0,
                     "core_seconds": ranks * sum(seconds.values()), "core_seconds_fill": ranks * seconds["fill"],
                     "core_seconds_shear": ranks * seconds.get("shear", 0.0), "core_seconds_production": 0.0,
                     "shear_strain": bed["strain"] if bed else float("nan"), "production_strain": float("nan"),
                     "window_chunks": 0, "stop": "sheared bed" if bed else "shared fill"})
    if not rows:
        raise SystemExit(f"{root}: no finished DEM runs (dem/*/*/run.json)")
    return pd.DataFrame(rows)


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


def job_timeline(root: Path) -> pd.DataFrame:
    """One row per finished job of ``root``: rule, case (the folder under the rule's, if any), job,
    seconds (the benchmark's ``s``), end (the benchmark file's modification time, s) and start."""
    rows = []
    for path in sorted((root / "benchmarks").rglob("*.tsv")):
        parts = path.relative_to(root / "benchmarks").parts
        try:
            seconds = float(pd.read_csv(path, sep="\t")["s"].iloc[0])
        except (ValueError, KeyError, IndexError, pd.errors.EmptyDataError) as err:
            raise SystemExit(f"{path}: not a Snakemake benchmark file ({err})") from None
        rule = parts[0].removesuffix(".tsv")
        case = parts[1] if len(parts) > 2 else ""
        end = path.stat().st_mtime
        rows.append({"rule": rule, "case": case, "job": path.stem, "seconds": seconds, "end": end, "start": end - seconds})
    if not rows:
        raise SystemExit(f"{root}: no benchmark files under benchmarks/")
    return pd.DataFrame(rows)


def concurrency(jobs: pd.DataFrame) -> pd.Series:
    """Seconds during which k jobs ran at once, for every k seen (index k)."""
    events = sorted([(t, 1) for t in jobs["start"]] + [(t, -1) for t in jobs["end"]])
    held: dict[int, float] = {}
    running, last = 0, events[0][0]
    for t, step in events:
        held[running] = held.get(running, 0.0) + (t - last)
        running, last = running + step, t
    return pd.Series(held).sort_index()


#: The model stage's rules, by their benchmark folders (rules/models.smk), and its parts by job name.
MODEL_STAGE_RULES = ("models", "model_draws", "model_fields")


def model_stage_part(rule: str, case: str, job: str) -> str:
    """Which part of the model stage a job of ``rule`` (a benchmark folder) is: the intruder's
    parameter draws, its sensitivities, its grid study, the draws' merge, its nominal solves, the
    planar models or the model fields."""
    if rule == "model_fields":
        return "fields"
    if rule == "models":
        return "intruder nominal" if case == "intruder" else "planar models"
    if job.startswith("draws-"):
        return "intruder draws"
    return {"sensitivities": "intruder sensitivities", "refined": "intruder grid study"}.get(job, "draws merge")


def print_model_stage(records: list[dict], jobs: pd.DataFrame) -> None:
    """The model stage's slot-seconds (one core per job) by part, and as a share of the DEM's
    slot-seconds (issue 57, item 1)."""
    model = jobs[jobs["rule"].isin(MODEL_STAGE_RULES)]
    if model.empty:
        print("model stage: no finished jobs")
        return
    parts = model.apply(lambda r: model_stage_part(r["rule"], r["case"], r["job"]), axis=1)
    dem = dem_slot_seconds(records, jobs)
    total = float(model["seconds"].sum())
    share = f"{100 * total / dem:.1f} % of the DEM's {dem:.0f}" if dem > 0 else "no DEM jobs to compare with"
    print(f"model stage: {total:.0f} slot-seconds in {len(model)} jobs, {share}; by part: "
          + ", ".join(f"{k} {v:.0f}" for k, v in model.groupby(parts)["seconds"].sum().sort_values(ascending=False).items()))


def print_timeline(root: Path, slots: int, bare: float | None = None) -> None:
    """The slots' use of one finished workflow run (module docstring)."""
    jobs = job_timeline(root)
    wall = float(jobs["end"].max() - jobs["start"].min())
    busy = float(jobs["seconds"].sum())
    print(f"{root}: {len(jobs)} jobs, wall time {wall:.0f} s ({wall / 60:.1f} min), {busy:.0f} slot-seconds; "
          f"busy fraction {busy / (slots * wall):.3f} of {slots} slots")
    dem = jobs["rule"] == "dem"
    by_case = jobs[dem].groupby("case")["seconds"].agg(["count", "sum"]).rename(columns={"count": "jobs", "sum": "slot_s"})
    print("DEM slot-seconds by case:\n" + by_case.to_string(float_format=lambda v: f"{v:.0f}"))
    print(f"after the DEM (every other rule): {jobs.loc[~dem, 'seconds'].sum():.0f} slot-seconds in {int((~dem).sum())} jobs; by rule: "
          + ", ".join(f"{r} {v:.0f}" for r, v in jobs[~dem].groupby("rule")["seconds"].sum().sort_values(ascending=False).items()))
    records = dem_records(root)
    print_model_stage(records, jobs)
    held = concurrency(jobs)
    print("seconds with k jobs running: " + ", ".join(f"{k}: {v:.0f}" for k, v in held.items()))
    # The idle tail: from the last moment the slots were all busy to the end.
    events = sorted([(t, 1) for t in jobs["start"]] + [(t, -1) for t in jobs["end"]])
    running, full_until = 0, float(jobs["start"].min())
    for t, step in events:
        if running >= slots and running + step < slots:
            full_until = t
        running += step
    end = float(jobs["end"].max())
    tail = jobs[jobs["end"] > full_until].sort_values("start")
    print(f"last {end - full_until:.0f} s with fewer than {slots} jobs running; the jobs then: "
          + "; ".join(f"{r.rule} {r.case}/{r.job} {r.seconds:.0f} s" for r in tail.itertuples()))
    last_dem = float(jobs.loc[dem, "end"].max()) if dem.any() else float("nan")
    print(f"from the last DEM job's end to the last job's: {end - last_dem:.0f} s")
    print_dem_speed(root, records, jobs, slots, wall, end - last_dem, bare)


def run_logs(run_dir: Path) -> list[Path]:
    """The engine logs a DEM folder's own job wrote, one per stage: a shared fill's log, copied into
    each run that adopted it, is counted in the fill's folder only."""
    state = run_dir / "state.json"
    shared = state.exists() and json.loads(state.read_text()).get("fill", {}).get("shared")
    return [log for log in sorted((run_dir / "logs").glob("*.log")) if not (shared and log.name == "fill.log")]


@functools.lru_cache(maxsize=None)
def log_loops(log: Path) -> tuple[tuple[str, ...], ...]:
    """Every ``run`` loop's timing in an engine log (seconds, processes, steps, atoms), read once
    for both the loops' totals and the launches."""
    return tuple(LOOP.findall(log.read_text(errors="replace")))


def engine_loops(root: Path) -> tuple[float, float]:
    """Particle-steps and core-seconds inside the engines' own ``run`` loops, from every DEM log of
    ``root`` (runs and shared fills; the loop time is wall time x processes)."""
    steps = seconds = 0.0
    for log in (log for run_dir in sorted((root / "dem").glob("*/*/")) for log in run_logs(run_dir)):
        for t, procs, n_steps, atoms in log_loops(log):
            steps += float(n_steps) * float(atoms)
            seconds += float(t) * float(procs)
    return steps, seconds


def engine_launches(root: Path, dem: pd.DataFrame) -> tuple[int, float]:
    """How many times the DEM jobs of ``dem`` (rows of :func:`job_timeline`) started the engine (one
    log per stage), and their wall seconds outside the engine's loops (the job's seconds less the
    wall time of every ``run`` loop in its logs; a shared fill's log copied into a run is the
    fill job's, not the run's)."""
    launches, outside = 0, 0.0
    for row in dem.itertuples():
        loops = 0.0
        for log in run_logs(root / "dem" / row.case / row.job):
            found = log_loops(log)
            launches += bool(found)
            loops += sum(float(t) for t, *_ in found)
        outside += row.seconds - loops
    return launches, outside


def dem_records(root: Path) -> list[dict]:
    """The run and shared-fill records of ``root``'s finished DEM (``run.json``, ``fill.json``)."""
    return [json.loads(p.read_text()) for pattern in ("*/*/run.json", "*/fill-*/fill.json")
            for p in sorted((root / "dem").glob(pattern))]


def dem_slot_seconds(records: list[dict], jobs: pd.DataFrame) -> float:
    """The DEM jobs' slot-seconds: each job's wall seconds x its MPI ranks from its record (both
    rules, runs and shared fills, keep their benchmark files under benchmarks/dem/)."""
    ranks = {(r["case"], r["run"]): r.get("mpi_ranks", 1) for r in records}
    return float(sum(row.seconds * ranks.get((row.case, row.job), 1) for row in jobs[jobs["rule"] == "dem"].itertuples()))


def print_dem_speed(root: Path, records: list[dict], jobs: pd.DataFrame, slots: int, wall: float, tail: float,
                    bare: float | None) -> None:
    """Issue 57, item 4: the wall against 1.05 x the DEM's slot-seconds over the slots plus the tail
    after the last DEM job, and the DEM's particle-steps per slot-second (the jobs' own seconds x
    their ranks) against the engine's inside its loops and, with ``bare``, alone on the same bed."""
    if not records:
        print("DEM: no finished runs (dem/*/*/run.json): no DEM speed to report")
        return
    runs = run_costs(root)
    dem = jobs[jobs["rule"] == "dem"]
    slot_s = dem_slot_seconds(records, jobs)
    bound = 1.05 * slot_s / slots + tail
    print(f"DEM jobs (runs and shared fills): {len(dem)}, {slot_s:.0f} slot-seconds; wall {wall:.0f} s against "
          f"1.05 x {slot_s:.0f} / {slots} + {tail:.0f} s tail = {bound:.0f} s: ratio {wall / bound:.3f} "
          f"({'met' if wall <= bound else 'not met'})")
    steps = float(runs["particle_steps"].sum())
    loop_steps, loop_seconds = engine_loops(root)
    if slot_s <= 0.0 or loop_seconds <= 0.0:
        print(f"DEM: {steps:.3g} particle-steps, but no DEM benchmark files or no engine timing in its logs: no rate")
        return
    job_rate, loop_rate = steps / slot_s, loop_steps / loop_seconds
    line = (f"DEM: {steps:.3g} particle-steps, {job_rate / 1e6:.2f} M per slot-second of its jobs; inside the engines' "
            f"loops {loop_steps:.3g} particle-steps at {loop_rate / 1e6:.2f} M per core-second (jobs / loops {job_rate / loop_rate:.3f})")
    if bare is not None:
        line += f"; against the engine alone on the same bed ({bare:.2f} M): jobs {job_rate / 1e6 / bare:.3f}, loops {loop_rate / 1e6 / bare:.3f}"
    print(line)
    launches, outside = engine_launches(root, dem)
    if launches:
        print(f"DEM outside the loops: {outside:.0f} s of the DEM jobs' wall over {launches} engine launches (one per stage: "
              f"fill, shear and production chunks), {outside / launches:.2f} s a launch: start-up, restart files read "
              "and written, the dumps' and series' checks and the pipeline's Python between chunks")


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
    parser.add_argument("--bare", type=float, metavar="M",
                        help="with --timeline: the engine's particle-steps per core-second alone on the same bed, in "
                             "millions (benchmarks/engine_speed.py on one of the root's runs), for the DEM's ratio to it")
    args = parser.parse_args(argv)
    if args.timeline is not None:
        print_timeline(args.timeline, args.slots, args.bare)
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
