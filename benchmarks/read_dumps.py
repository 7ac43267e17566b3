"""Throughput of the particle-dump reader, in rows per second, on a synthetic 16-column dump.

Writes (once) a LIGGGHTS-like ``dump custom`` file with the columns of the pipeline's particle
dumps (``id type x y z vx vy vz omegax omegay omegaz radius mass fx fy fz``, 6 significant
digits as LIGGGHTS prints them) to /tmp, then times :func:`pipeline.dumps.reader.read_dump` (best of
``--repeat``) with one thread and with the default thread count, against pandas' C parser on
the same bytes. Goal: at least 1.5 million rows/s (OVITO's LAMMPS-dump reader on 2 cores).

Usage: ``python -m benchmarks.read_dumps [--rows 1000000] [--snapshots 10] [--path /tmp/...]``
"""
from __future__ import annotations

import argparse
import io
import time
from pathlib import Path

import numpy as np

from pipeline.dumps import reader as dumps
from pipeline.dumps import fastparse

HEADER = "id type x y z vx vy vz omegax omegay omegaz radius mass fx fy fz"


def write_dump(path: Path, rows: int, snapshots: int, seed: int = 1) -> None:
    """A synthetic particle dump: ``snapshots`` snapshots of ``rows // snapshots`` particles."""
    rng = np.random.default_rng(seed)
    n = rows // snapshots
    scale = np.array([0.01, 0.01, 0.06, 1, 0.1, 0.1, 50, 50, 50, 0.0012, 1.8e-5, 0.01, 0.01, 0.01])
    tmp = path.with_suffix(".tmp")
    with open(tmp, "w") as f:
        for s in range(snapshots):
            f.write(f"ITEM: TIMESTEP\n{s * 1000}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS pp pp ff\n"
                    f"0 0.01\n0 0.01\n0 0.06\nITEM: ATOMS {HEADER} \n")
            values = (rng.random((n, 14)) - 0.2) * scale
            body = np.column_stack([np.arange(1, n + 1), rng.integers(1, 4, n), values])
            np.savetxt(f, body, fmt=["%d", "%d"] + ["%g"] * 14)
    tmp.replace(path)


def best_time(func, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--snapshots", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--path", type=Path, default=None)
    parser.add_argument("--no-pandas", action="store_true", help="skip the pandas baseline")
    args = parser.parse_args(argv)
    path = args.path or Path(f"/tmp/gv_bench_dump_{args.rows}_{args.snapshots}.dump")
    if not path.exists():
        write_dump(path, args.rows, args.snapshots)
    size = path.stat().st_size
    rows = dumps.read_dump(path).data.shape[0]
    print(f"file {path}: {rows} rows x 16 columns, {size / 1e6:.1f} MB; compiled parser: {fastparse.compiled()}")
    for threads in (1, dumps.default_threads()):
        t = best_time(lambda: dumps.read_dump(path, threads=threads), args.repeat)
        print(f"pipeline.dumps.reader.read_dump, {threads} thread(s): {rows / t / 1e6:.2f} million rows/s "
              f"({size / t / 1e6:.0f} MB/s, {t:.3f} s)")
    if not args.no_pandas:
        import pandas as pd

        raw = path.read_bytes()
        start = raw.index(b"\n", raw.index(b"ITEM: ATOMS")) + 1
        stop = raw.find(b"ITEM:", start)
        block = raw[start:stop]
        t = best_time(lambda: pd.read_csv(io.BytesIO(block), sep=r"\s+", header=None, engine="c").to_numpy(), args.repeat)
        n = block.count(b"\n")
        print(f"pandas.read_csv (C engine), one snapshot block: {n / t / 1e6:.2f} million rows/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
