"""Benchmark: the price of the intruder scene. For each model, the time of its intruder
prediction (2D solve for NGF) and grid size, next to the 1D planar solve time (continuum.solve)
for the same geometry. Run as ``python benchmarks/intruder_solve.py``.

Development parameters: d = 2 mm, rho_s = 2500 kg m-3, depth 20 d, L_x = 16 d, P_wall = 200 Pa,
V = 0.1 m/s; glass beads mu_s 0.3819, mu_2 0.6435, I_0 0.279, A 0.48, nu 0.6; critical-state
line nu_cs = 0.6 + 0.01 ln(p / 500 Pa), l = 1 d. Rod D = 3 d at 7 d below the top, F = 0.5 N/m.
"""
from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import continuum  # noqa: E402
from continuum.intruder import GridOptions, RodIntruder, intruder_speed  # noqa: E402
from continuum.parameters import (  # noqa: E402
    CriticalStateLine, CriticalStateParameters, LocalMuIParameters, MuIParameters, NGFParameters,
    SolidFractionLaw, VolumeAveragedParameters,
)

D = 0.002
GEO = continuum.PlanarShear(depth=20 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0)
MU_I = MuIParameters(0.3819, 0.6435, 0.279)
CS = CriticalStateParameters(0.3819, CriticalStateLine(0.6, 0.01, 500.0))
PARAMS = {"ngf": NGFParameters(MU_I, A=0.48, nu=0.6),
          "local_mu_i": LocalMuIParameters(MU_I, SolidFractionLaw(0.6, 0.3)),
          "critical_state": CS, "volume_averaged": VolumeAveragedParameters(CS, l=D)}


def median_time(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    rod = RodIntruder.below_top(GEO, 3 * D, 7 * D, 0.5)
    print(f"{'model':<16} {'method':<12} {'grid':>10} {'scene_s':>9} {'1d_s':>8} {'ratio':>7} {'U_m_s':>10}")
    runs = [("ngf", "frozen", 4), ("ngf", "frozen", 6), ("ngf", "coupled", 4),
            ("local_mu_i", None, None), ("critical_state", None, None), ("volume_averaged", None, None)]
    for model, coupling, cpd in runs:
        grid = GridOptions(cells_per_d=cpd or 4)
        kwargs = {"coupling": coupling} if coupling else {}
        try:
            res = intruder_speed(model, GEO, PARAMS[model], rod, 16 * D, grid, **kwargs)
        except continuum.ContinuumError as exc:
            print(f"{model:<16} {'2d/' + str(coupling):<12} failed: {exc}")
            continue
        t_scene = res.solve_seconds if coupling == "coupled" else median_time(
            lambda: intruder_speed(model, GEO, PARAMS[model], rod, 16 * D, grid, **kwargs))
        t_1d = median_time(lambda: continuum.solve(model, GEO, PARAMS[model]), 5)
        size = (f"{res.attrs['nx']}x{res.attrs['nz']}" if "nx" in res.attrs
                else f"{res.n_grid} (1D)" if res.n_grid else "-")
        label = f"{res.method}/{coupling}" if coupling else res.method
        print(f"{model:<16} {label:<12} {size:>10} {t_scene:>9.3f} {t_1d:>8.4f} {t_scene / t_1d:>7.0f} {res.speed:>10.3e}"
              + (f"  ({res.iterations} Picard iterations)" if coupling == "coupled" else ""))


if __name__ == "__main__":
    main()
