"""Benchmark (issue 57, item 1): u_input from fewer, quasi-random parameter draws.

Run as ``python benchmarks/draws_sampler.py ROOT REFERENCE --out OUT [--draws 16] [--scrambles 4]``.
REFERENCE is a root of ROOT's DEM scored with today's draws (``calibration.draws`` pseudo-random, 64
by default; e.g. ``benchmarks/wall_before_after.py``'s ``rheometer`` root). For each of
``--scrambles`` Sobol scrambles (the config's seed + k) the planar post-DEM stages run again with
``calibration.draws`` = ``--draws`` and ``calibration.draw_sampler: sobol``
(:mod:`pipeline.calibration.samplers`), and every planar score's ``u_input`` is set against the
reference's: the ratio per score, and whether the scrambles' mean lies within the two estimates'
sampling errors (the reference's: u / sqrt(2 (n - 1)) for n random draws; the Sobol estimate's: the
scrambles' standard error). Prints the table and the planar model stage's CPU seconds of both.

With ``--intruder`` the same for the intruder's scores, on the scramble roots the planar run made:
each intruder model's draws are solved again from each scramble's ``calibration/draws.json`` (the
first ``--intruder-draws`` of its Sobol points for NGF, ``--intruder-plastic-draws`` for the 2D
plastic solvers), warm-started from ROOT's nominal states as the workflow does, merged with ROOT's
grid study (which does not depend on the draws), and scored by the workflow's intruder scoring
beside ROOT's own draws (``model_draws/intruder``). The reference's sampling error is per model,
u / sqrt(2 (n - 1)) with its own number of draws. Prints the table and the draws' seconds of both.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from wall_before_after import one_law  # noqa: E402


def model_seconds(root: Path) -> float:
    """CPU seconds the planar model solves took (nominal + draws + refined), from the draws files."""
    import xarray as xr

    total = 0.0
    for path in sorted((root / "model_draws").glob("*/*.nc")):
        if path.parent.name == "intruder":  # the --intruder mode's draws (their seconds are its own line)
            continue
        with xr.open_dataset(path) as ds:
            total += float(np.nansum(ds["solve_seconds"].values))
    return total


def compare(table: pd.DataFrame, cols: list[str], n_ref: float | pd.Series) -> pd.DataFrame:
    """``table`` (``u_input_ref`` and one column of u_input per scramble, ``cols``) with the
    scrambles' mean and standard error, the reference's sampling error for ``n_ref`` random draws,
    their ratio and z; rows whose reference u_input is at round-off are dropped (a score the draws
    cannot move, e.g. critical state's band, says nothing)."""
    table = table.copy()
    table["sobol_mean"] = table[cols].mean(axis=1)
    table["sobol_sem"] = table[cols].std(axis=1, ddof=1) / math.sqrt(len(cols)) if len(cols) > 1 else np.nan
    table["ref_err"] = table["u_input_ref"] / np.sqrt(2 * (n_ref - 1))
    table["ratio"] = table["sobol_mean"] / table["u_input_ref"]
    table["z"] = (table["sobol_mean"] - table["u_input_ref"]) / np.hypot(table["ref_err"], table["sobol_sem"])
    table = table[np.isfinite(table["u_input_ref"]) & (table["u_input_ref"] > 1e-12)]
    pd.set_option("display.width", 220)
    print(table.reset_index().to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("reference", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--draws", type=int, default=16)
    parser.add_argument("--scrambles", type=int, default=4)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--summary-only", action="store_true")
    parser.add_argument("--intruder", action="store_true", help="the intruder's scores (module docstring)")
    parser.add_argument("--intruder-draws", type=int, default=8)
    parser.add_argument("--intruder-plastic-draws", type=int, default=4)
    args = parser.parse_args(argv)
    if args.intruder:
        return intruder_main(args)
    config = json.loads((args.root / "config.effective.json").read_text())
    law = config.get("calibration", {}).get("wall_slip", "rheometer")
    roots = [args.out / f"sobol{args.draws}-s{k}" for k in range(args.scrambles)]
    if not args.summary_only:
        for k, out in enumerate(roots):
            one_law(args.root, out, law, args.jobs, {"seed": int(config["seed"]) + k,
                                                      "calibration": {"draws": args.draws, "draw_sampler": "sobol"}})
    key = ["case", "model", "metric"]
    ref = pd.read_csv(args.reference / "scores.csv").set_index(key)
    n_ref = json.loads((args.reference / "calibration" / "draws.json").read_text())["n_draws"]
    runs = pd.concat([pd.read_csv(r / "scores.csv").set_index(key)["u_input"].rename(r.name) for r in roots], axis=1)
    table = pd.DataFrame({"u_input_ref": ref["u_input"]}).join(runs, how="inner")
    cols = [r.name for r in roots]
    table = compare(table, cols, n_ref)
    within = (table["z"].abs() <= 2.0).mean()
    print(f"\n{len(table)} scores; sobol ({args.draws} draws, {len(cols)} scrambles) / random ({n_ref} draws): "
          f"u_input ratio median {table['ratio'].median():.3f}, range {table['ratio'].min():.3f}-{table['ratio'].max():.3f}; "
          f"|z| <= 2 for {within:.0%} (largest |z| {table['z'].abs().max():.2f}); "
          f"a single scramble's spread about the scrambles' mean: median {np.median(table[cols].std(axis=1, ddof=1) / table['sobol_mean']):.3f} of u_input")
    seconds = [model_seconds(r) for r in roots]
    print(f"planar model solves, CPU s: random {n_ref} draws {model_seconds(args.reference):.1f}; "
          f"sobol {args.draws} draws {np.mean(seconds):.1f} (per scramble)")
    return 0


def _intruder_draw_files(root: Path, scramble: Path, args: argparse.Namespace) -> dict[str, Path]:
    """Solve each intruder model's draws of ``scramble``'s ensemble (ROOT's nominal states and grid
    study) into ``scramble/model_draws/intruder``; the model -> file map."""
    from concurrent.futures import ThreadPoolExecutor

    from wall_before_after import run  # noqa: E402

    config = json.loads((root / "config.effective.json").read_text())
    config["output_root"] = str(scramble)
    config["models"].update({"intruder_draws": args.intruder_draws, "intruder_plastic_draws": args.intruder_plastic_draws})
    cfg = scramble / "config.intruder.json"
    cfg.write_text(json.dumps(config, indent=1))
    runs = sorted((root / "dem" / "intruder").glob("D*/run.json"))
    fields = [root / "fields" / "intruder" / f"{r.parent.name}.nc" for r in runs]
    py = sys.executable
    out, tasks = {}, []
    for model_file in sorted((root / "models" / "intruder").glob("*.nc")):
        model = model_file.stem
        part = scramble / "model_draws" / "intruder" / "parts" / model / "draws-1-of-1.nc"
        out[model] = scramble / "model_draws" / "intruder" / f"{model}.nc"
        common = ["--config", str(cfg), "--params", str(root / "calibration" / "params.json"), "--model", model,
                  "--runs", *map(str, runs), "--fields", *map(str, fields),
                  "--states", str(root / "models" / "intruder" / f"{model}.states.npz"),
                  "--draws", str(scramble / "calibration" / "draws.json")]
        refined = root / "model_draws" / "intruder" / "parts" / model / "refined.nc"
        tasks.append([([py, "-m", "pipeline.models", "intruder-draws", "draws", *common, "--part", "1/1", "--out", str(part)],
                       scramble / "logs" / "intruder_draws" / f"{model}.log"),
                      ([py, "-m", "pipeline.models", "intruder-draws", "merge", *common, "--parts", str(part), str(refined),
                        "--out", str(out[model])], scramble / "logs" / "intruder_draws" / f"{model}.merge.log")])
    if not args.summary_only:
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            list(pool.map(lambda steps: [run(*step) for step in steps], tasks))
    return out


def _intruder_u_input(root: Path, draw_files: dict[str, Path]) -> pd.Series:
    """u_input of every intruder score (speed per depth, the force sweep's slope) from ``draw_files``."""
    from pipeline.common.config import load_config
    from pipeline.scoring.force_sweep import score_force_sweep
    from pipeline.scoring.intruder_scores import score_intruder
    from pipeline.scoring.score_table import ScoringSettings

    settings = ScoringSettings.from_config(load_config(str(root / "config.effective.json")))
    runs = [json.loads(p.read_text()) for p in sorted((root / "dem" / "intruder").glob("D*/run.json"))]
    files = {p.stem: p for p in sorted((root / "models" / "intruder").glob("*.nc"))}
    rows, _ = score_intruder(runs, files, draw_files, settings)
    more, _, _ = score_force_sweep(runs, files, draw_files, settings)
    frame = pd.DataFrame(rows + more)
    return frame.set_index(["case", "model", "metric"])["u_input"]


def intruder_main(args: argparse.Namespace) -> int:
    """The ``--intruder`` mode (module docstring): ROOT is both the DEM and the reference."""
    import xarray as xr

    roots = [args.out / f"sobol{args.draws}-s{k}" for k in range(args.scrambles)]
    missing = [r for r in roots if not (r / "calibration" / "draws.json").exists()]
    if missing:
        raise SystemExit(f"draws_sampler: {missing[0]}/calibration/draws.json: not found (run the planar mode first)")
    ref_files = {p.stem: p for p in sorted((args.root / "model_draws" / "intruder").glob("*.nc"))}
    runs = {r.name: _intruder_u_input(args.root, _intruder_draw_files(args.root, r, args)) for r in roots}
    table = pd.DataFrame({"u_input_ref": _intruder_u_input(args.root, ref_files)}).join(pd.DataFrame(runs), how="inner")
    n_ref = {m: int(xr.open_dataset(p).attrs["n_draws"]) for m, p in ref_files.items()}
    cols = [r.name for r in roots]
    table["n_ref"] = [n_ref[m] for m in table.index.get_level_values("model")]
    table = compare(table, cols, table["n_ref"])
    print(f"\n{len(table)} intruder scores; sobol ({args.intruder_draws} NGF / {args.intruder_plastic_draws} plastic draws, "
          f"{len(cols)} scrambles) / the root's draws: u_input ratio median {table['ratio'].median():.3f}, range "
          f"{table['ratio'].min():.3f}-{table['ratio'].max():.3f}; |z| <= 2 for {(table['z'].abs() <= 2).mean():.0%} "
          f"(largest |z| {table['z'].abs().max():.2f})")

    def seconds(files: dict[str, Path]) -> dict[str, float]:
        return {m: float(xr.open_dataset(p).attrs["draws_seconds"]) for m, p in files.items()}

    ref_s = seconds(ref_files)
    new_s = [seconds({m: r / "model_draws" / "intruder" / f"{m}.nc" for m in ref_files}) for r in roots]
    for m in ref_files:
        print(f"intruder draws of {m}: {n_ref[m]} draws {ref_s[m]:.0f} s; sobol {np.mean([s[m] for s in new_s]):.0f} s (per scramble)")
    print(f"intruder draws, all models: {sum(ref_s.values()):.0f} s; sobol {np.mean([sum(s.values()) for s in new_s]):.0f} s (per scramble)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
