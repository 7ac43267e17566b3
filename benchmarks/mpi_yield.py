"""A DEM run on several MPI ranks beside other work: Open MPI's ranks spinning while they wait for
each other, or yielding the core (``mpi_yield_when_idle``), side by side.

Open MPI's ranks poll for messages. When every rank has a core of its own that costs nothing, but
the suite runs its two-rank rerun (tests/pipeline/dem/test_planar_run.py) beside the background
workflows on 2 cores, and the workflow runs beside Snakemake and its other jobs: a rank the kernel
has taken off its core holds the other, which spins through its own slices waiting for it. Open
MPI yields only where it counts more ranks than slots itself, which it does not here.

This reruns one finished DEM run of an output root (as the workflow's rule starts it:
``python -m pipeline.dem``, its own fill, or the slower state it continues from) on ``--ranks``
ranks through mpirun, with ``--load`` busy processes at nice 5 beside it (the suite starts its
workflows at nice 5), the two modes alternated ``--repeats`` times:

- ``spin``: ``OMPI_MCA_mpi_yield_when_idle=0`` (Open MPI's default on an undersubscribed node);
- ``yield``: ``OMPI_MCA_mpi_yield_when_idle=1``.

Printed: each rerun's wall seconds and the engines' loop seconds (``Loop time``, summed over the
run's stages), the medians per mode and their ratio. The grains and steps are the same in both
modes; the numbers differ only by summation order.

Measured 2026-12-07 (docs/dem_cost.md 35): spinning, the reduced rheometer state took 18 s beside
two busy processes at nice 5; yielding, its ranks gave their cores to those processes at every
poll (7 % and 2 % of a core) and it had not finished after 10 minutes. The launch does not yield.

Usage: ``python benchmarks/mpi_yield.py ROOT [--run rheometer/I0.3-P50-r1] [--ranks 2] [--load 2] [--repeats 2]``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
LOOP = re.compile(r"Loop time of (\S+) on (\d+) procs")
BUSY = "while True: pass"


def rerun(root: Path, record: dict, out: Path, ranks: int, yield_when_idle: bool) -> tuple[float, float]:
    """Wall seconds of the rerun and the sum of its engine loops' seconds."""
    start_from = record.get("started_from")
    extra = ["--start-from", str(root / "dem" / record["case"] / start_from["run"])] if start_from else []
    command = [sys.executable, "-m", "pipeline.dem", "--config", str(root / "config.effective.json"),
               "--case", record["case"], "--run", record["run"], "--out", str(out), "--mpi-launcher", "mpirun",
               "--mpi-ranks", str(ranks), *extra]
    env = dict(os.environ, OMPI_MCA_mpi_yield_when_idle="1" if yield_when_idle else "0")
    t0 = time.perf_counter()
    proc = subprocess.run(command, cwd=REPO, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"error: the rerun failed (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
    loops = sum(float(m.group(1)) for log in (out / "logs").glob("*.log") for m in LOOP.finditer(log.read_text()))
    return wall, loops


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path, help="a finished output root (its config.effective.json and dem/)")
    parser.add_argument("--run", default="", help="CASE/RUN to rerun (default: the root's fastest rheometer state)")
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--load", type=int, default=2, help="busy processes at nice 5 beside the rerun (default 2)")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args(argv)
    if args.ranks < 2 or args.load < 0 or args.repeats < 1:
        parser.error("--ranks must be 2 or more, --load 0 or more, --repeats 1 or more")
    if not (args.root / "config.effective.json").is_file():
        parser.error(f"{args.root}: no config.effective.json (not a finished output root)")
    if args.run:
        path = args.root / "dem" / args.run / "run.json"
        if not path.is_file():
            parser.error(f"--run {args.run}: no {path}")
        record = json.loads(path.read_text())
    else:
        records = [json.loads(p.read_text()) for p in (args.root / "dem" / "rheometer").glob("*/run.json")]
        if not records:
            parser.error(f"{args.root}: no rheometer run to rerun (name one with --run)")
        record = max(records, key=lambda r: float(r["run"].split("-")[0][1:]))
    load = [subprocess.Popen(["nice", "-n", "5", sys.executable, "-c", BUSY]) for _ in range(args.load)]
    rows: dict[str, list[tuple[float, float]]] = {"spin": [], "yield": []}
    try:
        with tempfile.TemporaryDirectory(prefix="mpi_yield_") as tmp:
            for k in range(args.repeats):
                for mode in ("spin", "yield"):
                    out = Path(tmp) / f"{mode}{k}"
                    rows[mode].append(rerun(args.root, record, out, args.ranks, mode == "yield"))
                    print(f"{record['case']}/{record['run']} on {args.ranks} ranks, {args.load} busy beside, {mode:5}: "
                          f"wall {rows[mode][-1][0]:7.1f} s, loops {rows[mode][-1][1]:7.1f} s", flush=True)
    finally:
        for p in load:
            p.kill()
            p.wait()
    wall = {m: statistics.median(w for w, _ in r) for m, r in rows.items()}
    loops = {m: statistics.median(lp for _, lp in r) for m, r in rows.items()}
    print(f"medians: spin wall {wall['spin']:.1f} s (loops {loops['spin']:.1f} s); yield wall {wall['yield']:.1f} s "
          f"(loops {loops['yield']:.1f} s); yield / spin: wall {wall['yield'] / wall['spin']:.2f}, "
          f"loops {loops['yield'] / loops['spin']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
