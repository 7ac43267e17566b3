"""How often concurrent one-rank LIGGGHTS starts fail MPI_Init, with Open MPI's shared session
directory and with one of each launch's own (docs/dem_cost.md 35).

Every isolated singleton (:data:`pipeline.dem.engines.liggghts.SINGLETON_MCA`) is Open MPI job
family 0, so concurrent launches share ``<tmp>/ompi.<host>.<uid>/jf.0``; one creating it while
another, finishing, removes it fails ``MPI_Init``. The workflow runs two DEM jobs at once and
restarts the engine at every chunk; the suite runs its DEM tests beside one another.

This starts the real binary on an input that only prints, ``--workers`` loops at once, each
``--launches`` times, in two modes one after the other:

- ``shared``: the launch environment with Open MPI's default session base (before 2026-12-07);
- ``own``: :func:`pipeline.dem.engines.liggghts.mpi_environment`, a base per launch.

It prints the failed launches of each mode and the first failure's message.

Usage: ``python benchmarks/singleton_race.py [--workers 4] [--launches 150]``.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.dem.engines.liggghts import mpi_environment  # noqa: E402


def start(binary: str, work: Path, own_base: bool) -> str:
    """One start; its output if it failed, else the empty string."""
    with mpi_environment(singleton=True) as env:
        if not own_base:
            env.pop("OMPI_MCA_orte_tmpdir_base")
        proc = subprocess.run([binary, "-in", "in.print", "-log", "none"], cwd=work, env=env,
                              capture_output=True, text=True, check=False, timeout=60)
    return "" if proc.returncode == 0 else proc.stdout + proc.stderr


def loop(binary: str, work: Path, own_base: bool, launches: int) -> list[str]:
    """``launches`` starts in turn; the failures' outputs."""
    return [out for out in (start(binary, work, own_base) for _ in range(launches)) if out]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=4, help="loops of starts at once (default 4)")
    parser.add_argument("--launches", type=int, default=150, help="starts of each loop per mode (default 150)")
    args = parser.parse_args(argv)
    if args.workers < 2 or args.launches < 1:
        parser.error("--workers must be 2 or more (a race needs two) and --launches 1 or more")
    binary = shutil.which("liggghts")
    if binary is None:
        parser.error("liggghts is not on PATH (install the Debian package 'liggghts')")
    total = args.workers * args.launches
    print(f"LIGGGHTS {binary}: {args.workers} loops at once, {args.launches} starts each, per mode")
    with tempfile.TemporaryDirectory(prefix="singleton_race_") as tmp:
        work = Path(tmp)
        (work / "in.print").write_text("print hello\n")
        for mode, own_base in (("shared", False), ("own", True)):
            with ThreadPoolExecutor(max_workers=args.workers) as pool:
                failures = [f for part in pool.map(lambda _: loop(binary, work, own_base, args.launches),
                                                   range(args.workers)) for f in part]
            print(f"{mode:<7} {len(failures)} of {total} launches failed")
            if failures:
                first = next((line.strip() for line in failures[0].splitlines() if "Directory:" in line
                              or "Error:" in line), failures[0].strip().splitlines()[-1])
                print(f"        first failure: {first}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
