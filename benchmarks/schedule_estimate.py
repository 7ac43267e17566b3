"""Estimated wall time of a config's workflow on N slots, with and without the DEM priorities.

An estimate, not a measurement: the DEM jobs (runs, shared fills, sheared beds) with their
dependencies (a fill before its runs, a rheometer state before the state it continues) and their
estimated seconds (``pipeline.workflow.priorities.estimated_seconds``, the DEM cost model, scaled
per case to measured slot-seconds where ``--measured CASE=SECONDS`` gives them) are list-scheduled
on ``--slots`` slots, each run followed by its share of the work after the DEM
(``--after-dem`` slot-seconds spread over the runs: dumps, fields), then the serial tail to the
report (``--tail`` seconds: calibration, draws, models, scores, report once the last DEM is in).
The intruder's 2D model stage (``--intruder-models`` slot-seconds in ``--intruder-model-jobs``
equal jobs) waits for every calibration-set run (the models need the calibration) and every
intruder run (their scenes), and starts before any DEM job once ready, as the workflow asks: the
order of the DEM decides how much of it runs beside the DEM.
Orders: by priority (the upward rank, as the workflow now asks Snakemake), in the config's order,
and without priorities, where Snakemake's choice among equally ranked ready jobs is arbitrary as
to their length: ``--random`` random orders (seeded), their median and 90th percentile. Printed:
the DEM slot-seconds by case, the wall time and the busy fraction of each order.

Usage: ``python benchmarks/schedule_estimate.py config/config.yaml [--slots 2] [--after-dem 480] [--tail 100]
[--measured shear_gravity=3018 ...] [--intruder-models 882 --intruder-model-jobs 10]``
"""
from __future__ import annotations

import argparse
import heapq
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.common.config import (calibration_runs, dem_fills, dem_runs, load_config, predecessor_state,  # noqa: E402
                                    shared_fill_of)
from pipeline.workflow.priorities import dem_priority, estimated_seconds  # noqa: E402


def schedule(jobs: dict[tuple[str, str], float], needs: dict[tuple[str, str], list[tuple[str, str]]],
             order: dict[tuple[str, str], float], slots: int) -> tuple[float, float]:
    """List scheduling: whenever a slot is free, the ready job of highest ``order`` starts.
    Returns (makespan, slot-seconds)."""
    waiting = {j: set(needs.get(j, [])) for j in jobs}
    ready = [(-order[j], j) for j, w in waiting.items() if not w]
    heapq.heapify(ready)
    running: list[tuple[float, tuple[str, str]]] = []
    now, done = 0.0, set()
    while ready or running:
        while ready and len(running) < slots:
            _, job = heapq.heappop(ready)
            heapq.heappush(running, (now + jobs[job], job))
        now, job = heapq.heappop(running)
        done.add(job)
        for other, w in waiting.items():
            if job in w:
                w.discard(job)
                if not w and other not in done and all(other != r for _, r in ready) and all(other != r for _, r in running):
                    heapq.heappush(ready, (-order[other], other))
    return now, sum(jobs.values())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", type=Path)
    parser.add_argument("--slots", type=int, default=2)
    parser.add_argument("--after-dem", type=float, default=480.0, help="slot-seconds of the rules after the DEM, spread over the runs")
    parser.add_argument("--tail", type=float, default=100.0, help="serial seconds from the last DEM's follow-up to the report")
    parser.add_argument("--random", type=int, default=200, help="random orders without priorities (default 200)")
    parser.add_argument("--seed", type=int, default=45)
    parser.add_argument("--measured", nargs="*", default=[], metavar="CASE=SECONDS",
                        help="measured DEM slot-seconds of a case: its jobs' estimates are scaled to them")
    parser.add_argument("--intruder-models", type=float, default=0.0,
                        help="slot-seconds of the intruder's model stage (after the calibration set and every rod)")
    parser.add_argument("--intruder-model-jobs", type=int, default=10, help="jobs it is split into (default 10)")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    dem = dem_fills(config) + dem_runs(config)
    seconds = {job: estimated_seconds(config, *job) for job in dem}
    for item in args.measured:
        case, value = item.split("=")
        total = sum(s for (c, _), s in seconds.items() if c == case)
        for job in [j for j in seconds if j[0] == case]:
            seconds[job] *= float(value) / total
    needs: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for case, run in dem_runs(config):
        spec = config["cases"][case]
        fill = shared_fill_of(case, spec, run)
        before = predecessor_state(case, spec, run)
        needs[(case, run)] = [(case, x) for x in (fill, before) if x]
    jobs = dict(seconds)
    order_priority = {job: float(dem_priority(config, *job)) for job in dem}
    order_config = {job: -k for k, job in enumerate(dem)}
    share = args.after_dem / max(len(dem_runs(config)), 1)
    for case, run in dem_runs(config):
        follow = (case, f"{run}:after")
        jobs[follow] = share
        needs[follow] = [(case, run)]
        # Right after its run (as every rule after the DEM has the top priority).
        order_priority[follow] = order_config[follow] = 1e9
    if args.intruder_models > 0:
        calibration = {c for c, _ in calibration_runs(config)}
        gate = [(c, r) for c, r in dem_runs(config)
                if c in calibration or config["cases"][c]["geometry"] == "intruder"]
        for k in range(args.intruder_model_jobs):
            job = ("intruder models", f"part{k}:after")
            jobs[job] = args.intruder_models / args.intruder_model_jobs
            needs[job] = gate
            order_priority[job] = order_config[job] = 1e9 + 1
    by_case: dict[str, float] = defaultdict(float)
    for (case, _), s in seconds.items():
        by_case[case] += s
    print(f"{args.config}: {len(dem)} DEM jobs, estimated DEM slot-seconds by case: "
          + ", ".join(f"{c} {v:.0f}" for c, v in by_case.items()) + f"; all {sum(seconds.values()):.0f}")
    for label, order in (("by priority (upward rank)", order_priority), ("in config order", order_config)):
        span, busy = schedule(jobs, needs, order, args.slots)
        wall = span + args.tail
        total = busy + args.tail
        print(f"  {label}: wall time {wall:.0f} s ({wall / 60:.1f} min), busy fraction {total / (args.slots * wall):.3f}")
    rng = np.random.default_rng(args.seed)
    walls = []
    for _ in range(args.random):
        order = {job: float(rng.random()) for job in jobs} | {j: 1e9 for j in jobs if j[1].endswith(":after")}
        span, busy = schedule(jobs, needs, order, args.slots)
        walls.append(span + args.tail)
    total = sum(jobs.values()) + args.tail
    for label, wall in (("median", np.median(walls)), ("90th percentile", np.percentile(walls, 90))):
        print(f"  without priorities, {args.random} random orders, {label}: wall time {wall:.0f} s ({wall / 60:.1f} min), "
              f"busy fraction {total / (args.slots * wall):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
