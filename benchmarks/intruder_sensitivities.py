"""Benchmark (issue 57, item 1): the 2D plastic models' u_input from their speed's parameter
sensitivities against the root's solved parameter draws.

Run as ``python benchmarks/intruder_sensitivities.py ROOT --out OUT [--models ...]``. For each
2D plastic model of ROOT's intruder case, ``python -m pipeline.models intruder-sensitivities``
runs on ROOT's nominal states and ensemble (``calibration/draws.json``, every draw), its part is
merged with ROOT's grid study, and then:

1. **draw by draw**: on the draws ROOT solved (its ``model_draws/intruder/{model}.nc``), each
   propagated speed against the solved one: the largest and median |ln(U / U_solved)| over draws
   and scenes, for the form the pipeline uses (first order in ln U) and plain linear, beside the
   draws' own spread (std of ln U_solved) they are to be small against, and the check solves'
   own errors (``check_dln_linear``);
2. **every score's u_input** by the workflow's intruder scoring: (a) the propagated speeds of the
   same draws ROOT solved (the propagation's error alone, no sampling difference), (b) of the
   first ``--first`` draws (against a reference of that many solved draws, where one was made) and
   (c) of every draw of the ensemble (what the pipeline reports), against ROOT's solved draws, with
   z = (u - u_ref) / hypot(e_ref, e), e = u / sqrt(2 (n - 1)) the sampling error of n draws;
3. **cost**: the sensitivities' wall and CPU seconds against the solved draws' (``draws_seconds``
   of ROOT's file, and its draws jobs' benchmark files).
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from draws_sampler import _intruder_u_input as u_inputs  # noqa: E402  (the workflow's intruder scoring of a root)

PLASTIC = ("local_mu_i", "critical_state", "cosserat", "volume_averaged")


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_model(root: Path, out: Path, model: str) -> tuple[Path, float, float]:
    """The sensitivities part and the merged file of ``model``; the part's wall and CPU seconds."""
    runs = sorted((root / "dem" / "intruder").glob("D*/run.json"))
    runs = [r for r in runs if "control" not in r.parent.name]
    fields = [root / "fields" / "intruder" / f"{r.parent.name}.nc" for r in runs]
    part = out / "parts" / model / "sensitivities.nc"
    merged = out / "model_draws" / "intruder" / f"{model}.nc"
    part.parent.mkdir(parents=True, exist_ok=True)
    merged.parent.mkdir(parents=True, exist_ok=True)
    common = ["--config", str(root / "config.effective.json"), "--params", str(root / "calibration" / "params.json"),
              "--model", model, "--runs", *map(str, runs), "--fields", *map(str, fields),
              "--states", str(root / "models" / "intruder" / f"{model}.states.npz")]
    cpu0, t0 = _children_cpu(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "pipeline.models", "intruder-sensitivities", *common,
                    "--draws", str(root / "calibration" / "draws.json"), "--out", str(part)], check=True)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu0
    refined = root / "model_draws" / "intruder" / "parts" / model / "refined.nc"
    subprocess.run([sys.executable, "-m", "pipeline.models", "intruder-draws", "merge", *common,
                    "--draws", str(root / "calibration" / "draws.json"), "--parts", str(part), str(refined),
                    "--out", str(merged)], check=True, stdout=subprocess.DEVNULL)
    return merged, wall, cpu


def draw_by_draw(solved: xr.Dataset, part: xr.Dataset) -> dict:
    """Item 1 of the module docstring, on the draws both files hold: the largest and median
    |ln(U / U_solved)| of the propagated form (U_0 exp(s)) and of plain linear (U_0 (1 + s)),
    beside the draws' own spread (std of ln U) and the check solves' own errors."""
    common = np.intersect1d(solved.draw.values, part.draw.values)
    u_solved = solved.speed.sel(draw=common).values
    s = part.log_offset.sel(draw=common).values
    u0 = part.speed_nominal.values[None, :]
    forms = {"propagated": part.speed.sel(draw=common).values, "linear": u0 * (1.0 + s)}
    moving = np.isfinite(u_solved) & (u_solved != 0.0)
    out: dict = {"draws": len(common), "moving": int(moving.sum()),
                 "zero_both": int(((u_solved == 0.0) & (forms["propagated"] == 0.0)).sum())}
    if moving.any():
        for name, u in forms.items():
            with np.errstate(divide="ignore", invalid="ignore"):
                err = np.abs(np.log(u[moving] / u_solved[moving]))
            out[f"max_dln_{name}"] = float(np.max(np.where(np.isfinite(err), err, np.inf)))
            out[f"median_dln_{name}"] = float(np.median(err))
        out["spread_ln_median"] = float(np.nanmedian(np.nanstd(np.log(np.where(u_solved > 0, u_solved, np.nan)),
                                                               axis=0, ddof=1)))
        out["check_draws"] = [int(v) for v in part.check_draw.values]
        out["check_dln_linear_max"] = float(np.nanmax(np.abs(part.check_dln_linear.values)))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--models", nargs="+", default=list(PLASTIC))
    parser.add_argument("--first", type=int, default=32,
                        help="also the u_input of the first N propagated draws (against a reference of N solved draws)")
    args = parser.parse_args(argv)
    root = args.root
    ref_files = {m: root / "model_draws" / "intruder" / f"{m}.nc" for m in args.models}
    lin_files, same_files, first_files, cost = {}, {}, {}, {}
    print("draw by draw (the draws ROOT solved; dln = |ln(U / U_solved)|):")
    for model in args.models:
        merged, wall, cpu = run_model(root, args.out, model)
        lin_files[model] = merged
        solved = xr.open_dataset(ref_files[model]).load()
        part = xr.open_dataset(args.out / "parts" / model / "sensitivities.nc").load()
        # the same draws ROOT solved, as a file of their own (item 2a)
        same = xr.open_dataset(merged).load()
        same = same.sel(draw=np.intersect1d(same.draw.values, solved.draw.values))
        same.attrs["n_draws"] = int(same.sizes["draw"])
        same_files[model] = args.out / "same_draws" / f"{model}.nc"
        same_files[model].parent.mkdir(parents=True, exist_ok=True)
        same.to_netcdf(same_files[model])
        first = xr.open_dataset(merged).load()
        first = first.sel(draw=first.draw.values[first.draw.values < args.first])
        first.attrs["n_draws"] = int(first.sizes["draw"])
        first_files[model] = args.out / f"first{args.first}" / f"{model}.nc"
        first_files[model].parent.mkdir(parents=True, exist_ok=True)
        first.to_netcdf(first_files[model])
        check = draw_by_draw(solved, part)
        ref_seconds = float(solved.attrs["draws_seconds"])
        bench = sorted((root / "benchmarks" / "model_draws" / "intruder" / model).glob("draws-*.tsv"))
        ref_wall = sum(float(pd.read_csv(p, sep="\t")["s"].iloc[0]) for p in bench)
        cost[model] = (ref_wall, ref_seconds, wall, cpu, float(part.attrs["draws_seconds"]))
        print(f"  {model}: {json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in check.items()})}; "
              f"parameters {list(part.parameter.values)}; rigid nominal scenes {int(part.rigid_nominal.sum())} of {part.sizes['run']}")
    ref = u_inputs(root, ref_files)
    same_u = u_inputs(root, same_files)
    lin = u_inputs(root, lin_files)
    first_u = u_inputs(root, first_files)
    table = pd.DataFrame({"u_ref": ref, "u_same_draws": same_u, f"u_first{args.first}": first_u,
                          "u_linearised": lin}).dropna()
    table = table[table.index.get_level_values("model").isin(args.models)]
    n_ref = {m: int(xr.open_dataset(p).attrs["n_draws"]) for m, p in ref_files.items()}
    n_lin = {m: int(xr.open_dataset(p).attrs["n_draws"]) for m, p in lin_files.items()}
    models = table.index.get_level_values("model")
    e_ref = table["u_ref"] / np.sqrt(2 * (np.array([n_ref[m] for m in models]) - 1))
    e_lin = table["u_linearised"] / np.sqrt(2 * (np.array([n_lin[m] for m in models]) - 1))
    table["ratio_same"] = table["u_same_draws"] / table["u_ref"]
    table["ratio"] = table["u_linearised"] / table["u_ref"]
    table["z"] = (table["u_linearised"] - table["u_ref"]) / np.hypot(e_ref, e_lin)
    pd.set_option("display.width", 200)
    print("\nu_input per score (ROOT's solved draws; the linearised same draws; the linearised ensemble):")
    print(table.round(4).to_string())
    moving = table[table["u_ref"] > 1e-12]
    if len(moving):
        print(f"\n{len(moving)} scores with u_input > 0: same draws ratio {moving['ratio_same'].min():.3f}-"
              f"{moving['ratio_same'].max():.3f}; ensemble ratio {moving['ratio'].min():.3f}-{moving['ratio'].max():.3f}, "
              f"largest |z| {moving['z'].abs().max():.2f}; {len(table) - len(moving)} scores at u_input 0 in both "
              f"({int((table['u_linearised'][table['u_ref'] <= 1e-12] > 1e-12).sum())} not 0 linearised)")
    print("\ncost: solved draws (benchmark wall s of the jobs; draws_seconds) against the sensitivities (wall s; CPU s; in-process s):")
    for m, (rw, rs, w, c, s) in cost.items():
        print(f"  {m}: {n_ref[m]} draws {rw:.1f} s ({rs:.1f} s in process); sensitivities for {n_lin[m]} draws "
              f"{w:.1f} s wall, {c:.1f} CPU s ({s:.1f} s in process): x {rw / w:.0f}")
    total_ref = sum(v[0] for v in cost.values())
    total_new = sum(v[2] for v in cost.values())
    print(f"  all: {total_ref:.0f} s -> {total_new:.0f} s (x {total_ref / total_new:.0f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
