"""Benchmark (issue 57, item 4): the intruder grid study's start, side by side in one process
(alternating, CPU seconds by time.process_time; never a test).

NGF carries no state across grids, so its grid study (``intruder-draws refined``, the finer
grid) started every scene from the planar solution. Now a scene at a depth the job has already
solved on the finer grid starts from that solution under its other push
(``pipeline.models.intruder.SAME_DEPTH_FALLBACK``: the continuation in the push the nominal
solves use; not for the volume-averaged model, whose continuation failed and was retried cold,
so that ``--models volume_averaged`` runs the same job twice unless ``--newton-too``). For each model of
``--models`` the job runs on ROOT's own inputs with
the switch off (``planar``) and on (``same-depth``), the order alternated per repeat, and prints
the CPU seconds, their ratio and the largest relative difference of any speed the two wrote (the
solves' tolerance is a scaled residual of 1e-6; the grid study's differences are percents).

Run: ``python benchmarks/grid_study_start.py ROOT --out OUT [--models ngf] [--repeats 1] [--newton-too]``
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from pipeline.models import intruder, intruder_draws  # noqa: E402
from sparse_lu import MODELS, job_argv, side_by_side  # noqa: E402

STARTS = {"planar": False, "same-depth": True}


def run(root: Path, model: str, start: str, out: Path) -> tuple[float, dict]:
    """CPU seconds of the grid-study job of ``model`` with the start ``start``, and its speeds."""
    out.mkdir(parents=True, exist_ok=True)
    intruder.SAME_DEPTH_FALLBACK = STARTS[start]
    t0 = time.process_time()
    code = intruder_draws.main(job_argv(root, "refined", model, out))
    cpu = time.process_time() - t0
    if code not in (0, None):
        raise SystemExit(f"refined {model} with the {start} start: exit {code}")
    with xr.open_dataset(out / f"{model}.refined.nc") as ds:
        return cpu, {"speed_refined": ds["speed_refined"].values.copy()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--models", nargs="+", default=["ngf"], choices=MODELS)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--newton-too", action="store_true",
                        help="let the Newton models (the volume-averaged model) take the same-depth start too: "
                             "how their loss was measured")
    args = parser.parse_args()
    if args.newton_too:
        intruder.has_jacobian = lambda model: False
    for need in ("config.effective.json", "calibration/params.json", "models/intruder"):
        if not (args.root / need).exists():
            parser.error(f"root: {args.root}: no {need} (a finished output root with intruder models)")
    a, b = STARTS
    side_by_side([(f"refined {model}", lambda s, model=model: run(args.root, model, s, args.out / s))
                  for model in args.models], a, b, args.repeats)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
