"""Do the stated error bars hold? Replica scatter against the fields' standard errors.

For independent replicas of a case, at each interior profile point the scatter of a field about
the replicas' inverse-variance mean, in units of each replica's stated error, has n - 1 degrees
of freedom if the stated errors are right, so

    chi2 = mean over points of sum_r (x_r - xbar)^2 / err_r^2 / (n - 1)

is 1 on average: well above 1 the errors understate the noise, well below they overstate it.
Neighbouring points are not independent (they share grains through the kernel, and a load-
controlled wall moves the whole profile at once), so the number of independent points is counted
from the correlation length of the standardised residuals along z (:func:`replica_chi2`); the
table gives chi2's standard error sqrt(2 / dof) and the probability of a departure from 1 at
least as large (``p_value``) if the errors hold. Written to ``validation/error_check.csv``
(case, field, chi2, chi2_err, pairs, points, replicas, dof, p_value, correlation_points,
error_scale), with the scalars' rows (:mod:`pipeline.scoring.scalar_checks`: the rheometer's bulk
means, the wall friction, the rods' speeds) after the profiles'. The command also writes the
creep's resolution (:mod:`pipeline.scoring.creep_resolution`) and its halves.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from scipy import stats

from pipeline.common.statistics import independent_points, integrated_autocorrelation_time
from pipeline.common import atomic
from pipeline.common.config import load_config
from pipeline.scoring import scalar_checks
from pipeline.scoring.creep_resolution import DecadesTargets, creep_resolution
from pipeline.scoring.replicas import align_replicas, interior

FIELDS = ("u_x", "u_x_disp", "nu", "sigma_zz", "sigma_xz", "mu")


def replica_chi2(reps: list[xr.Dataset], field: str) -> dict[str, float]:
    """The chi2 of one field over the replicas of a case (module docstring).

    At each interior point with n finite replicas, ``sum_r (x_r - xbar)^2 / err_r^2 / (n - 1)``
    with ``xbar`` the inverse-variance mean: n - 1 degrees of freedom per point. Neighbouring
    points are not independent (kernel overlap, and whole-profile fluctuations such as the load-
    controlled wall's), so the independent points along z are counted from the integrated
    autocorrelation ``tau`` (in points) of the standardised residuals ``(x_r - xbar) / err_r``:
    ``points / (2 tau)``. Returns chi2, its standard error ``sqrt(2 / dof)``, dof, the two-sided
    probability of a chi2 at least as far from 1 if the errors hold (``p_value``), pairs (for the
    table's earlier readers), points and the correlation length ``tau`` in points.
    """
    mask = interior(reps[0])
    have = [ds for ds in reps if field in ds and f"{field}_err" in ds]
    empty = {"chi2": math.nan, "chi2_err": math.nan, "pairs": 0, "points": 0, "replicas": len(have),
             "dof": math.nan, "p_value": math.nan, "correlation_points": math.nan}
    if len(have) < 2:
        return empty
    x = np.array([ds[field].values[mask] for ds in have])
    err = np.array([ds[f"{field}_err"].values[mask] for ds in have])
    ok = np.all(np.isfinite(x) & np.isfinite(err) & (err > 0), axis=0)
    if ok.sum() < 2:
        return empty
    x, err = x[:, ok], err[:, ok]
    n = len(have)
    weight = 1.0 / err**2
    mean = (weight * x).sum(axis=0) / weight.sum(axis=0)
    standardised = (x - mean) / err
    chi2 = float((standardised**2).sum(axis=0).mean() / (n - 1))
    tau = float(np.nanmean(integrated_autocorrelation_time(standardised.T)))
    points = int(ok.sum())
    independent = independent_points(points, tau)
    dof = (n - 1) * independent
    cdf = float(stats.chi2.cdf(chi2 * dof, dof))
    return {"chi2": chi2, "chi2_err": math.sqrt(2.0 / dof), "pairs": n * (n - 1) // 2, "points": points,
            "replicas": n, "dof": dof, "p_value": float(min(1.0, 2.0 * min(cdf, 1.0 - cdf))),
            "correlation_points": tau}


def scalar_rows(rheometer: list[Path], fields: list[Path], intruder_runs: list[Path]) -> list[dict]:
    """The scalars' replica checks (:mod:`pipeline.scoring.scalar_checks`): the rheometer states'
    bulk means, each planar case's wall friction, the rods' speeds."""
    rows = []
    if rheometer:
        states: dict[str, list[xr.Dataset]] = {}
        for path in rheometer:
            states.setdefault(path.stem.rsplit("-", 1)[0], []).append(xr.open_dataset(path))
        rows += scalar_checks.rheometer_rows(states)
        for reps in states.values():
            for ds in reps:
                ds.close()
    for case in sorted({p.parent.name for p in fields}):
        sets = [xr.open_dataset(p) for p in sorted(fields) if p.parent.name == case]
        if len(sets) >= 2:
            rows.append(scalar_checks.wall_friction_row(case, sets))
        for ds in sets:
            ds.close()
    if intruder_runs:
        runs = [json.loads(p.read_text()) for p in intruder_runs]
        rows.append(scalar_checks.rod_speed_row(runs))
        rows.append(scalar_checks.rod_halves_row(runs))
    return rows


def halves_table(fields: list[Path], intruder_runs: list[Path] = ()) -> pd.DataFrame:
    """``validation/creep_halves.csv``: each planar gravity run's production, first half against
    second, then each moving rod's speed (case ``intruder``)."""
    frames = []
    for path in sorted(fields):
        with xr.open_dataset(path) as ds:
            if float(ds.attrs.get("gravity", 0.0)) > 0:
                frames.append(scalar_checks.creep_halves(ds))
    if intruder_runs:
        frames.append(scalar_checks.rod_halves([json.loads(p.read_text()) for p in intruder_runs]))
    frames = [f for f in frames if not f.empty]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=scalar_checks.HALVES_COLUMNS)


def halves_summary(halves: pd.DataFrame) -> str:
    """One line: points whose halves differ beyond 2 (normal-equivalent, the Student t of each
    point's blocks) against the 4.55 % a steady run gives, per kind (planar creep, rods)."""
    parts = []
    for kind, frame in (("planar creep", halves[halves.case != "intruder"]), ("rods", halves[halves.case == "intruder"])):
        beyond, known = scalar_checks.beyond_two(frame)
        if known:
            parts.append(f"{kind}: {beyond} of {known} beyond 2 ({scalar_checks.STEADY_BEYOND_TWO * known:.1f} "
                         f"expected), mean z_normal {frame.z_normal.astype(float).mean():+.2f}")
    return "halves: " + ("; ".join(parts) if parts else "no halves with known blocks")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Replica scatter against the stated error bars, per case and field.")
    parser.add_argument("--config", default=None, help="the workflow config: the creep resolution's targets (scoring.creep_decades)")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="fields/CASE/RUN.nc (replicas grouped by folder)")
    parser.add_argument("--rheometer", nargs="*", default=[], type=Path, help="fields/rheometer/*.nc: the states' bulk means")
    parser.add_argument("--intruder-runs", nargs="*", default=[], type=Path, help="run.json of the intruder runs: the rods' speeds")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--resolution-out", type=Path, default=None,
                        help="also write the decades of creep each run resolves (validation/creep_resolution.csv)")
    parser.add_argument("--halves-out", type=Path, default=None,
                        help="also write each planar run's creep, first half of its production against the second "
                             "(validation/creep_halves.csv)")
    args = parser.parse_args(argv)
    # The config first: a bad target is named before any input is read or output written.
    targets = (DecadesTargets.from_config(load_config(args.config))
               if args.config and args.resolution_out is not None else None)
    # Read once: written point by point here, pooled per case into the table below.
    halves = halves_table(args.fields, args.intruder_runs)
    if args.halves_out is not None:
        atomic.write_csv(halves, args.halves_out)
        for (case, run), frame in halves.groupby(["case", "run"]):
            print(f"{case}/{run}: creep halves at {len(frame)} depths, mean z {frame.z.mean():+.2f}, "
                  f"chi2 {np.mean(frame.z ** 2):.2f}, beyond 2 (normal-equivalent) {scalar_checks.beyond_two(frame)[0]}")
        print(halves_summary(halves))
    if args.resolution_out is not None:
        resolution = creep_resolution(args.fields, targets)
        atomic.write_csv(resolution, args.resolution_out)
        print(resolution.to_string(index=False))
    rows = []
    for case in sorted({p.parent.name for p in args.fields}):
        files = sorted(p for p in args.fields if p.parent.name == case)
        if len(files) < 2:
            continue
        reps = align_replicas([xr.open_dataset(f) for f in files])
        for field in FIELDS:
            check = replica_chi2(reps, field)
            rows.append({"case": case, "field": field, **check,
                         "error_scale": scalar_checks.error_scale(check["chi2"], check["chi2_err"])})
        for ds in reps:
            ds.close()
    rows += scalar_rows(args.rheometer, args.fields, args.intruder_runs)
    # The planar creep's halves as one chi2 a case (the table above gives them point by point).
    for case in sorted(set(halves.case) - {"intruder"}):
        rows.append(scalar_checks.creep_halves_row(halves, case))
    table = pd.DataFrame(rows, columns=scalar_checks.SCALAR_COLUMNS)
    atomic.write_csv(table, args.out)
    print(table.to_string(index=False))
    return 0
