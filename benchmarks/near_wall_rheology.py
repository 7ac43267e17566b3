"""Benchmark (issue 54): is the gravity beds' band under the top wall on the rheometer's mu(I)?

Run as ``python benchmarks/near_wall_rheology.py ROOT [--depths 1 1.5 2 3 4]``. For every planar
gravity case of ROOT it prints, at each depth below the top contact plane (in d), the replicas'
mean inertial number I and stress ratio mu = |sigma_xz| / p of the coarse-grained fields (standard
errors from the replicas' scatter), the calibration's mu(I) at that I (``calibration/params.json``,
with its error from the fit's covariance), and their difference in units of its error.

Why: a model whose top-wall shear stress misses the DEM's misses it at every depth (sigma_xz is
uniform). If the band's own (I, mu) lie on mu(I), a local model misses the wall stress because its
band is elsewhere (the wall's kinematics); if they lie below it, the band flows at a lower stress
ratio than the rheometer's law at the same I, which no wall condition of a local model can give.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import xarray as xr


def mu_of_i(local: dict[str, float], inertial: float) -> float:
    return local["mu_s"] + (local["mu_2"] - local["mu_s"]) / (1.0 + local["I_0"] / inertial)


def mu_error(params: dict, inertial: float) -> float:
    """Error of mu(I) at I from the (mu_s, mu_2, I_0) covariance (linearised)."""
    local = {k: v["value"] for k, v in params["local"].items()}
    cov = params["covariance"]["mu_i"]
    names, matrix = cov["names"], np.asarray(cov["matrix"], dtype=float)
    grad = []
    for name in names:
        step = 1e-6 * max(abs(local[name]), 1e-6)
        up = dict(local, **{name: local[name] + step})
        grad.append((mu_of_i(up, inertial) - mu_of_i(local, inertial)) / step)
    g = np.asarray(grad)
    return float(math.sqrt(max(g @ matrix @ g, 0.0)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--depths", type=float, nargs="+", default=[1.0, 1.5, 2.0, 2.5, 3.0, 4.0])
    args = parser.parse_args(argv)
    params = json.loads((args.root / "calibration" / "params.json").read_text())
    local = {k: v["value"] for k, v in params["local"].items()}
    for folder in sorted((args.root / "fields").iterdir()):
        files = sorted(f for f in folder.glob("r*.nc") if f.stem[1:].isdigit())
        if not files:
            continue
        sets = [xr.open_dataset(f) for f in files]
        if float(sets[0].attrs.get("gravity", 0.0)) <= 0.0:
            continue
        print(f"{folder.name}: {len(sets)} replicas; depth below the top contact plane (d), DEM I and mu "
              "(replica mean +- standard error), mu(I) of the rheometer fit +- its error, (mu - mu(I)) / error")
        for depth in args.depths:
            rows = []
            for ds in sets:
                z, d = ds.z.values, float(ds.attrs["d"])
                at = float(ds.attrs["z_top_contact_plane"]) - depth * d
                rows.append((float(np.interp(at, z, ds["I"].values)), float(np.interp(at, z, ds["mu"].values))))
            arr = np.array(rows)
            mean = arr.mean(axis=0)
            sem = arr.std(axis=0, ddof=1) / math.sqrt(len(arr)) if len(arr) > 1 else np.full(2, math.nan)
            law, law_err = mu_of_i(local, mean[0]), mu_error(params, mean[0])
            err = math.hypot(sem[1], law_err)
            print(f"  {depth:4.1f}  I {mean[0]:.3g} +- {sem[0]:.2g}  mu {mean[1]:.3f} +- {sem[1]:.3f}  "
                  f"mu(I) {law:.3f} +- {law_err:.3f}  diff {mean[1] - law:+.3f} ({(mean[1] - law) / err:+.1f} errors)")
        for ds in sets:
            ds.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
