"""Which part of the pour makes LAMMPS's creeping bed denser? (issue 56; docs/dem.md "The pour, not the law")

LIGGGHTS pours the calibration case's grains with ``insert/pack`` into a box sized for a loose solid
fraction of 0.25; LAMMPS places them with ``create_atoms`` at 0.15 (the box 1.7 times taller, the
settling drag, set by the fall time, weaker). The beds differ from the first loaded chunk on: the top
wall's mean height over the first 0.25 strain is 23.54 d on LIGGGHTS's pours and 23.20 d on LAMMPS's,
whichever engine shears (replica scatter 0.02-0.03 d). This runs LIGGGHTS's own pour at LAMMPS's
loose fraction (the engine's ``insertion_solid_fraction``, nothing else changed: its law, seeds,
walls and insertion), then its first shear chunks, for the study config's replicas, and prints the
top wall's height per chunk beside the roots': if it lands on LAMMPS's, the pour's height is what
makes the difference.

Run: ``.venv/bin/python benchmarks/pour_height.py --config config/studies/damping_off_liggghts.yaml
--out /tmp/pour_height [--fraction 0.15] [--chunks 4] [--runs r1 r2 r3 r4] [--jobs 2]``
"""
from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from pipeline.common.config import load_config, run_config  # noqa: E402
from pipeline.dem.planar_run import PlanarShearRun  # noqa: E402
from packing_swap import htop_per_chunk  # noqa: E402

CASE = "shear_gravity"


def pour_and_shear(config_path: str, run: str, out: str, fraction: float, chunks: int) -> tuple[str, float, list[float]]:
    config = run_config(load_config(Path(config_path)), CASE, run)
    runner = PlanarShearRun(config, CASE, run, Path(out) / run)
    runner.engine.insertion_solid_fraction = fraction  # the one change: the loose box's height
    runner.run_dir.mkdir(parents=True, exist_ok=True)
    runner.engine.copy_templates(runner.case["geometry"], runner.run_dir)
    runner._load_state()
    if "fill" not in runner.state:
        runner._fill()
    plan = runner._chunk_plan()
    for k in range(len(runner.state["chunks"]), chunks):
        runner._run_chunk("shear", k, plan)
    d = float(runner.mat["d"])
    return run, runner.state["fill"]["settled_gap"] / d, htop_per_chunk(runner.run_dir, d, ("shear",))[:chunks]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--fraction", type=float, default=0.15)
    parser.add_argument("--chunks", type=int, default=4)
    parser.add_argument("--runs", nargs="+", default=["r1", "r2", "r3", "r4"])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--roots", nargs="+", default=["results-damping-off", "results-lammps-damping-off",
                                                        "results-lammps-liggghts-packing", "results-liggghts-lammps-packing"])
    args = parser.parse_args(argv)
    with ProcessPoolExecutor(args.jobs) as pool:
        done = list(pool.map(pour_and_shear, [args.config] * len(args.runs), args.runs, [args.out] * len(args.runs),
                             [args.fraction] * len(args.runs), [args.chunks] * len(args.runs)))
    print(f"top wall's mean height per shear chunk (d), the first {args.chunks}; mean +- standard error over the runs")

    def line(label: str, rows: list[list[float]]) -> None:
        a = np.array(rows)
        cells = ", ".join(f"{m:.2f}+-{s:.2f}" for m, s in zip(a.mean(0), a.std(0, ddof=1) / np.sqrt(len(a))))
        print(f"  {label:58} {cells}")

    line(f"LIGGGHTS pour at loose fraction {args.fraction:g} (this run)", [h for _, _, h in done])
    for root in args.roots:
        rows = [htop_per_chunk(Path(root) / "dem" / CASE / run, 0.002, ("shear",))[:args.chunks] for run in args.runs]
        if all(len(r) == args.chunks for r in rows):
            line(root, rows)
    print("settled gap / d (this run):", ", ".join(f"{run} {g:.2f}" for run, g, _ in done))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
