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
from pipeline.common.config import ConfigError, load_config  # noqa: E402
from pipeline.common.observables import decades_resolved, replica_mean  # noqa: E402
from pipeline.dumps.store import read_run_json  # noqa: E402
from pipeline.scoring.replicas import WALL_MARGIN_OVER_D  # noqa: E402

FRACTIONS = (0.25, 0.5, 0.75, 1.0)


def run_windows(run_dir: Path, opts: dict) -> list[dict]:
    """For each of :data:`FRACTIONS`, u_x_disp / V, its error / V and the depth below the top wall
    (m) inside the wall margin on the first ``fraction`` of the production window, with the
    window's strain and the run's production core-seconds. The dumps are read once."""
    run = read_run_json(run_dir)
    particles, _ = load_tables(run_dir, run)
    steady = steady_snapshots(particles, run)
    d, v = float(run["d"]), float(run["wall_speed"])
    kernel = Kernel(opts["kernel"], opts["width_over_d"] * d)
    chunks = json.loads((run_dir / "state.json").read_text())["chunks"]
    seconds = sum(c["wall_seconds"] for c in chunks if c["kind"] == "production") * int(run.get("mpi_ranks", 1))
    out = []
    for fraction in FRACTIONS:
        chosen = steady[:max(3, int(math.ceil(fraction * steady.size)))]
        walls = wall_geometry(particles, chosen)
        z = profile_grid(walls.bottom_mean, walls.top_mean, dz=opts["spacing_over_width"] * kernel.width).z
        times = particles.timesteps[chosen] * float(run["time_step"])
        u, err_time = displacement_velocity(particles, chosen, times, kernel, z, int(opts["blocks"]))
        margin = opts["bulk_margin_over_d"] * d
        bulk = (z >= walls.bottom_mean + margin) & (z <= walls.top_mean - margin)
        err_structure, _ = displacement_structural_error(particles, chosen, times, kernel, z, d, bulk)
        inside = (z >= walls.bottom_mean + WALL_MARGIN_OVER_D * d) & (z <= walls.top_mean - WALL_MARGIN_OVER_D * d)
        out.append({"u": u[inside] / v, "err": np.fmax(err_time, err_structure)[inside] / v,
                    "depth": (walls.top_mean - z)[inside],
                    "strain": v * float(times[-1] - times[0]) / (walls.top_mean - walls.bottom_mean),
                    "production_core_s": seconds})
    return out


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
    config_path = args.root / "config.effective.json"
    try:
        opts = settings(load_config(config_path))
    except ConfigError as err:
        print(f"creep_depth: {err} (--root must be the output root of a finished workflow)", file=sys.stderr)
        return 2
    windows = {r.name: run_windows(r, opts) for r in runs}
    # LIGGGHTS core-seconds per strain of each run's whole production window.
    rate = {name: w[-1]["production_core_s"] / w[-1]["strain"] for name, w in windows.items()}
    rows = []
    for k, fraction in enumerate(FRACTIONS):
        profiles = {name: w[k] for name, w in windows.items()}
        for name, p in profiles.items():
            decades, slowest = decades_resolved(p["u"], p["err"], 1.0)
            rows.append({"run": name, "fraction": fraction, "strain": p["strain"], "decades": decades,
                         "slowest_over_v": slowest, "core_s_per_strain": rate[name]})
        first = next(iter(profiles.values()))
        mean, err = replica_mean(first["depth"], [(p["depth"], p["u"], p["err"]) for p in profiles.values()])
        decades, slowest = decades_resolved(mean, err, 1.0)
        rows.append({"run": f"mean of {len(runs)}", "fraction": fraction,
                     "strain": float(np.mean([p["strain"] for p in profiles.values()])), "decades": decades,
                     "slowest_over_v": slowest, "core_s_per_strain": float(sum(rate.values()))})
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
