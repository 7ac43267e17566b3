"""``python -m pipeline.coarse_graining [dumps]``: any LIGGGHTS/LAMMPS text dumps into fields (NetCDF).

    python -m pipeline.coarse_graining PARTICLE_DUMP... [--contacts CONTACT_DUMP...] --out FILE.nc
        [--width W] [--kernel gaussian|lucy] [--bins N | --dx DX] [--axis z | --plane xz] [--t-start T]

The fields are :func:`pipeline.coarse_graining.coarse_grain.coarse_grain`'s; a contact dump is
checked to be the particle dump's at every averaged step first (:mod:`pipeline.coarse_graining.pairing`).
With ``--plane xz`` a ``.vts`` for ParaView is written beside the NetCDF, first: the NetCDF,
written last, says the step finished.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from pipeline.coarse_graining.coarse_grain import CoarseGrainError, coarse_grain, plane_grid, profile_grid, write_netcdf
from pipeline.coarse_graining.kernels import KERNELS, Kernel
from pipeline.coarse_graining.pairing import check_contacts_match
from pipeline.coarse_graining.vtk import write_fields_vtk
from pipeline.common import atomic
from pipeline.common.cli import nonnegative_float, positive_float, positive_int
from pipeline.dumps.reader import DumpError, read_contacts, read_particles


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="Coarse-grain LAMMPS/LIGGGHTS text dumps (dump custom particles, dump local contacts) "
                    "into time-averaged continuum fields with standard errors, written as NetCDF.",
        epilog="Particle dumps need columns x y z (or xu/xs) vx vy vz radius (or diameter) mass, found by "
               "name; contact dumps need x1 y1 z1 x2 y2 z2 fx fy fz (force on particle 1), either by name "
               "or as generic c_ID[k] columns mapped with --contact-columns (default: LIGGGHTS "
               "pair/gran/local 'pos id force contactPoint delta' order). Stress is compressive positive.")
    parser.add_argument("particle_dump", type=Path, nargs="+", help="particle dump file(s), joined in time")
    parser.add_argument("--contacts", type=Path, nargs="+", default=None, help="contact dump file(s)")
    parser.add_argument("--contact-columns", default=None,
                        help="physical names of c_ID[1], c_ID[2], ... separated by spaces or commas")
    parser.add_argument("--out", type=Path, required=True, help="output NetCDF file")
    parser.add_argument("--width", type=positive_float, default=None, help="kernel width w in m (default: half the mean diameter)")
    parser.add_argument("--kernel", choices=KERNELS, default="gaussian", help="gaussian (cut at 3 w) or lucy")
    bins = parser.add_mutually_exclusive_group()
    bins.add_argument("--bins", type=positive_int, default=None, help="number of z points")
    bins.add_argument("--dx", type=positive_float, default=None, help="grid spacing in m (default w / 2)")
    geom = parser.add_mutually_exclusive_group()
    geom.add_argument("--axis", choices=("z",), default="z", help="profile along z (x and y integrated)")
    geom.add_argument("--plane", choices=("xz",), default=None, help="2D field in x-z (y integrated)")
    parser.add_argument("--t-start", type=nonnegative_float, default=None, help="first time to average from (s; needs --time-step)")
    parser.add_argument("--time-step", type=positive_float, default=None, help="DEM time step in s (timestep -> time)")
    parser.add_argument("--blocks", type=positive_int, default=5, help="blocks for the standard errors (default 5)")
    parser.add_argument("--body-types", default="all",
                        help="particle types gravity acts on, for rho_body (comma list, or 'all')")
    parser.add_argument("--rho-s", type=positive_float, default=None,
                        help="grain density in kg m-3 (default: from mass and radius; needed when the dump has no mass)")
    parser.add_argument("--diameter", type=positive_float, default=None,
                        help="grain diameter in m, for a dump without a radius or diameter column (monodisperse)")
    parser.add_argument("--d", type=positive_float, default=None, help="particle diameter for I (default: mean diameter)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    # Every output of this step, the side file too, from this invocation only.
    atomic.clear_stale(args.out.with_suffix(".vts"), temporaries_of=(args.out,))
    try:
        particles = read_particles(args.particle_dump, rho_s=args.rho_s, diameter=args.diameter)
        names = None
        if args.contact_columns:
            names = [n for n in args.contact_columns.replace(",", " ").split() if n]
        contacts = read_contacts(args.contacts, names) if args.contacts else None
        chosen = np.arange(len(particles))
        if args.t_start is not None:
            if args.time_step is None:
                raise CoarseGrainError("--t-start needs --time-step (dumps carry timesteps, not times)")
            chosen = np.nonzero(particles.timesteps * args.time_step >= args.t_start)[0]
            if chosen.size == 0:
                times = particles.timesteps * args.time_step
                raise CoarseGrainError(f"--t-start {args.t_start:g} s is after the last snapshot: the dumps span "
                                       f"{times.min():.6g} to {times.max():.6g} s (with --time-step {args.time_step:g})")
        if contacts is not None:
            check_contacts_match(particles, contacts, chosen)
        radius = particles.column("radius")
        d = args.d if args.d is not None else float(2.0 * radius.mean())
        width = args.width if args.width is not None else 0.5 * d
        kernel = Kernel(args.kernel, width)
        z = particles.column("z")
        dx = args.dx if args.dx is not None else width / 2.0
        if args.plane:
            box = particles.boxes[0]
            grid = plane_grid(float(box[0, 0]), float(box[0, 1] - box[0, 0]), float(z.min()), float(z.max()), dx,
                              bins_z=args.bins)
        else:
            grid = profile_grid(float(z.min()), float(z.max()), bins=args.bins, dz=dx)
        body = None if args.body_types == "all" else [int(t) for t in args.body_types.split(",")]
        result = coarse_grain(particles, contacts, kernel, grid, snapshots=chosen, d=d, rho_s=args.rho_s,
                              blocks=args.blocks, time_step=args.time_step, body_types=body)
    except (DumpError, CoarseGrainError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    ds = result.dataset
    ds.attrs["particle_dumps"] = " ".join(str(p) for p in args.particle_dump)
    ds.attrs["contact_dumps"] = " ".join(str(p) for p in args.contacts or [])
    # The side file first: the main file, written last, says the step finished.
    if args.plane:
        print(f"{write_fields_vtk(ds, args.out.with_suffix('.vts'))}: the x-z fields for ParaView")
    write_netcdf(ds, args.out)
    print(f"{args.out}: {ds.attrs['number_of_snapshots']} snapshots, grid {dict(ds.sizes)}, "
          f"{result.seconds:.2f} s")
    return 0
