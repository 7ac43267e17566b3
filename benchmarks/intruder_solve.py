"""Benchmark: the intruder's 2D solves, per model. Prints, side by side (never asserted):

1. per model and scene of the default (depths 5, 7, 9 d at half the 5 d yield force; 0.3, 0.6,
   0.9 of the yield force at 7 d): U, u_input (standard deviation of log10 U over the draws),
   converged, map evaluations and CPU seconds of the nominal (cold) solve;
2. per model: evaluations and CPU seconds per solve, cold and warm (a draw started from the
   nominal solution), medians over the draws solved both ways;
3. the slope of log10 U against F / F_y over the force sweep beside the DEM's 3.7 +- 0.5 (issue
   43), excluded when |s - 3.7| > 1.96 sqrt(0.5^2 + u_input^2 + u_num^2);
4. grid convergence of U at 3, 4, 6 cells per d at 7 d, two pushes;
5. the model stage's CPU seconds as the pipeline runs it (nominal + draws warm + the grid study
   at 4 cells per d), and that over two cores.

The scene is the default's (config/config.yaml): bed 21.6 d between the contact planes, cell
12 d, rod 3 d with its axis (k - 0.5) d under the top contact plane for k d under the wall grains'
centres, P_wall 200 Pa, V 0.1 m/s, sigma_zz / p = 1.058, pushes from F_y = 1.5 p D (p
hydrostatic with nu 0.6, pipeline/dem/intruder_run.py). Parameters: the default run's
calibration (docs/validation.md: mu_s 0.374 +- 0.0028, mu_2 1.023 +- 0.045, I_0 0.637 +- 0.075,
nu_c 0.587, NGF A 0.327 +- 0.055); draws independent normal with those errors, seed 43.

Run: ``nice -n 5 python benchmarks/intruder_solve.py [--draws 8] [--cold-draws 2] [--models ngf ngf_frozen
local_mu_i critical_state volume_averaged cosserat] [--draws-cells 3] [--no-grid] [--grid-warm] [--grid-pushes 0.3 0.6] [--grid-only]``
(the yield-stress models' draws vary mu_s, and mu_2, I_0 for mu(I), l = 1.165 +- 0.06 d for the volume-averaged
model, l = 1.944 +- 0.009 d for Cosserat). CPU seconds (time.process_time) are reported, the machine being shared.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import continuum  # noqa: E402
from continuum.intruder import INTRUDER_MODELS, GridOptions, RodIntruder, intruder_speed  # noqa: E402
from continuum.parameters import (CosseratParameters, CriticalStateLine, CriticalStateParameters, LocalMuIParameters,  # noqa: E402
                                  MuIParameters, NGFParameters, SolidFractionLaw, VolumeAveragedParameters)

D = 0.002
GEO = continuum.PlanarShear(depth=21.6 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                            normal_stress_ratio=1.058)
LX = 12 * D
#: l_cosserat: the 2026-12-05 default run's fit, 1.944 +- 0.009 d (calibration/params.json).
NOMINAL = {"mu_s": 0.374, "mu_2": 1.023, "I_0": 0.637, "A": 0.327, "l": 1.165 * D, "l_cosserat": 1.944 * D}
ERRORS = {"mu_s": 0.0028, "mu_2": 0.045, "I_0": 0.075, "A": 0.055, "l": 0.06 * D, "l_cosserat": 0.009 * D}
DEM_SLOPE, DEM_SLOPE_ERR = 3.7, 0.5


def yield_force(depth_d: float) -> float:
    return 1.5 * (200.0 + 0.6 * 2500.0 * 9.81 * depth_d * D) * 3 * D


SCENES = [(5.0, 0.5 * yield_force(5)), (7.0, 0.5 * yield_force(5)), (9.0, 0.5 * yield_force(5)),
          (7.0, 0.3 * yield_force(7)), (7.0, 0.6 * yield_force(7)), (7.0, 0.9 * yield_force(7))]


def parameters(model: str, v: dict[str, float]):
    mu_i = MuIParameters(v["mu_s"], v["mu_2"], v["I_0"])
    critical = CriticalStateParameters(v["mu_s"], CriticalStateLine(0.5868, 0.005, 300.0))
    if model in ("ngf", "ngf_frozen"):
        return NGFParameters(mu_i, A=v["A"], nu=0.587)
    if model == "local_mu_i":
        return LocalMuIParameters(mu_i, SolidFractionLaw(0.5868, 0.141))
    if model == "critical_state":
        return critical
    if model == "volume_averaged":
        return VolumeAveragedParameters(critical, v["l"])
    if model == "cosserat":
        return CosseratParameters(critical, v["l_cosserat"], beta=1.0, wall_spin_ratio=0.5)
    raise KeyError(f"benchmark has no parameters for {model!r} yet")


def rod(depth: float, force: float) -> RodIntruder:
    return RodIntruder.below_top(GEO, 3 * D, (depth - 0.5) * D, force)


def timed(model: str, values: dict[str, float], scene: tuple[float, float], cells: float, warm=None):
    t0 = time.process_time()
    try:
        res = intruder_speed(model, GEO, parameters(model, values), rod(*scene), LX, GridOptions(cells_per_d=cells), warm=warm)
    except continuum.ContinuumError as exc:
        return None, time.process_time() - t0, str(exc)[:300]
    return res, time.process_time() - t0, ""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", nargs="+", default=["ngf", "ngf_frozen"])
    ap.add_argument("--draws", type=int, default=8, help="draws solved warm per scene")
    ap.add_argument("--cold-draws", type=int, default=2, help="of those, also solved cold")
    ap.add_argument("--pipeline-draws", type=int, default=32, help="draws the pipeline solves (models.intruder_draws)")
    ap.add_argument("--draws-cells", type=float, default=3.0,
                    help="grid of the draws (cells per d); the nominal solve they start from is re-solved there")
    ap.add_argument("--no-grid", action="store_true")
    ap.add_argument("--grid-warm", action="store_true",
                    help="start the 4 and 6 cells/d solves from the 3 cells/d one carried onto them (the pipeline's "
                         "grid study does, for the solvers that can: continuum/intruder/regrid.py)")
    ap.add_argument("--grid-pushes", nargs="+", type=float, default=[0.3, 0.6])
    ap.add_argument("--grid-only", action="store_true", help="only section 4 (the grid convergence)")
    args = ap.parse_args()
    rng = np.random.default_rng(43)
    draws = [{k: NOMINAL[k] + ERRORS[k] * rng.standard_normal() for k in NOMINAL if k != "l_cosserat"}
             for _ in range(args.draws)]
    # Cosserat's l from a stream of its own, so the other models' draws stay those recorded before it
    rng_cosserat = np.random.default_rng(44)
    for draw in draws:
        draw["l_cosserat"] = NOMINAL["l_cosserat"] + ERRORS["l_cosserat"] * rng_cosserat.standard_normal()
    print("scene: depth / d, F / F_y(depth); U in m/s; cpu_s = CPU seconds; it = fixed-point map evaluations")
    print(f"{'model':<12} {'depth':>5} {'F/F_y':>6} {'U':>10} {'u_input':>8} {'conv':>4} {'it':>4} {'cpu_s':>6}"
          f" {'warm_it':>7} {'warm_s':>6} {'cold_it':>7} {'cold_s':>6}")
    stage: dict[str, float] = {}
    for model in [] if args.grid_only else args.models:
        solver_model = INTRUDER_MODELS[model].solver is not None
        cold_it, cold_s, warm_it, warm_s = [], [], [], []
        sweep: dict[float, tuple[float, float]] = {}
        nominal_s = 0.0
        for scene in SCENES:
            res, sec, err = timed(model, NOMINAL, scene, 3.0)
            nominal_s += sec
            push = scene[1] / yield_force(scene[0])
            if res is None:
                print(f"{model:<12} {scene[0]:>5g} {push:>6.2f} failed: {err}")
                continue
            speeds, w_it, w_s, c_it, c_s = [], [], [], [], []
            start = res
            if args.draws_cells != 3.0:
                start, sec_d, _ = timed(model, NOMINAL, scene, args.draws_cells)
                nominal_s += sec_d
            for k, values in enumerate(draws):
                w, s, _ = timed(model, values, scene, args.draws_cells, warm=start if solver_model else None)
                if w is not None:
                    speeds.append(w.speed)
                    w_it.append(w.iterations)
                    w_s.append(s)
                if solver_model and k < args.cold_draws:
                    c, s, _ = timed(model, values, scene, args.draws_cells)
                    if c is not None:
                        c_it.append(c.iterations)
                        c_s.append(s)
            logs = np.log10([u for u in speeds if u > 0]) if speeds else np.array([])
            u_in = float(np.std(logs, ddof=1)) if logs.size > 1 else math.nan
            if scene[0] == 7.0:
                sweep[push] = (res.speed, u_in)
            cold_it += c_it
            cold_s += c_s
            warm_it += w_it
            warm_s += w_s
            med = lambda v: statistics.median(v) if v else math.nan  # noqa: E731
            print(f"{model:<12} {scene[0]:>5g} {push:>6.2f} {res.speed:>10.3e} {u_in:>8.3f} {int(res.converged):>4} "
                  f"{res.iterations:>4} {sec:>6.2f} {med(w_it):>7.0f} {med(w_s):>6.2f} {med(c_it):>7.0f} {med(c_s):>6.2f}")
        pushes = np.array(sorted(p for p in sweep if p in (0.3, 0.6, 0.9) or abs(p - round(p, 1)) < 1e-9))
        if pushes.size >= 2:
            logs = np.log10([sweep[p][0] for p in pushes])
            s = float(np.polyfit(pushes, logs, 1)[0])
            u_in = float(np.nanmean([sweep[p][1] for p in pushes])) * math.sqrt(2.0) / float(np.ptp(pushes))
            u = math.sqrt(DEM_SLOPE_ERR**2 + (u_in if math.isfinite(u_in) else 0.0) ** 2)
            verdict = "excluded" if abs(s - DEM_SLOPE) > 1.96 * u else "not excluded"
            print(f"  {model}: slope d log10 U / d(F/F_y) over {list(pushes.round(2))} = {s:.2f} (u_input ~{u_in:.2f}) "
                  f"against DEM {DEM_SLOPE} +- {DEM_SLOPE_ERR}: {verdict} (|diff| {abs(s - DEM_SLOPE):.2f} vs 1.96 u = {1.96 * u:.2f})")
        med = lambda v: statistics.median(v) if v else math.nan  # noqa: E731
        per_warm = med(warm_s)
        stage[model] = nominal_s + len(SCENES) * args.pipeline_draws * (per_warm if math.isfinite(per_warm) else 0.0)
        print(f"  {model}: per solve cold {med(cold_it):.0f} it / {med(cold_s):.2f} cpu s, warm {med(warm_it):.0f} it / "
              f"{per_warm:.2f} cpu s (medians over {len(cold_s)} cold, {len(warm_s)} warm draws)")
    if not args.no_grid:
        print("grid convergence (nominal parameters, 7 d):")
        for model in args.models:
            for push in args.grid_pushes:
                scene = (7.0, push * yield_force(7))
                row = []
                coarse = None
                for cells in (3.0, 4.0, 6.0):
                    res, sec, err = timed(model, NOMINAL, scene, cells, warm=coarse if args.grid_warm else None)
                    if cells == 3.0:
                        coarse = res
                    print(f"    ({model} F/F_y {push} {cells:g}/d: {res.speed if res else err} in {sec:.1f} cpu s)", flush=True)
                    row.append((cells, res.speed if res else math.nan, res.iterations if res else -1, sec))
                    if cells == 4.0 and model in stage:
                        stage[model] += sec * len(SCENES) / 2.0  # the grid study: every scene at 4 cells/d
                u6 = row[-1][1]
                print(f"  {model:<12} F/F_y {push}: " + "; ".join(
                    f"{c:g}/d U {u:.4e} (" + (f"{(u / u6 - 1) * 100:+.2f} % of 6/d, " if u6 else "")  # a rod at rest has no ratio
                    + f"{it} it, {s:.1f} cpu s)" for c, u, it, s in row))
    for model, sec in stage.items():
        print(f"stage estimate {model}: {sec:.0f} cpu s ({sec / 2:.0f} s on 2 cores if split evenly), "
              f"{len(SCENES)} scenes x (1 + {args.pipeline_draws} draws) + grid study")


if __name__ == "__main__":
    main()
