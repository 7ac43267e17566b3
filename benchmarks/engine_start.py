"""What one start of LIGGGHTS costs, by how it is started (docs/dem_cost.md 30).

A DEM run restarts the engine at every chunk (about 1800 launches in the default, 230 in the
reduced run), so the start is paid per chunk. This times starts of the real binary on an empty
input (the start and MPI_Init, nothing else), the three ways side by side in turn, round after
round, so a drift of the machine's speed falls on all three alike:

- ``mpirun -n 1``: the launch of a one-rank run before 2026-12-07 (mpirun forks its daemon);
- ``bare, Open MPI defaults``: the binary alone, a singleton that forks its own daemon and loads
  every transport (Omni-Path's psm2 library probes for adapters in a sleeping loop);
- ``bare, singleton settings``: the binary with :data:`pipeline.dem.engines.liggghts.SINGLETON_MCA`
  (no daemon, point-to-point over self and shared memory), as a one-rank run starts now.

Wall seconds per start (median and spread over the rounds) and the CPU seconds the start's
processes were charged (the daemons included where they were waited for), with each mode's
median wall against the first's.

Usage: ``python benchmarks/engine_start.py [--rounds 20] [--liggghts liggghts]``.
"""
from __future__ import annotations

import argparse
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.dem.engines.liggghts import mpi_environment  # noqa: E402


def modes(binary: str) -> dict[str, tuple[list[str], bool]]:
    """Start mode -> (command prefix, whether the environment is a singleton's)."""
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        raise SystemExit("error: mpirun not on PATH (scripts/install.sh installs Open MPI)")
    return {"mpirun -n 1": ([mpirun, "-n", "1", binary], False),
            "bare, Open MPI defaults": ([binary], False),
            "bare, singleton settings": ([binary], True)}


def one_start(prefix: list[str], singleton: bool, work: Path) -> tuple[float, float]:
    """Wall and CPU seconds of one start on an empty input."""
    with mpi_environment(singleton) as env:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run([*prefix, "-in", "in.empty", "-log", "log.empty"], cwd=work, env=env,
                       stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, check=True, timeout=60)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=20, help="starts of each mode, in turn (default 20)")
    parser.add_argument("--liggghts", default="liggghts", help="the LIGGGHTS executable (default: liggghts on PATH)")
    args = parser.parse_args(argv)
    if args.rounds < 3:
        parser.error("--rounds must be 3 or more (a median and a spread)")
    binary = shutil.which(args.liggghts)
    if binary is None:
        parser.error(f"--liggghts {args.liggghts!r} is not on PATH (install the Debian package 'liggghts')")
    table = modes(binary)
    walls: dict[str, list[float]] = {m: [] for m in table}
    cpus: dict[str, list[float]] = {m: [] for m in table}
    with tempfile.TemporaryDirectory(prefix="engine_start_") as tmp:
        work = Path(tmp)
        (work / "in.empty").write_text("")
        for _ in range(args.rounds):
            for mode, (prefix, singleton) in table.items():
                wall, cpu = one_start(prefix, singleton, work)
                walls[mode].append(wall)
                cpus[mode].append(cpu)
    first = float(np.median(walls[next(iter(table))]))
    print(f"LIGGGHTS {binary}: {args.rounds} starts of each mode on an empty input, in turn")
    print(f"{'mode':<26} {'wall s: median':>15} {'(min-max)':>14} {'CPU s: median':>14} {'wall / first':>13}")
    for mode in table:
        w = np.asarray(walls[mode])
        c = np.asarray(cpus[mode])
        print(f"{mode:<26} {np.median(w):15.3f} {f'({w.min():.3f}-{w.max():.3f})':>14} {np.median(c):14.3f} "
              f"{np.median(w) / first:13.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
