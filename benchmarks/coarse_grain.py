"""Coarse-graining throughput on a DEM run folder, and two ratios against the same run.

Prints particle-snapshots per second and contacts per second of the coarse-graining (profiles
along z, the workflow's default settings), then

- coarse-graining time / DEM wall-clock time of the run (run.json ``wall_clock_seconds``),
  goal at most 0.05;
- coarse-graining time / bare parse time of the same text dumps, goal at most 2.

"Coarse-graining time" is the whole fields step as the workflow runs it from the text dumps:
parse, coarse-grain, checks (the first ratio's numerator); the line "compute only" separates the
kernel sums from the parse. Best of ``--repeat`` runs each. ``--plane`` also times the x-z fields
(the intruder case's geometry, all snapshots of the window in one batched pass) per snapshot.

Usage: ``python -m benchmarks.coarse_grain [RUN_DIR] [--repeat 3] [--plane]``
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from pipeline.coarse_graining import fields
from pipeline.coarse_graining.coarse_grain import coarse_grain, plane_grid, profile_grid
from pipeline.dumps.store import parse_run
from pipeline.coarse_graining.field_checks import wall_geometry
from pipeline.coarse_graining.kernels import Kernel


def best(func, repeat: int) -> tuple[float, object]:
    out, fastest = None, float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = func()
        fastest = min(fastest, time.perf_counter() - t0)
    return fastest, out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path, nargs="?", default=Path("/tmp/gv_sg"))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--plane", action="store_true", help="also time the x-z fields")
    args = parser.parse_args(argv)
    run = json.loads((args.run_dir / "run.json").read_text())
    config = {"material": {"d": run["d"], "rho_s": run["density"]}}
    t_parse, (particles, contacts) = best(lambda: parse_run(args.run_dir, run), args.repeat)
    chosen = fields.steady_snapshots(particles, run)
    kernel = Kernel("gaussian", fields.DEFAULTS["width_over_d"] * run["d"])
    walls = wall_geometry(particles, chosen)
    grid = profile_grid(walls.bottom_mean, walls.top_mean, dz=fields.DEFAULTS["spacing_over_width"] * kernel.width)
    t_compute, _ = best(lambda: coarse_grain(particles, contacts, kernel, grid, snapshots=chosen, d=run["d"],
                                             rho_s=run["density"]), args.repeat)
    store = args.run_dir / "dumps.nc"
    hidden = None
    if store.exists():  # time the step from the text dumps, as a fresh workflow would
        hidden = store.rename(store.with_name(".dumps.nc.bench"))
    try:
        t_step, _ = best(lambda: fields.run_fields(config, args.run_dir), args.repeat)
    finally:
        if hidden is not None:
            hidden.rename(store)
    n_particles = int(particles.counts[chosen].sum())
    n_contacts = int(contacts.counts[[list(contacts.timesteps).index(t) for t in particles.timesteps[chosen]]].sum()) \
        if contacts is not None else 0
    dem = float(run["wall_clock_seconds"])
    print(f"run {args.run_dir}: {len(chosen)} snapshots, {n_particles} particle-snapshots, {n_contacts} contacts, "
          f"{grid.z.size} z points, kernel {kernel.name} w = {kernel.width:.3g} m")
    print(f"bare parse of the text dumps:   {t_parse:.3f} s")
    print(f"coarse-graining, compute only:  {t_compute:.3f} s  -> {n_particles / t_compute:,.0f} particle-snapshots/s, "
          f"{n_contacts / t_compute:,.0f} contacts/s")
    print(f"fields step (parse + coarse-grain + checks): {t_step:.3f} s")
    print(f"ratio coarse-graining / DEM wall clock ({dem:.1f} s): {t_step / dem:.4f}  (goal <= 0.05)")
    print(f"ratio coarse-graining / bare parse: {t_step / t_parse:.2f} (whole step), "
          f"{(t_compute + t_parse) / t_parse:.2f} (parse + compute only)  (goal <= 2)")
    if args.plane:
        box = particles.boxes[chosen[0]]
        pgrid = plane_grid(float(box[0, 0]), float(run["cell"][0]), walls.bottom_mean, walls.top_mean,
                           fields.DEFAULTS["spacing_over_width"] * kernel.width)
        t_plane, _ = best(lambda: coarse_grain(particles, contacts, kernel, pgrid, snapshots=chosen, d=run["d"],
                                               rho_s=run["density"]), args.repeat)
        print(f"x-z fields ({pgrid.x.size} x {pgrid.z.size} points), compute only: {t_plane:.3f} s -> "
              f"{t_plane / len(chosen):.4f} s per snapshot")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
