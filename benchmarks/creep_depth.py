"""How many decades of creep a production window resolves, and what more would cost (issue 15).

For each replica of a gravity case in a finished output root, the displacement creep speed
``u_x_disp`` and its error (time blocks and the frozen structure, exactly as the fields files:
:mod:`pipeline.coarse_graining.displacement`) are recomputed on the first 25, 50, 75 and 100 %
of the production window, and the decades of u_x / V resolved above 2 sigma are counted inside
the wall margin (:func:`pipeline.common.observables.decades_resolved`), per replica and for the
replicas' mean (the error the larger of the combined stated errors and the scatter over sqrt(n),
as ``validation/creep_resolution.csv``). A line of decades against log10(strain) over the windows
then gives the production strain that would resolve ``--goal`` decades, and its LIGGGHTS
core-seconds at the run's own production rate (core-s per strain, from run.json).

Usage: ``python benchmarks/creep_depth.py --root results [--case shear_gravity] [--goal 4]``
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.coarse_graining.displacement import displacement_structural_error, displacement_velocity  # noqa: E402
from pipeline.coarse_graining.coarse_grain import profile_grid  # noqa: E402
from pipeline.coarse_graining.fields import load_tables, settings, steady_snapshots  # noqa: E402
from pipeline.coarse_graining.field_checks import wall_geometry  # noqa: E402
from pipeline.coarse_graining.kernels import Kernel  # noqa: E402
from pipeline.common.config import load_config  # noqa: E402
from pipeline.common.observables import decades_resolved, replica_mean  # noqa: E402
from pipeline.dumps.store import read_run_json  # noqa: E402
from pipeline.scoring.scores import WALL_MARGIN_OVER_D  # noqa: E402

FRACTIONS = (0.25, 0.5, 0.75, 1.0)


def window_profiles(run_dir: Path, opts: dict, fraction: float) -> dict:
    """u_x_disp / V, its error / V and depth below the top wall (m) on the first ``fraction`` of
    the production window, with the window's strain."""
    run = read_run_json(run_dir)
    particles, _ = load_tables(run_dir, run)
    chosen = steady_snapshots(particles, run)
    chosen = chosen[:max(3, int(math.ceil(fraction * chosen.size)))]
    d = float(run["d"])
    kernel = Kernel(opts["kernel"], opts["width_over_d"] * d)
    walls = wall_geometry(particles, chosen)
    z = profile_grid(walls.bottom_mean, walls.top_mean, dz=opts["spacing_over_width"] * kernel.width).z
    times = particles.timesteps[chosen] * float(run["time_step"])
    u, err_time = displacement_velocity(particles, chosen, times, kernel, z, int(opts["blocks"]))
    margin = opts["bulk_margin_over_d"] * d
    bulk = (z >= walls.bottom_mean + margin) & (z <= walls.top_mean - margin)
    err_structure, _ = displacement_structural_error(particles, chosen, times, kernel, z, d, bulk)
    v = float(run["wall_speed"])
    inside = (z >= walls.bottom_mean + WALL_MARGIN_OVER_D * d) & (z <= walls.top_mean - WALL_MARGIN_OVER_D * d)
    depth = walls.top_mean - z
    gap = walls.top_mean - walls.bottom_mean
    strain = v * float(times[-1] - times[0]) / gap
    chunks = json.loads((run_dir / "state.json").read_text())["chunks"]
    seconds = sum(c["wall_seconds"] for c in chunks if c["kind"] == "production") * int(run.get("mpi_ranks", 1))
    return {"u": u[inside] / v, "err": np.fmax(err_time, err_structure)[inside] / v, "depth": depth[inside],
            "strain": strain, "production_core_s": seconds, "d": d}


def replica_mean_decades(profiles: list[dict]) -> tuple[float, float]:
    """Decades resolved by the replicas' mean, aligned by depth below the top wall."""
    depth = profiles[0]["depth"]
    us, errs = [], []
    for p in profiles:
        order = np.argsort(p["depth"])
        us.append(np.interp(depth, p["depth"][order], p["u"][order], left=np.nan, right=np.nan))
        errs.append(np.interp(depth, p["depth"][order], p["err"][order], left=np.nan, right=np.nan))
    mean, err = replica_mean(np.array(us), np.array(errs))
    return decades_resolved(mean, err, 1.0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, required=True, help="output root of a finished workflow")
    parser.add_argument("--case", default="shear_gravity", help="a gravity case (default shear_gravity)")
    parser.add_argument("--goal", type=float, default=4.0, help="decades of u_x / V asked for (default 4)")
    args = parser.parse_args(argv)
    runs = sorted(p for p in (args.root / "dem" / args.case).glob("r*") if p.name[1:].isdigit())
    if not runs:
        print(f"creep_depth: no replica r<k> of case {args.case!r} under {args.root / 'dem'}", file=sys.stderr)
        return 2
    config = load_config(args.root / "config.effective.json")
    opts = settings(config)
    rows = []
    # LIGGGHTS core-seconds per strain of each run's whole production window.
    whole = [window_profiles(r, opts, 1.0) for r in runs]
    rate = {r.name: p["production_core_s"] / p["strain"] for r, p in zip(runs, whole)}
    for fraction in FRACTIONS:
        profiles = whole if fraction == 1.0 else [window_profiles(r, opts, fraction) for r in runs]
        for r, p in zip(runs, profiles):
            decades, slowest = decades_resolved(p["u"], p["err"], 1.0)
            rows.append({"run": r.name, "fraction": fraction, "strain": p["strain"], "decades": decades,
                         "slowest_over_v": slowest, "core_s_per_strain": rate[r.name]})
        decades, slowest = replica_mean_decades(profiles)
        rows.append({"run": f"mean of {len(runs)}", "fraction": fraction,
                     "strain": float(np.mean([p["strain"] for p in profiles])), "decades": decades,
                     "slowest_over_v": slowest,
                     "core_s_per_strain": float(sum(rate.values()))})
    table = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    print(f"Decades of u_x / V resolved above 2 sigma (u_x_disp), {args.case}, against the production strain averaged")
    print(table.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"\nproduction strain for {args.goal:g} decades (line of decades against log10 strain over the windows):")
    for run, group in table.groupby("run", sort=False):
        slope, intercept = np.polyfit(np.log10(group.strain), group.decades, 1)
        need = 10 ** ((args.goal - intercept) / slope) if slope > 0 else math.inf
        cost = need * float(group.core_s_per_strain.iloc[-1])
        print(f"  {run}: {slope:.2f} decades per decade of strain; {args.goal:g} decades at {need:.3g} strain, "
              f"{cost:.3g} core-s of production")
    return 0


if __name__ == "__main__":
    sys.exit(main())
