"""Benchmark: each continuum model's planar solve time at the grid converged to 1 %.

Run as ``python benchmarks/continuum_solve.py``. Geometry: the shear_gravity benchmark of the
Henann group (depth 20 d, top pressure 6.67 nu rho_s g d, wall speed 1e-3 sqrt(g d)) with
d = 4 mm, rho_s = 2500 kg m-3, nu = 0.6; glass-bead parameters mu_s = 0.3819, mu_2 = 0.6435,
I_0 = 0.279, A = 0.48, nu(I) = 0.6 - 0.3 I; critical-state line nu_cs(p) = 0.6 + 0.01 ln(p / 500 Pa),
sin_phi = mu_s; l = 1 d for the Cosserat and volume-averaged models. These are benchmark
defaults only: the pipeline passes calibrated values.

"Converged to 1 %": the grid is doubled (n - 1 intervals -> 2 (n - 1)) until the velocity at every
node of the coarser grid agrees with the finer solution to 1 % (relative, with speeds below
1e-6 V compared in absolute terms against 1e-6 V) and tau to 1 %. The printed time is the median
of repeated solves at the coarser grid of that pair.
"""
from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import continuum  # noqa: E402
from continuum.parameters import (  # noqa: E402
    CosseratParameters,
    CriticalStateLine,
    CriticalStateParameters,
    LocalMuIParameters,
    MuIParameters,
    NGFParameters,
    SolidFractionLaw,
    VolumeAveragedParameters,
)

D, RHO_S, G = 0.004, 2500.0, 9.81
GEOMETRY = continuum.PlanarShear(depth=20 * D, wall_speed=1e-3 * np.sqrt(G * D),
                                 wall_pressure=6.67 * 0.6 * RHO_S * G * D, gravity=G, d=D, rho_s=RHO_S)
MU_I = MuIParameters(0.3819, 0.6435, 0.279)
CS = CriticalStateParameters(0.3819, CriticalStateLine(0.6, 0.01, 500.0))
PARAMS = {
    "local_mu_i": LocalMuIParameters(MU_I, SolidFractionLaw(0.6, 0.3)),
    "critical_state": CS,
    "cosserat": CosseratParameters(CS, l=1.0 * D),
    "ngf": NGFParameters(MU_I, A=0.48, nu=0.6),
    "volume_averaged": VolumeAveragedParameters(CS, l=1.0 * D),
}


def difference(coarse, fine) -> float:
    """Largest relative velocity difference at the coarse nodes, and the tau difference."""
    V = GEOMETRY.wall_speed
    u_c = coarse.u_x.values
    u_f = np.interp(coarse.z.values, fine.z.values, fine.u_x.values)
    floor = 1e-6 * V
    du = np.max(np.abs(u_c - u_f) / np.maximum(np.abs(u_f), floor))
    dtau = abs(coarse.attrs["tau"] / fine.attrs["tau"] - 1.0)
    return float(max(du, dtau))


def converged_grid(model: str, n_start: int = 17, n_max: int = 20000) -> tuple[int, float]:
    n = n_start
    coarse = continuum.solve(model, GEOMETRY, PARAMS[model], n_grid=n)
    while True:
        n_fine = 2 * (n - 1) + 1
        if n_fine > n_max:
            raise RuntimeError(f"{model}: not converged to 1 % below {n_max} nodes")
        fine = continuum.solve(model, GEOMETRY, PARAMS[model], n_grid=n_fine)
        diff = difference(coarse, fine)
        if diff <= 0.01:
            return n, diff
        n, coarse = n_fine, fine


def main() -> None:
    print(f"shear_gravity: depth {GEOMETRY.depth:.3g} m = 20 d, V = {GEOMETRY.wall_speed:.3g} m/s, "
          f"P_wall = {GEOMETRY.wall_pressure:.4g} Pa")
    print(f"{'model':<16} {'n_grid':>7} {'diff_vs_2x':>11} {'solve_ms':>9} {'tau_Pa':>9}  goal <= 50 ms")
    for model in continuum.MODEL_NAMES:
        n, diff = converged_grid(model)
        times = []
        for _ in range(7):
            t0 = time.perf_counter()
            ds = continuum.solve(model, GEOMETRY, PARAMS[model], n_grid=n)
            times.append(time.perf_counter() - t0)
        ms = 1e3 * statistics.median(times)
        flag = "ok" if ms <= 50.0 else "SLOW"
        print(f"{model:<16} {n:>7d} {diff:>11.2e} {ms:>9.2f} {ds.attrs['tau']:>9.3f}  {flag}")


if __name__ == "__main__":
    main()
