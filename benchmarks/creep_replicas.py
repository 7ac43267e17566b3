"""Creep resolved against the number of replicas: does the count ``replicas_for_target`` asks for
reach the target?

``validation/creep_resolution.csv`` asks, per case, for ``n * error_over_needed^2`` replicas to
resolve the case's target decades of u_x / V (``pipeline/scoring/creep_resolution.py``: the
replica mean's errors fall as 1 / sqrt(n)). This benchmark reads more replicas of a case than the
workflow ran (the fields of extra runs of the same config with more ``replicas``, in other output
roots) and prints, for every n from 2 to all, the decades resolved, ``error_over_needed`` and
``replicas_for_target`` of the mean over every subset of n replicas (their median and range), and
of the first n (r1..rn, the workflow's choice). It prints; it asserts nothing.

``--half first`` reads each replica's creep over the first half of its production only
(:func:`pipeline.common.observables.creep_half`): the run as it would have been with half its
production strain (the steady window is the production's start, and every run of the default
produces to its cap). Against the whole window, it says how the replica mean's error falls with
the averaging time, as the subsets say how it falls with n.

Usage: ``python benchmarks/creep_replicas.py --case shear_gravity --target 4 [--half first] ROOT [ROOT ...]``
(each ROOT an output root holding ``fields/<case>/r<k>.nc``; a run id found in two roots is read
from the first).
"""
from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np
import xarray as xr

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.common.observables import creep_half  # noqa: E402
from pipeline.scoring.creep_resolution import DecadesTargets, replica_mean_resolution  # noqa: E402

#: Subsets read per n at the most (all of them below this).
MAX_SUBSETS = 200


def replica_files(roots: list[Path], case: str) -> list[Path]:
    """``fields/<case>/r<k>.nc`` of every root, by run id, first root first; ordered by k."""
    found: dict[int, Path] = {}
    for root in roots:
        for path in sorted((root / "fields" / case).glob("r*.nc")):
            if path.stem[1:].isdigit():
                found.setdefault(int(path.stem[1:]), path)
    return [found[k] for k in sorted(found)]


def half_window_files(files: list[Path], case: str, half: str, work: Path) -> list[Path]:
    """``files`` with their creep over one ``half`` of the production, written under ``work``."""
    out = []
    folder = work / f"{half}_half" / case
    folder.mkdir(parents=True, exist_ok=True)
    for k, path in enumerate(files, start=1):
        target = folder / f"r{k}.nc"
        with xr.open_dataset(path) as ds:
            creep_half(ds.load(), half).to_netcdf(target)
        out.append(target)
    return out


def subset_row(files: list[Path], case: str, target: float, work: Path) -> dict[str, object]:
    """The replica mean's resolution row of ``files`` (linked into ``work`` under one case folder,
    as the workflow lays them out)."""
    folder = work / "fields" / case
    for old in folder.glob("*.nc"):
        old.unlink()
    folder.mkdir(parents=True, exist_ok=True)
    links = []
    for k, path in enumerate(files, start=1):
        link = folder / f"r{k}.nc"
        link.symlink_to(path.resolve())
        links.append(link)
    return replica_mean_resolution(links, DecadesTargets(case, target, target))[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("roots", nargs="+", type=Path, help="output roots with fields/<case>/r<k>.nc")
    parser.add_argument("--case", required=True)
    parser.add_argument("--target", type=float, required=True, help="decades of u_x / V to resolve")
    parser.add_argument("--half", choices=("first", "second"), help="the creep of one half of each production only")
    parser.add_argument("--work", type=Path, default=Path("/tmp/creep_replicas"), help="scratch folder for the links")
    args = parser.parse_args(argv)
    files = replica_files(args.roots, args.case)
    if len(files) < 2:
        print(f"error: fewer than 2 replicas of {args.case} under {', '.join(map(str, args.roots))}", file=sys.stderr)
        return 1
    print(f"{args.case}: {len(files)} replicas ({', '.join(str(f) for f in files)}); target {args.target:g} decades")
    if args.half:
        files = half_window_files(files, args.case, args.half, args.work)
        print(f"creep over the {args.half} half of each production")
    print(f"{'n':>2} {'subsets':>7}  {'decades median [range]':>24}  {'met':>5}  {'error_over_needed median':>24}  "
          f"{'replicas asked (median)':>23}  first n: decades, error_over_needed, asked")
    for n in range(2, len(files) + 1):
        subsets = list(itertools.combinations(files, n))
        if len(subsets) > MAX_SUBSETS:
            pick = np.random.default_rng(n).choice(len(subsets), MAX_SUBSETS, replace=False)
            subsets = [subsets[i] for i in sorted(pick)]
        rows = [subset_row(list(s), args.case, args.target, args.work) for s in subsets]
        decades = np.array([r["decades_best"] for r in rows], dtype=float)
        factor = np.array([r["error_over_needed"] for r in rows], dtype=float)
        asked = np.array([r["replicas_for_target"] for r in rows], dtype=float)
        met = np.mean([bool(r["target_met"]) for r in rows])
        first = subset_row(files[:n], args.case, args.target, args.work)
        print(f"{n:>2} {len(rows):>7}  {np.median(decades):8.2f} [{decades.min():.2f}, {decades.max():.2f}]  "
              f"{met:5.2f}  {np.nanmedian(factor):24.2f}  {np.nanmedian(asked):23.0f}  "
              f"{first['decades_best']:.2f}, {first['error_over_needed']:.2f}, {first['replicas_for_target']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
