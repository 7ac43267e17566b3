"""Pipeline overhead of a DEM run: the pipeline's run against bare ``liggghts -in`` on the same inputs.

The pipeline run (``pipeline.dem.planar_run``: rendering, log and series checks, steady-state tests,
restart bookkeeping) is timed from outside. Then every stage input it rendered (``in.fill``,
``in.shear_000``, ...) is replayed in a copy of the run folder with the bare binary, in the same
order, renaming each restart as the pipeline does. Both do exactly the same LIGGGHTS steps; the
ratio of the two wall times is the overhead. Pairs are alternated to share machine load. A third
replay of the same inputs with ``dump_every`` set to 0 (no particle or contact dumps) prices the
dumps inside the engine (issue 57, item 4); what is left between it and the engine's bare
throughput (``benchmarks/engine_speed.py``) is the stages' restarts and process starts.

With ``--launchers mpirun none`` it times instead the pipeline run through each launcher in turn
(one rank either way, the same DEM): what ``mpirun -n 1`` cost per engine start. Since 2026-12-07
a one-rank run starts the bare binary whatever the launcher (``pipeline.dem.engines.liggghts``),
so on one rank the two are the same start and their difference is the machine's noise; the start
itself is priced by ``benchmarks/engine_start.py``. The bare replays start as a one-rank run does
(the singleton settings).

Usage: ``python benchmarks/dem_overhead.py [--config config/ci.yaml] [--case rheometer] [--run I0.2-P200-r1] [--repeat 2] [--launchers mpirun none]``
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.planar_run import mpi_environment  # noqa: E402


def pipeline_run(config: str, case: str, run: str, out: Path, launcher: str | None = None) -> float:
    """Wall seconds of the pipeline's run of ``case``/``run`` into ``out`` (``launcher``: the
    ``--mpi-launcher`` override, e.g. 'none' for the bare binary; None: the config's)."""
    override = [] if launcher is None else ["--mpi-launcher", launcher]
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "pipeline.dem", "--config", config, "--case", case, "--run", run, "--out", str(out), *override],
        cwd=REPO, check=True, capture_output=True,
    )
    return time.perf_counter() - start


def launcher_pairs(config: str, case: str, run: str, launchers: list[str], repeat: int, tmp: Path) -> None:
    """The same pipeline run started through each of ``launchers`` in turn, ``repeat`` rounds: what
    the launcher costs per engine start (the DEM is the same: one rank either way)."""
    seconds: dict[str, list[float]] = {name: [] for name in launchers}
    launches = 0
    for k in range(repeat):
        for name in launchers:
            out = tmp / f"launcher-{name}-{k}"
            seconds[name].append(pipeline_run(config, case, run, out, name))
            launches = len(list((out / "logs").glob("*.log")))
            print(f"round {k}: launcher {name!r}: {seconds[name][-1]:.2f} s for {launches} engine starts")
    first = launchers[0]
    for name in launchers[1:]:
        diffs = [a - b for a, b in zip(seconds[first], seconds[name])]
        mean = sum(diffs) / len(diffs)
        print(f"{first!r} - {name!r}: {mean:+.2f} s a run over {len(diffs)} rounds ({', '.join(f'{d:+.2f}' for d in diffs)}), "
              f"{mean / launches:+.3f} s an engine start; ratio of the means "
              f"{sum(seconds[first]) / sum(seconds[name]):.3f}")


DUMP_EVERY = re.compile(r'^variable dump_every string "\d+"$', re.MULTILINE)


def bare_replay(run_dir: Path, work: Path, dumps: bool = True) -> tuple[float, int]:
    state = json.loads((run_dir / "state.json").read_text())
    shutil.copytree(run_dir, work)
    if not dumps:
        for path in work.glob("in.*"):
            path.write_text(DUMP_EVERY.sub('variable dump_every string "0"', path.read_text()))
    for sub in ("restart", "series", "dumps", "logs"):
        shutil.rmtree(work / sub, ignore_errors=True)
        (work / sub).mkdir()
    stages = ["fill"] + [c["stage"] for c in state["chunks"]]
    steps = sum(c["steps"] for c in state["chunks"])
    start = time.perf_counter()
    for stage in stages:
        with mpi_environment(singleton=True) as env:
            subprocess.run(["liggghts", "-in", f"in.{stage}", "-log", f"logs/{stage}.log"], cwd=work, check=True,
                           stdout=subprocess.DEVNULL, env=env)
        tmp = work / "restart" / f"{stage}.restart.tmp"
        if tmp.exists():
            tmp.replace(work / "restart" / f"{stage}.restart")
    return time.perf_counter() - start, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default="config/ci.yaml")
    parser.add_argument("--case", default="rheometer")
    parser.add_argument("--run", default="I0.2-P200-r1")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--launchers", nargs="+", metavar="LAUNCHER",
                        help="instead: time the pipeline run through each of these --mpi-launcher values in turn "
                             "(e.g. mpirun none) on one rank")
    args = parser.parse_args()
    if args.launchers:
        # The launchers are compared on one rank, where 'none' runs the same DEM.
        ranks = yaml.safe_load(Path(args.config).read_text())["dem"]["mpi_ranks"]
        if ranks != 1:
            raise SystemExit(f"{args.config}: dem.mpi_ranks {ranks}: --launchers compares launchers on one rank "
                             "(give a copy of the config with dem.mpi_ranks: 1)")
        with tempfile.TemporaryDirectory() as tmp:
            launcher_pairs(args.config, args.case, args.run, args.launchers, args.repeat, Path(tmp))
        return
    ratios, dump_ratios = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeat):
            out = Path(tmp) / f"pipeline{k}"
            t_pipe = pipeline_run(args.config, args.case, args.run, out)
            t_bare, steps = bare_replay(out, Path(tmp) / f"bare{k}")
            t_nodump, _ = bare_replay(out, Path(tmp) / f"nodump{k}", dumps=False)
            ratios.append(t_pipe / t_bare)
            dump_ratios.append(t_bare / t_nodump)
            n = json.loads((out / "run.json").read_text())["particle_count"]
            print(f"repeat {k}: {steps} shear/production steps + fill, {n} grains: "
                  f"pipeline {t_pipe:.2f} s, bare liggghts {t_bare:.2f} s, ratio {t_pipe / t_bare:.3f} "
                  f"(bare: {steps * n / t_bare / 1e6:.2f} M particle-steps/s); without dumps {t_nodump:.2f} s "
                  f"({steps * n / t_nodump / 1e6:.2f} M particle-steps/s), dumps ratio {t_bare / t_nodump:.3f}")
    print(f"pipeline / bare wall time: mean ratio {sum(ratios) / len(ratios):.3f} "
          f"(overhead {100 * (sum(ratios) / len(ratios) - 1):.1f} %) over {len(ratios)} pairs; "
          f"bare with / without dumps: mean ratio {sum(dump_ratios) / len(dump_ratios):.3f}")


if __name__ == "__main__":
    main()
