"""Benchmark (issue 57, items 1 and 4): the 2D plastic intruder jobs with two sparse-LU set-ups side
by side in one process (alternating, CPU seconds by time.process_time; never a test): by default
PARDISO with its analysis reused between a Newton solve's Jacobians and GMRES preconditioned without
PARDISO's refinement steps (``pardiso-reuse``, the pipeline's) against PARDISO analysing every
Jacobian and refining every preconditioner application (``pardiso``, the set-up of docs/dem_cost.md
26); ``--compare superlu pardiso`` gives that section's comparison. ``--compare stokes-colamd
stokes-mmd-ata --models ngf`` compares SuperLU's column orderings of the Stokes system
(``continuum.intruder.mac.STOKES_ORDERING``: scipy's default COLAMD against minimum degree on A^T A,
docs/dem_cost.md 35), which NGF factorises at every map evaluation.

For each model of ``--models`` and each job of ``--jobs`` (``nominal``: ``python -m pipeline.models
intruder``, the depth and force sweeps and their F = 0 drifts at 3 cells per d; ``refined``: the grid
study's finer grid, ``intruder-draws refined``), the job runs on ROOT's own inputs once per backend
per repeat (``continuum.intruder.sparse_lu``'s settings changed between runs, the order alternated),
and prints the CPU seconds, their ratio, and the largest relative difference of any speed the two
backends wrote (the stages' tolerance is a scaled residual of 1e-6, so U agrees to far below the
grid study's differences).

Run: ``python benchmarks/sparse_lu.py ROOT --out OUT [--models ...] [--jobs nominal refined] [--repeats 1]
[--compare pardiso pardiso-reuse]``
"""
from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from continuum.intruder import mac, sparse_lu  # noqa: E402
from pipeline.models import intruder, intruder_draws  # noqa: E402

PLASTIC = ("local_mu_i", "critical_state", "cosserat", "volume_averaged")
MODELS = (*PLASTIC, "ngf")
#: The set-ups compared: (backend, reuse the analysis, precondition without refinement, SuperLU's
#: ordering of the Stokes system).
SETUPS = {"superlu": ("superlu", False, False, "MMD_ATA"), "pardiso": ("pardiso", False, False, "MMD_ATA"),
          "pardiso-reuse": ("pardiso", True, True, "MMD_ATA"),
          "stokes-colamd": ("pardiso", True, True, "COLAMD"), "stokes-mmd-ata": ("pardiso", True, True, "MMD_ATA")}
SPEEDS = {"nominal": ("speed", "sweep_speed", "drift_speed", "sweep_drift_speed"), "refined": ("speed_refined",)}


def job_argv(root: Path, job: str, model: str, out: Path) -> list[str]:
    """The rule's command line for ``job`` of ``model`` on ROOT's inputs, written under ``out``."""
    runs = sorted(r for r in (root / "dem" / "intruder").glob("D*/run.json") if "control" not in r.parent.name)
    fields = [root / "fields" / "intruder" / f"{r.parent.name}.nc" for r in runs]
    common = ["--config", str(root / "config.effective.json"), "--params", str(root / "calibration" / "params.json"),
              "--model", model, "--runs", *map(str, runs), "--fields", *map(str, fields)]
    if job == "nominal":
        return [*common, "--out", str(out / f"{model}.nc"), "--states-out", str(out / f"{model}.states.npz")]
    return ["refined", *common, "--states", str(root / "models" / "intruder" / f"{model}.states.npz"),
            "--out", str(out / f"{model}.refined.nc")]


def run(root: Path, job: str, model: str, backend: str, out: Path) -> tuple[float, dict[str, np.ndarray]]:
    """CPU seconds of one job with the set-up ``backend`` (a key of ``SETUPS``), and the speeds it wrote."""
    out.mkdir(parents=True, exist_ok=True)
    sparse_lu.DEFAULT_BACKEND, sparse_lu.ANALYSIS_REUSE, sparse_lu.PRECONDITION_UNREFINED, mac.STOKES_ORDERING = \
        SETUPS[backend]
    main = intruder.main if job == "nominal" else intruder_draws.main
    t0 = time.process_time()
    code = main(job_argv(root, job, model, out))
    cpu = time.process_time() - t0
    if code not in (0, None):
        raise SystemExit(f"{job} {model} with {backend}: exit {code}")
    path = out / (f"{model}.nc" if job == "nominal" else f"{model}.refined.nc")
    with xr.open_dataset(path) as ds:
        speeds = {k: ds[k].values.copy() for k in SPEEDS[job] if k in ds}
    return cpu, speeds


def largest_difference(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """Largest |a - b| / max(|a|, |b|) over every finite speed of both (0 where both are 0)."""
    worst = 0.0
    for k in a:
        x, y = a[k], b[k]
        ok = np.isfinite(x) & np.isfinite(y) & ((x != 0) | (y != 0))
        if ok.any():
            worst = max(worst, float(np.max(np.abs(x[ok] - y[ok]) / np.maximum(np.abs(x[ok]), np.abs(y[ok])))))
        if not np.array_equal(np.isfinite(x), np.isfinite(y)):
            worst = np.inf  # one backend converged where the other did not
    return worst


def side_by_side(cases: list[tuple[str, Callable[[str], tuple[float, dict[str, np.ndarray]]]]], a: str, b: str,
                 repeats: int) -> None:
    """Each case's ``measure(setup)`` (CPU seconds, the speeds written) with set-ups ``a`` and ``b`` in
    turn, ``a`` first on even repeats and ``b`` first on odd ones (the machine's drift falls on both);
    prints per run the CPU seconds, their ratio and the largest relative difference of any speed,
    then the totals."""
    totals = {a: 0.0, b: 0.0}
    print(f"{'job':25s} {'rep':>3s} {a + ' s':>14s} {b + ' s':>14s} {'ratio':>6s} {'max rel dU':>10s}")
    for label, measure in cases:
        for rep in range(repeats):
            got = {s: measure(s) for s in ((a, b) if rep % 2 == 0 else (b, a))}
            for s in got:
                totals[s] += got[s][0]
            print(f"{label:25s} {rep:3d} {got[a][0]:14.1f} {got[b][0]:14.1f} {got[a][0] / got[b][0]:6.2f} "
                  f"{largest_difference(got[a][1], got[b][1]):10.2g}", flush=True)
    print(f"total CPU s: {a} {totals[a]:.1f}, {b} {totals[b]:.1f}, ratio {totals[a] / totals[b]:.3f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--models", nargs="+", default=list(PLASTIC), choices=MODELS)
    parser.add_argument("--jobs", nargs="+", default=["nominal", "refined"], choices=["nominal", "refined"])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--compare", nargs=2, default=["pardiso", "pardiso-reuse"], choices=sorted(SETUPS),
                        metavar="SETUP", help=f"the two set-ups, A then B (ratio A / B); of {', '.join(SETUPS)}")
    args = parser.parse_args()
    for need in ("config.effective.json", "calibration/params.json", "dem/intruder"):
        if not (args.root / need).exists():
            parser.error(f"root: {args.root}: no {need} (a finished output root with intruder runs)")
    a, b = args.compare
    side_by_side([(f"{job} {model}", lambda s, job=job, model=model: run(args.root, job, model, s, args.out / s / job))
                  for job in args.jobs for model in args.models], a, b, args.repeats)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
