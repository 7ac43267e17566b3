"""What Snakemake's own process costs while it waits for jobs, by its job-rate setting (docs/dem_cost.md 34).

Snakemake 9.27's scheduler, after every scheduling pass, starts a one-shot timer of the job-rate
limiter's timespan (``--max-jobs-per-timespan``, default ``100/1s``) that triggers another pass.
A pass run because a job finished starts a timer too, so every finished job adds one more chain
of passes: after N finished jobs the scheduler makes about N passes per timespan, each a thread
start and a look over the waiting jobs, for the rest of the run. On the 2-core machine that CPU is
taken from the DEM. At exit the interpreter waits for the last timers: about one timespan.

This runs one synthetic workflow (``--jobs`` independent jobs that sleep ``--sleep`` seconds on
one core each, then one job gathering them that sleeps ``--tail`` seconds: a long job after many
finished ones, as the default's last DEM runs are) with each setting in turn, round after round, and
reports per setting: the wall time, the CPU seconds of Snakemake's process tree (the sleeping
jobs use almost none: it is Snakemake's own), that CPU over the wall (its share of a core), and
the exit delay (from the last output file's time to the process's end).

Usage: ``python benchmarks/snakemake_overhead.py [--jobs 120] [--sleep 1.5] [--tail 30] [--rounds 2]
[--setting 100/1s 1000/10s ...]``.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SNAKEFILE = """\
N = {jobs}
rule all:
    input: "gathered.txt"
rule gather:
    input: expand("out/{{i}}.txt", i=range(N))
    output: "gathered.txt"
    shell: "sleep {tail} && cat {{input}} > {{output}}"
rule job:
    output: "out/{{i}}.txt"
    shell: "sleep {sleep} && echo {{wildcards.i}} > {{output}}"
"""


def one_run(work: Path, setting: str, cores: int) -> dict[str, float]:
    """Wall, Snakemake's CPU and exit delay (s) of one run of the workflow in ``work``, from scratch."""
    for name in ("out", ".snakemake"):
        shutil.rmtree(work / name, ignore_errors=True)
    (work / "gathered.txt").unlink(missing_ok=True)
    cmd = [sys.executable, "-m", "snakemake", "all", "--cores", str(cores), "--max-jobs-per-timespan", setting,
           "--quiet"]
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=False)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    end = time.time()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"error: snakemake with --max-jobs-per-timespan {setting} failed:\n"
                         f"{proc.stderr.read().decode(errors='replace')[-2000:]}")
    proc.stderr.close()
    last_output = (work / "gathered.txt").stat().st_mtime  # the gathering job ends by writing it
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "exit_delay_s": end - last_output}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=120, help="sleeping jobs (default 120)")
    parser.add_argument("--sleep", type=float, default=1.5, help="seconds each job sleeps (default 1.5)")
    parser.add_argument("--tail", type=float, default=30.0, help="seconds the gathering job sleeps (default 30)")
    parser.add_argument("--cores", type=int, default=2, help="--cores (default 2)")
    parser.add_argument("--rounds", type=int, default=2, help="runs of each setting, in turn (default 2)")
    parser.add_argument("--setting", nargs="+", default=["100/1s", "1000/10s"],
                        help="--max-jobs-per-timespan values compared (default: Snakemake's 100/1s and 1000/10s)")
    args = parser.parse_args(argv)
    if args.jobs < 1 or args.sleep <= 0 or args.tail < 0 or args.rounds < 1 or args.cores < 1:
        parser.error("--jobs, --rounds and --cores must be at least 1, --sleep positive and --tail not negative")
    rows: dict[str, list[dict[str, float]]] = {s: [] for s in args.setting}
    with tempfile.TemporaryDirectory(prefix="smk_overhead_") as tmp:
        work = Path(tmp)
        (work / "Snakefile").write_text(SNAKEFILE.format(jobs=args.jobs, sleep=args.sleep, tail=args.tail))
        for r in range(args.rounds):
            for setting in args.setting:
                rows[setting].append(one_run(work, setting, args.cores))
                print(f"round {r + 1} {setting}: " + ", ".join(f"{k} {v:.2f}" for k, v in rows[setting][-1].items()),
                      flush=True)
    base = args.setting[0]
    base_cpu = float(np.mean([x["cpu_s"] for x in rows[base]]))
    print(f"\n{args.jobs} jobs of {args.sleep} s on {args.cores} cores, then one of {args.tail} s; {args.rounds} rounds"
          " (means; range):")
    print(f"{'setting':>12} {'wall s':>16} {'Snakemake CPU s':>22} {'share of a core':>16} {'exit delay s':>16} {'CPU / ' + base:>14}")
    for setting, xs in rows.items():
        w = np.array([x["wall_s"] for x in xs])
        c = np.array([x["cpu_s"] for x in xs])
        d = np.array([x["exit_delay_s"] for x in xs])
        print(f"{setting:>12} {w.mean():7.1f} ({w.min():.1f}-{w.max():.1f}) {c.mean():9.2f} ({c.min():.2f}-{c.max():.2f})"
              f" {np.mean(c / w):16.3f} {d.mean():7.1f} ({d.min():.1f}-{d.max():.1f}) {c.mean() / base_cpu:14.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
