"""Do the stated error bars hold? Replica scatter against the fields' standard errors.

For independent replicas a and b of a case, at each interior profile point the difference of a
field has variance ``err_a^2 + err_b^2`` if the stated errors are right, so

    chi2 = mean over points and replica pairs of (a - b)^2 / (err_a^2 + err_b^2)

is 1 on average: well above 1 the errors understate the noise, well below they overstate it.
Neighbouring points share grains through the kernel, so the number of independent points is
about (interior points) x spacing / (kernel width); the table gives the chi2's own standard error,
sqrt(2 / independent points / pairs), to judge a departure from 1. Written to
``validation/error_check.csv`` (case, field, chi2, chi2_err, pairs, points).
"""
from __future__ import annotations

import argparse
import itertools
import math
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common import atomic
from pipeline.scoring.scores import align_replicas, interior

FIELDS = ("u_x", "u_x_disp", "nu", "sigma_zz", "sigma_xz", "mu")


def replica_chi2(reps: list[xr.Dataset], field: str) -> dict[str, float]:
    """The chi2 of one field over the replica pairs of a case (module docstring)."""
    mask = interior(reps[0])
    z = reps[0].z.values
    width = float(reps[0].attrs.get("width", z[1] - z[0]))
    terms, pairs = [], 0
    for a, b in itertools.combinations(reps, 2):
        if field not in a or field not in b:
            continue
        da, db = a[field].values[mask], b[field].values[mask]
        ea, eb = a[f"{field}_err"].values[mask], b[f"{field}_err"].values[mask]
        ok = np.isfinite(da) & np.isfinite(db) & (ea**2 + eb**2 > 0)
        terms.append(((da - db) ** 2 / (ea**2 + eb**2))[ok])
        pairs += 1
    if not pairs:
        return {"chi2": float("nan"), "chi2_err": float("nan"), "pairs": 0, "points": 0}
    values = np.concatenate(terms)
    independent = max(values.size / pairs * (z[1] - z[0]) / width, 1.0)
    return {"chi2": float(values.mean()), "chi2_err": float(math.sqrt(2.0 / independent / pairs)), "pairs": pairs,
            "points": int(values.size / pairs)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Replica scatter against the stated error bars, per case and field.")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="fields/CASE/RUN.nc (replicas grouped by folder)")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    rows = []
    for case in sorted({p.parent.name for p in args.fields}):
        files = sorted(p for p in args.fields if p.parent.name == case)
        if len(files) < 2:
            continue
        reps = align_replicas([xr.open_dataset(f) for f in files])
        for field in FIELDS:
            rows.append({"case": case, "field": field, **replica_chi2(reps, field)})
        for ds in reps:
            ds.close()
    table = pd.DataFrame(rows, columns=["case", "field", "chi2", "chi2_err", "pairs", "points"])
    atomic.write_csv(table, args.out)
    print(table.to_string(index=False))
    return 0
