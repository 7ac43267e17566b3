"""``python -m pipeline.dem``: one DEM run of a case, planar shear or intruder by its geometry."""
from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.common import atomic
from pipeline.common.cli import positive_int
from pipeline.common.config import continues_from_slower, dem_runs, load_config, shared_fill_ids, shared_fill_of, size_study_cell
from pipeline.dem.intruder_run import IntruderRun, YieldProbe
from pipeline.dem.planar_run import FILL_RECORD, PlanarShearRun
from pipeline.dem.shared_fill import run_shared_fill


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="One LIGGGHTS run of a case: fill and settle, shear until steady, produce "
                    "(planar shear, or the intruder case by its geometry).")
    parser.add_argument("--config", required=True, help="workflow config (YAML)")
    parser.add_argument("--case", required=True, help="case name in the config (rheometer, shear_gravity, intruder)")
    parser.add_argument("--run", required=True, help="run id (e.g. I0.02-r1, r2, D5-r1, D5-control-r1)")
    parser.add_argument("--out", help="run folder (default: <output_root>/dem/<case>/<run>)")
    parser.add_argument("--mpi-ranks", type=positive_int, help="override dem.mpi_ranks")
    parser.add_argument("--mpi-launcher", help="override dem.mpi_launcher, the launcher of a run on several ranks (one rank always starts the binary directly)")
    parser.add_argument("--probe-yield", action="store_true",
                        help="intruder cases: measure the rod's yield force (staircase, wall at rest)")
    parser.add_argument("--fill-only", action="store_true",
                        help="run a shared fill (--run fill-<...>: a rheometer replica's with cases.rheometer.shared_fill, an intruder "
                             "control's): pour and settle only, write fill.json")
    parser.add_argument("--fill-from", help="folder of the shared fill this run starts from (its fill.json)")
    parser.add_argument("--start-from", help="folder of the finished slower rheometer state whose final packing this "
                                             "state shears from (cases.rheometer.continue_above)")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    if args.mpi_ranks is not None:
        config["dem"]["mpi_ranks"] = args.mpi_ranks
    if args.mpi_launcher is not None:
        config["dem"]["mpi_launcher"] = args.mpi_launcher
    if args.case not in config["cases"]:
        parser.error(f"case {args.case!r} is not in {args.config} (cases: {', '.join(config['cases'])})")
    case = config["cases"][args.case]
    out = Path(args.out) if args.out else Path(config["output_root"]) / "dem" / args.case / args.run
    if args.fill_only:
        fills = shared_fill_ids(args.case, case)
        if args.run not in fills:
            parser.error(f"--fill-only --run {args.run!r}: not a shared fill of case {args.case!r} in {args.config} "
                         f"(its fills: {', '.join(fills) or 'none'})")
        record = run_shared_fill(config, args.case, args.run, out)
        atomic.write_json(record, out / FILL_RECORD)
        print(f"{args.case}/{args.run}: {record['steps_by_stage']['fill']} steps in {record['fill']['wall_seconds']:.1f} s of "
              f"{record['fill'].get('engine', 'liggghts')}")
        return 0
    runs = [r for c, r in dem_runs(config) if c == args.case]
    # Size-study runs (L<cell>-r<k>) belong to their case's study, which a run's own config omits.
    if args.run not in runs and size_study_cell(args.run) is None:
        parser.error(f"--run {args.run!r} is not a run of case {args.case!r} in {args.config} "
                     f"(its runs: {', '.join(runs[:12])}{' ...' if len(runs) > 12 else ''})")
    intruder = case["geometry"] == "intruder"
    # The probe pours its own fill: a study of its own, not a run of the workflow.
    if args.probe_yield:
        if not intruder:
            parser.error(f"--probe-yield needs an intruder case; {args.case!r} is planar shear")
        result = YieldProbe(config, args.case, args.run, out).run()
        print(f"yield coefficient between {result['largest_held_coefficient']} and {result['first_moving_coefficient']} (x p D L)")
        return 0
    # Without --fill-from a run whose fill is shared pours that same fill itself (its seed is the fill's).
    if args.fill_from is not None and shared_fill_of(args.case, case, args.run) is None:
        parser.error(f"--fill-from: run {args.run!r} of case {args.case!r} pours its own fill (it shares none)")
    fill_from = Path(args.fill_from) if args.fill_from else None
    chained = continues_from_slower(args.case, case, args.run)
    if chained and args.start_from is None:
        parser.error(f"--run {args.run!r}: its target I is above cases.{args.case}.continue_above ({case['continue_above']:g}), so it "
                     "shears from the next slower state's final packing: give --start-from that state's folder")
    if args.start_from is not None and not chained:
        parser.error(f"--start-from: run {args.run!r} of case {args.case!r} starts from its fill "
                     "(only rheometer states above continue_above continue from another's packing)")
    if intruder:
        record = IntruderRun(config, args.case, args.run, out, fill_from=fill_from).run()
    else:
        record = PlanarShearRun(config, args.case, args.run, out, fill_from=fill_from,
                                start_from=Path(args.start_from) if args.start_from else None).run()
    atomic.write_json(record, out / "run.json")
    if intruder:
        rod = record["intruder"]
        print(f"{args.case}/{args.run}: depth {rod['depth_over_d']:.2f} d, speed {rod['speed']:.3g} +- {rod['speed_err']:.2g} m/s, "
              f"arrested {rod['arrested']}")
    else:
        print(f"{args.case}/{args.run}: {record['steps']} steps in {record['wall_clock_seconds']:.1f} s of {record['engine']}")
    return 0
