"""How a finished workflow run used its slots, and its DEM against the engine's own speed.

Every job's wall seconds from its Snakemake ``benchmark:`` file (``ROOT/benchmarks/<rule>[/<case>]/<job>.tsv``)
and its end from that file's modification time (written when the job ends), so its start is the
end less its seconds; from them the wall time (first start to last end), the slot-seconds by rule
and case, the **busy fraction** (slot-seconds over slots x wall time) and how long 0, 1, 2, ... jobs
ran at once, with the idle stretch at the end (the last time fewer jobs than slots ran, to the end)
(issue 45). Then issue 57's item 4: the wall time against 1.05 x (the DEM jobs' slot-seconds /
slots) plus the tail after the last DEM job, and the DEM's particle-steps per slot-second of its
jobs, beside the engines' own rate inside their ``run`` loops (``Loop time`` lines of the root's
DEM logs) and the engine's rate alone on the same bed (``benchmarks/engine_speed.py``): one rate
for every case (``--bare M``), or one per case (``--bare rheometer=5.6 intruder=5.1 ...``), each
case's DEM then against its own bed's engine and all of it against the engine-alone seconds of the
same particle-steps, bed by bed.

Usage: ``python benchmarks/workflow_cost.py --timeline ROOT [--slots 2] [--bare M | --bare CASE=M ...]``
(this module is the ``--timeline`` of ``workflow_cost.py``).
"""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from dem_records import dem_records, engine_loops, engine_loops_by_case, log_loops, run_costs, run_logs  # noqa: E402


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


def print_timeline(root: Path, slots: int, bare: float | dict[str, float] | None = None) -> None:
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


def dem_slot_seconds(records: list[dict], jobs: pd.DataFrame) -> float:
    """The DEM jobs' slot-seconds: each job's wall seconds x its MPI ranks from its record (both
    rules, runs and shared fills, keep their benchmark files under benchmarks/dem/)."""
    ranks = {(r["case"], r["run"]): r.get("mpi_ranks", 1) for r in records}
    return float(sum(row.seconds * ranks.get((row.case, row.job), 1) for row in jobs[jobs["rule"] == "dem"].itertuples()))


def print_dem_speed(root: Path, records: list[dict], jobs: pd.DataFrame, slots: int, wall: float, tail: float,
                    bare: float | dict[str, float] | None) -> None:
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
    if isinstance(bare, float):
        line += f"; against the engine alone on the same bed ({bare:.2f} M): jobs {job_rate / 1e6 / bare:.3f}, loops {loop_rate / 1e6 / bare:.3f}"
    print(line)
    if isinstance(bare, dict):
        print_dem_speed_by_case(root, records, jobs, bare)
    launches, outside = engine_launches(root, dem)
    if launches:
        print(f"DEM outside the loops: {outside:.0f} s of the DEM jobs' wall over {launches} engine launches (one per stage: "
              f"fill, shear and production chunks), {outside / launches:.2f} s a launch: start-up, restart files read "
              "and written, the dumps' and series' checks and the pipeline's Python between chunks")


def parse_bare(values: list[str] | None) -> float | dict[str, float] | None:
    """``--bare``: one rate (M particle-steps per core-second) for every case, or ``CASE=M`` per case."""
    if not values:
        return None
    if len(values) == 1 and "=" not in values[0]:
        return _positive_rate(values[0], "the rate")
    rates: dict[str, float] = {}
    for item in values:
        case, sep, rate = item.partition("=")
        if not sep or not case:
            raise ValueError(f"{item!r}: give one rate for every case, or CASE=M for each case")
        if case in rates:
            raise ValueError(f"{case!r} given twice")
        rates[case] = _positive_rate(rate, case)
    return rates


def _positive_rate(text: str, what: str) -> float:
    try:
        rate = float(text)
    except ValueError:
        raise ValueError(f"{what}: {text!r} is not a number") from None
    if not rate > 0.0:
        raise ValueError(f"{what}: {text!r} is not a positive rate")
    return rate


def dem_speed_by_case(root: Path, records: list[dict], jobs: pd.DataFrame, bare: dict[str, float]) -> pd.DataFrame:
    """Per case: the DEM jobs' slot-seconds (``slot_s``), the particle-steps and core-seconds inside
    the engines' loops, the rates (M per slot-second of the jobs, per core-second of the loops), the
    engine alone on the case's own bed (``bare``, M per core-second; nan where not given), the
    seconds it would take for the same particle-steps (``alone_s``) and the ratios of the jobs'
    and the loops' rates to it."""
    dem = jobs[jobs["rule"] == "dem"]
    slot_s = pd.Series({case: dem_slot_seconds(records, group) for case, group in dem.groupby("case")}, name="slot_s")
    table = engine_loops_by_case(root).join(slot_s, how="outer")
    table["jobs_M"] = table["loop_steps"] / table["slot_s"] / 1e6
    table["loops_M"] = table["loop_steps"] / table["loop_seconds"] / 1e6
    table["bare_M"] = [bare.get(case, float("nan")) for case in table.index]
    table["alone_s"] = table["loop_steps"] / (table["bare_M"] * 1e6)
    table["jobs_over_bare"] = table["alone_s"] / table["slot_s"]
    table["loops_over_bare"] = table["alone_s"] / table["loop_seconds"]
    return table


def print_dem_speed_by_case(root: Path, records: list[dict], jobs: pd.DataFrame, bare: dict[str, float]) -> None:
    """Each case's DEM against the engine alone on its own bed, and all of it against the
    engine-alone seconds of the same particle-steps (the cases with a rate; those without are named)."""
    table = dem_speed_by_case(root, records, jobs, bare)
    unknown = sorted(set(bare) - set(table.index))
    if unknown:
        print(f"--bare names cases with no DEM in {root}: {', '.join(unknown)}")
    print("DEM by case, against the engine alone on the case's own bed (M particle-steps per slot- or core-second):")
    print(table[["slot_s", "loop_steps", "jobs_M", "loops_M", "bare_M", "jobs_over_bare", "loops_over_bare"]]
          .to_string(float_format=lambda v: f"{v:.4g}"))
    known = table[table["bare_M"].notna()]
    missing = sorted(set(table.index) - set(known.index))
    if known.empty:
        return
    print(f"the cases with a bare rate ({len(known)} of {len(table)}; {known['slot_s'].sum():.0f} of {table['slot_s'].sum():.0f} DEM "
          f"slot-seconds): jobs {known['alone_s'].sum() / known['slot_s'].sum():.3f}, loops "
          f"{known['alone_s'].sum() / known['loop_seconds'].sum():.3f} of the engine alone on the same beds"
          + (f"; without a rate: {', '.join(missing)}" if missing else ""))
