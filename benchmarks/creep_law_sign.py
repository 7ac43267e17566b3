"""Is the creep law's negative exponent real? Known answers, and the default under both window rules.

    python benchmarks/creep_law_sign.py coverage [--n 100] [--betas ...] [--beds ...] [--seed S] [--noise JSON] [--jackknife]
    python benchmarks/creep_law_sign.py default ROOT [--runs 'r*'] [--mu-s MU_S]

``coverage``: synthetic replica fields of the default's planar beds (config/config.yaml's geometry,
:mod:`pipeline.scoring.synthetic_creep` for the noise) with a known beta, pushed through
:mod:`pipeline.scoring.decay_length` under both window rules (``resolved``, the workflow's, and
``fixed_depth``); per true beta and rule: the recovered beta's mean, its bias and that bias's
standard error, the realisations' scatter against the stated error, and the share of the stated
68 % and 95 % intervals that cover the truth (binomial standard error beside each); with
``--jackknife`` also the leave-one-run-out error and its 95 % interval's coverage (Student's t, runs - 1 dof).

``default``: beta of an output root's planar DEM fields (``ROOT/fields/<case>/<runs>.nc``, mu_s
from ``ROOT/calibration/params.json`` unless given) under both rules: pooled over the cases, as
``validation/decay_length_fit.csv`` (all windows, and u / V < 0.01), and per case; with each fit's
stated error, the replicas' error scale, the model selection's delta AIC and, beside the stated
error, the leave-one-run-out jackknife error (which holds whatever the windows of a run share).

Measurements side by side, never asserted (the test is tests/pipeline/scoring/test_decay_length_synthetic.py).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pipeline.common.config import load_config  # noqa: E402
from pipeline.scoring import synthetic_creep as synthetic  # noqa: E402
from pipeline.scoring.decay_length import (BAND_EDGE, RULES, DecayLengthError, beta_interval, fit_windows,  # noqa: E402
                                           jackknife_error, scaled_windows, select_model)

CASES = ("shear_gravity", "shear_gravity_fast", "shear_gravity_heavy")


def beta_of(windows: pd.DataFrame, mu_s: float, d: float) -> dict[str, float]:
    """The law's fit on ``windows`` (the workflow's, :func:`fit_law`) with the model selection."""
    fit = fit_windows(windows, mu_s, d)
    return fit | {"delta_aic": select_model(windows, mu_s, d)["delta_aic"]}


def profile_summary(sets: list, mu_s: float, depths_over_d: tuple[float, ...] = (3, 5, 7, 9, 11, 13, 15, 17)) -> pd.DataFrame:
    """Per case and depth (d below the top contact plane): the replicas' median u / V, stated
    error / V and mu / mu_s, and the replicas' scatter of log10 u (decades; where every replica's u
    is positive): the realism of the synthetic noise read against the DEM's."""
    from pipeline.common.observables import creep_speed
    from pipeline.scoring.replicas import top_plane
    rows = []
    by_case: dict[str, list] = {}
    for ds in sets:
        by_case.setdefault(str(ds.attrs["case"]), []).append(ds)
    for case, group in by_case.items():
        for depth in depths_over_d:
            u, e, m = [], [], []
            for ds in group:
                speed, err, _ = creep_speed(ds)
                at = top_plane(ds) - depth * float(ds.attrs["d"])
                v = float(ds.attrs["wall_speed"])
                u.append(float(np.interp(at, ds.z.values, speed)) / v)
                e.append(float(np.interp(at, ds.z.values, err)) / v)
                m.append(float(np.interp(at, ds.z.values, ds["mu"].values)) / mu_s)
            u_arr = np.asarray(u)
            rows.append({"case": case, "depth_d": depth, "u/V": float(np.median(u_arr)), "err/V": float(np.median(e)),
                         "mu/mu_s": float(np.median(m)),
                         "replica_sd_log10u": float(np.std(np.log10(u_arr), ddof=1)) if np.all(u_arr > 0) else math.nan})
    return pd.DataFrame(rows)


def coverage(args: argparse.Namespace) -> int:
    config = load_config(args.config)
    scene = synthetic.beds_from_config(config, tuple(args.beds))
    scene.noise = synthetic.Noise(**json.loads(args.noise))
    d = scene.material.d
    print(f"synthetic beds {', '.join(f'{b.name} x{b.replicas}' for b in scene.beds)}; mu_s {args.mu_s}; noise {scene.noise}")
    print(f"{args.n} realisations per beta (seeds {args.seed}..{args.seed + args.n - 1}); fit over all windows below yield")
    header = (f"{'beta':>6} {'rule':>12} {'mean':>7} {'bias':>7} {'+-':>6} {'sd':>6} {'err':>6} {'sd/err':>6} "
              f"{'cov68':>6} {'cov95':>6} {'+-':>5} {'windows':>7} {'scale':>6}"
              + (f" {'jk_err':>6} {'jk95':>6}" if args.jackknife else ""))
    print(header)
    for beta in args.betas:
        law = synthetic.calibrated_law(beta, args.mu_s, scene)
        got: dict[str, list[tuple[float, float, float, int, float]]] = {rule: [] for rule in RULES}
        failed: dict[str, list[str]] = {rule: [] for rule in RULES}
        start = time.perf_counter()
        for k in range(args.n):
            sets = synthetic.replica_set(scene, law, np.random.default_rng(args.seed + k))
            for rule in RULES:
                windows, scale, _ = scaled_windows(sets, args.mu_s, rule)
                try:
                    fit = fit_windows(windows, args.mu_s, d)
                    jk = jackknife_error(windows, args.mu_s, d)[0] if args.jackknife else math.nan
                except (DecayLengthError, RuntimeError, ValueError, np.linalg.LinAlgError) as exc:
                    failed[rule].append(f"seed {args.seed + k}: {exc}")
                    continue
                got[rule].append((fit["beta"], fit["beta_err"], scale, len(windows), jk))
        # The jackknife's interval: Student's t with one fewer degree of freedom than runs.
        t95 = float(stats.t.ppf(0.975, sum(b.replicas for b in scene.beds) - 1))
        for rule, rows in got.items():
            a = np.asarray(rows)
            n = len(a)
            pull = (a[:, 0] - beta) / a[:, 1]
            c68, c95 = float(np.mean(np.abs(pull) < 1.0)), float(np.mean(np.abs(pull) < 1.959964))
            print(f"{beta:+6.2f} {rule:>12} {a[:, 0].mean():+7.3f} {a[:, 0].mean() - beta:+7.3f} "
                  f"{a[:, 0].std(ddof=1) / math.sqrt(n):6.3f} {a[:, 0].std(ddof=1):6.3f} {a[:, 1].mean():6.3f} "
                  f"{a[:, 0].std(ddof=1) / a[:, 1].mean():6.2f} {c68:6.2f} {c95:6.2f} "
                  f"{math.sqrt(0.95 * 0.05 / n):5.3f} {a[:, 3].mean():7.0f} {a[:, 2].mean():6.2f}"
                  + (f" {a[:, 4].mean():6.3f} {np.mean(np.abs(a[:, 0] - beta) < t95 * a[:, 4]):6.2f}"
                     if args.jackknife else ""))
        for rule, notes in failed.items():
            if notes:
                print(f"       {rule}: {len(notes)} fits failed ({notes[0]})")
        print(f"       ({time.perf_counter() - start:.0f} s)", flush=True)
    return 0


def default(args: argparse.Namespace) -> int:
    root = args.root
    params_path = root / "calibration" / "params.json"
    if args.mu_s is not None:
        mu_s, source = args.mu_s, "--mu-s"
    elif params_path.exists():
        mu_s, source = float(json.loads(params_path.read_text())["local"]["mu_s"]["value"]), str(params_path)
    else:
        print(f"{params_path}: not there (the calibration has not run); give --mu-s", file=sys.stderr)
        return 1
    files = [f for case in CASES for f in sorted((root / "fields" / case).glob(f"{args.runs}.nc"))]
    if not files:
        print(f"{root}/fields/<planar case>/{args.runs}.nc: no fields files", file=sys.stderr)
        return 1
    with xr.open_dataset(files[0]) as ds:
        d = float(ds.attrs["d"])
    print(f"{len(files)} fields files under {root}/fields ({', '.join(f'{f.parent.name}/{f.stem}' for f in files)})")
    print(f"mu_s {mu_s:.4f} ({source})")
    rows = []
    for rule in RULES:
        windows, scale, pairs = scaled_windows([(f, "calibration" if f.parent.name == CASES[0] else "held_out")
                                                for f in files], mu_s, rule)
        subsets = [("pooled, all windows", windows), (f"pooled, u/V < {BAND_EDGE:g}", windows[windows.u_over_V < BAND_EDGE])]
        subsets += [(case, windows[windows.case == case]) for case in CASES if (windows.case == case).any()]
        for name, sub in subsets:
            row = {"rule": rule, "windows": name, "n": int((sub.mu < mu_s).sum()), "scale": scale, "pairs": pairs}
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    fit = beta_of(sub, mu_s, d)
                    interval = beta_interval(sub, fit, mu_s, d)
                    row |= {"beta": fit["beta"], "beta_err": fit["beta_err"], "jackknife_err": interval["beta_err_jackknife"],
                            "runs": interval["beta_dof"] + 1,
                            "ci95": f"{fit['beta'] - interval['beta_half_width']:+.2f} to {fit['beta'] + interval['beta_half_width']:+.2f}",
                            "chi2_red": fit["chi2_reduced"], "delta_aic": fit["delta_aic"],
                            "mu/mu_s": f"{fit['mu_over_mu_s_min']:.2f}-{fit['mu_over_mu_s_max']:.2f}"}
            except (DecayLengthError, RuntimeError) as exc:
                row["note"] = str(exc)
            rows.append(row)
    with pd.option_context("display.width", 200, "display.max_columns", 20, "display.float_format", "{:.3f}".format):
        print(pd.DataFrame(rows).to_string(index=False))
    # The same summary of the DEM and of synthetic replicas at the DEM's beta (resolved rule, pooled):
    # how close the synthetic noise is to the DEM's.
    dem_sets = [xr.open_dataset(f) for f in files]
    summary = profile_summary(dem_sets, mu_s)
    beta_dem = next((r["beta"] for r in rows if r["rule"] == "resolved" and r["windows"] == "pooled, all windows"
                     and "beta" in r), 0.0)
    scene = synthetic.beds_from_config(load_config(args.config), tuple(c for c in CASES if (summary.case == c).any()))
    law = synthetic.calibrated_law(beta_dem, mu_s, scene)
    syn = profile_summary([ds for ds, _ in synthetic.replica_set(scene, law, np.random.default_rng(1))], mu_s)
    both = summary.merge(syn, on=["case", "depth_d"], suffixes=("", " syn"))
    print(f"\nDEM against synthetic replicas at beta = {beta_dem:+.3f} (medians over replicas):")
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(both.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    for ds in dem_sets:
        ds.close()
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    cov = sub.add_parser("coverage", help="the recovered beta against known answers, both rules")
    cov.add_argument("--config", default="config/config.yaml", help="the geometry's config (default: the default's)")
    cov.add_argument("--n", type=int, default=100, help="realisations per beta")
    cov.add_argument("--betas", type=float, nargs="+", default=[-0.5, -0.16, 0.0, 0.5, 1.0])
    cov.add_argument("--beds", nargs="+", default=list(CASES))
    cov.add_argument("--mu-s", type=float, default=0.378, help="the synthetic mu_s (the default's calibration: 0.37-0.38)")
    cov.add_argument("--seed", type=int, default=1000, help="first realisation's seed")
    cov.add_argument("--jackknife", action="store_true",
                     help="also the leave-one-run-out jackknife error and its 95 %% interval's coverage")
    cov.add_argument("--noise", default="{}", help='changes to the noise, JSON (e.g. \'{"ageing_exponent": 0}\')')
    dft = sub.add_parser("default", help="beta of an output root's planar fields under both rules")
    dft.add_argument("root", type=Path)
    dft.add_argument("--runs", default="r*", help="glob of the run ids (size-study runs: 'L16-r*')")
    dft.add_argument("--mu-s", type=float, default=None)
    dft.add_argument("--config", default="config/config.yaml", help="the geometry of the synthetic comparison")
    args = parser.parse_args(argv)
    return coverage(args) if args.command == "coverage" else default(args)


if __name__ == "__main__":
    raise SystemExit(main())
