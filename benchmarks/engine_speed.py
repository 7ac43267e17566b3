"""Particle-steps per core-second of each DEM engine on the same bed, side by side.

``python benchmarks/engine_speed.py RUN_DIR [RUN_DIR ...] [--stage production_000] [--repeats 3]``:
each RUN_DIR a finished planar run (``python -m pipeline.dem``), of either engine (its ``run.json``
names it). The chunk ``--stage`` is run again, as run (its ``in.<stage>`` from the restart it
started from, one rank), in a scratch copy of the folder, ``--repeats`` times; the engine's CPU
time (user + system of the child processes, so a loaded machine's waiting is not counted; LAMMPS's
includes the start of its Python wrapper) gives particle-steps per core-second, beside the wall-clock
rate. Two runs of one config that differ only in ``dem.engine`` are the same bed: the same grains,
walls, cell and time step (their packings differ, being poured by each engine). With
``--concurrent K`` it measures instead what sharing the machine costs an engine: the chunk's loop
rate alone against K copies of it at once (issue 57, item 4: the workflow runs one DEM job per
core). A benchmark: it prints, it asserts nothing.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.dem.engines import make_engine  # noqa: E402
from pipeline.dem.engines.lammps import lammps_environment  # noqa: E402
from pipeline.dem.engines.liggghts import mpi_environment  # noqa: E402

LOOP = re.compile(r"Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def last_production_stage(run_dir: Path) -> str:
    """The run's last production chunk (``production_NNN``, the highest of its ``in.production_*``)."""
    stages = sorted(p.name.removeprefix("in.") for p in run_dir.glob("in.production_*"))
    if not stages:
        raise SystemExit(f"{run_dir}: no production chunk (in.production_*) to replay")
    return stages[-1]


def measure(run_dir: Path, stage: str, dumps: bool = False) -> dict[str, float]:
    record = json.loads((run_dir / "run.json").read_text())
    if stage == "last":
        stage = last_production_stage(run_dir)
    engine = make_engine(record["provenance"]["config"]["dem"] | {"mpi_ranks": 1, "mpi_launcher": "none"})
    with tempfile.TemporaryDirectory(prefix="engine_speed_") as tmp:
        work = Path(tmp) / "run"
        shutil.copytree(run_dir, work, ignore=shutil.ignore_patterns("dumps", "logs"))
        (work / "logs").mkdir()
        (work / "dumps").mkdir()
        text = (work / f"in.{stage}").read_text()
        # No dumps (their writing is the store's cost, not the engine's), unless asked for: then the
        # chunk writes its particle and contact dumps as the run did.
        if not dumps:
            text = re.sub(r'variable dump_every string "\d+"', 'variable dump_every string "0"', text)
        (work / f"in.{stage}").write_text(text)
        cmd = engine.command(f"in.{stage}", "logs/bench.log") if hasattr(engine, "command") else \
            engine.launcher.command(f"in.{stage}", "logs/bench.log")
        launch = contextlib.nullcontext(lammps_environment()) if engine.name == "lammps" else \
            mpi_environment(engine.launcher.singleton)
        with launch as env:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run(cmd, cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, check=True)
            wall = time.perf_counter() - start
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        loops = LOOP.findall((work / "logs" / "bench.log").read_text())
    loop_seconds, _, steps, atoms = loops[-1]
    work_done = int(steps) * int(atoms)
    return {"engine": engine.name, "particle_steps": work_done, "cpu_s": cpu, "wall_s": wall,
            "per_core_second": work_done / cpu, "per_wall_second": work_done / wall,
            "per_loop_second": work_done / float(loop_seconds)}


def measure_concurrent(run_dir: Path, stage: str, copies: int) -> list[float]:
    """``copies`` replays of the same chunk at once (one rank each, each in its own scratch copy):
    each copy's particle-steps per second of its engine loop (``Loop time``: the wall time inside
    ``run``, which on an otherwise idle machine with a core per copy is its CPU time too)."""
    with ThreadPoolExecutor(max_workers=copies) as pool:
        rows = list(pool.map(lambda _: measure(run_dir, stage), range(copies)))
    return [r["per_loop_second"] for r in rows]


def print_contention(run: Path, stage: str, repeats: int, copies: int) -> None:
    """The engine's loop rate alone and with ``copies`` - 1 more copies beside it (as the workflow
    runs its DEM jobs, one per slot), alternated ``repeats`` times; their ratio per pair."""
    alone, shared, ratios = [], [], []
    for _ in range(repeats):
        one = measure_concurrent(run, stage, 1)[0]
        many = statistics.mean(measure_concurrent(run, stage, copies))
        alone.append(one / 1e6)
        shared.append(many / 1e6)
        ratios.append(many / one)
    spread = statistics.stdev(ratios) if len(ratios) > 1 else float("nan")
    print(f"{run}: loop rate alone {statistics.mean(alone):.2f} M particle-steps / s ({', '.join(f'{v:.2f}' for v in alone)}); "
          f"{copies} at once {statistics.mean(shared):.2f} each ({', '.join(f'{v:.2f}' for v in shared)}); "
          f"ratio {statistics.mean(ratios):.3f} +- {spread:.3f} over {repeats} pairs")


def print_dump_cost(run: Path, stage: str, repeats: int) -> None:
    """The chunk's CPU rate without its dumps and with them, alternated ``repeats`` times: their
    ratio per pair is what writing the text dumps costs the engine on this bed."""
    ratios, rates = [], {False: [], True: []}
    for _ in range(repeats):
        pair = {dumps: measure(run, stage, dumps=dumps)["per_core_second"] for dumps in (False, True)}
        for dumps, rate in pair.items():
            rates[dumps].append(rate / 1e6)
        ratios.append(pair[True] / pair[False])
    spread = statistics.stdev(ratios) if len(ratios) > 1 else float("nan")
    print(f"{run}: without dumps {statistics.mean(rates[False]):.2f} M particle-steps / core-s "
          f"({', '.join(f'{v:.2f}' for v in rates[False])}); with them {statistics.mean(rates[True]):.2f} "
          f"({', '.join(f'{v:.2f}' for v in rates[True])}); with / without {statistics.mean(ratios):.3f} +- {spread:.3f} "
          f"over {repeats} pairs")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--stage", default="production_000",
                        help="the chunk replayed: production_000 (default), any in.<stage> of the runs, or 'last' "
                             "(each run's last production chunk: continued rheometer states number theirs on)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dumps", choices=("off", "on", "both"), default="off",
                        help="the chunk without its dumps (off, the engine's own rate), with them as the run wrote "
                             "them (on), or both in turn, with their ratio (what the text dumps cost the engine)")
    parser.add_argument("--concurrent", type=int, metavar="K",
                        help="instead: each run's chunk replayed alone and K copies at once, alternated (the slowdown "
                             "of an engine sharing the machine with K - 1 others, as the workflow's DEM jobs do)")
    args = parser.parse_args(argv)
    if args.concurrent is not None:
        if args.concurrent < 2:
            parser.error(f"--concurrent {args.concurrent}: give 2 or more copies")
        for run in args.runs:
            print_contention(run, args.stage, args.repeats, args.concurrent)
        return 0
    if args.dumps == "both":
        for run in args.runs:
            print_dump_cost(run, args.stage, args.repeats)
        return 0
    print(f"{'run':<40} {'engine':<9} {'M p-steps':>9} {'M p-steps / core-s':>22} {'M p-steps / wall-s':>20} "
          f"{'(loop)':>8}")
    by_case: dict[str, list[float]] = {}
    for run in args.runs:
        rows = [measure(run, args.stage, dumps=args.dumps == "on") for _ in range(args.repeats)]
        core = [r["per_core_second"] / 1e6 for r in rows]
        wall = [r["per_wall_second"] / 1e6 for r in rows]
        loop = [r["per_loop_second"] / 1e6 for r in rows]
        spread = statistics.stdev(core) if len(core) > 1 else float("nan")
        print(f"{str(run):<40} {rows[0]['engine']:<9} {rows[0]['particle_steps'] / 1e6:>9.3f} "
              f"{statistics.mean(core):>12.2f} +- {spread:<6.2f} {statistics.mean(wall):>20.2f} {statistics.mean(loop):>8.2f}"
              f"   (each of {len(rows)}: {', '.join(f'{c:.2f}' for c in core)})")
        by_case.setdefault(json.loads((run / "run.json").read_text())["case"], []).extend(core)
    # The rates per case, as benchmarks/workflow_cost.py --timeline takes them (each case's DEM
    # against the engine alone on its own bed).
    print("--bare " + " ".join(f"{case}={statistics.mean(v):.3f}" for case, v in sorted(by_case.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
