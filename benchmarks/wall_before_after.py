"""Benchmark (issue 54): the planar calibration, scores and verdict with each wall law, on one DEM.

Run as ``python benchmarks/wall_before_after.py ROOT --out OUT [--laws none rheometer] [--jobs 2]``.
ROOT is a finished output root (its ``config.effective.json`` and the planar cases' ``fields/``).
For each wall law (``calibration.wall_slip``) the post-DEM planar stages run through their own
commands, exactly as the workflow's rules call them, into ``OUT/<law>/``: the calibration and its
draws, every model on every planar case with its draws, the scores with the verdict and
``validation/wall.csv``, and the decay-length law (beta). The intruder is left out (its 2D solves
are a stage of their own, and the wall law is the same there). Then it prints the wall table per
case and law, the calibrated parameters, beta, and ``benchmarks/verdict_stability.py`` between the
laws' roots.

Nothing in ROOT is written; the fields files are read in place.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parents[1]


def planar_fields(root: Path, config: dict) -> dict[str, list[str]]:
    """Fields files of every planar case of the config (replicas of the size study left out)."""
    out = {}
    for case, spec in config["cases"].items():
        if spec.get("geometry") != "planar_shear":
            continue
        files = sorted(str(p) for p in (root / "fields" / case).glob("*.nc") if p.stem.startswith(("r", "I")))
        files = [f for f in files if not Path(f).stem.startswith("L")]
        if files:
            out[case] = files
    return out


def run(command: list[str], log: Path) -> None:
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("w") as handle:
        done = subprocess.run(command, stdout=handle, stderr=subprocess.STDOUT, cwd=REPO)
    if done.returncode != 0:
        raise SystemExit(f"wall_before_after: {' '.join(command[:4])} ... failed (exit {done.returncode}); see {log}")


def one_law(root: Path, out: Path, law: str, jobs: int, overrides: dict | None = None) -> Path:
    """The planar post-DEM stages of ROOT's DEM into ``out`` with ``calibration.wall_slip`` = ``law``
    and the config's top-level sections updated by ``overrides`` (section -> {key: value}, or a value)."""
    config = json.loads((root / "config.effective.json").read_text())
    config["output_root"] = str(out)
    config.setdefault("calibration", {})["wall_slip"] = law
    for key, value in (overrides or {}).items():
        if isinstance(value, dict):
            config.setdefault(key, {}).update(value)
        else:
            config[key] = value
    out.mkdir(parents=True, exist_ok=True)
    cfg = out / "config.effective.json"
    cfg.write_text(json.dumps(config, indent=1))
    fields = planar_fields(root, config)
    nonlocal_case = config["calibration"].get("nonlocal_case", "shear_gravity")
    py = sys.executable
    params, draws = out / "calibration" / "params.json", out / "calibration" / "draws.json"
    params.parent.mkdir(parents=True, exist_ok=True)
    run([py, "-m", "pipeline.calibration", "--config", str(cfg), "--rheometer", *fields["rheometer"],
         "--nonlocal", *fields[nonlocal_case], "--out", str(params)], out / "logs" / "calibrate.log")
    run([py, "-m", "pipeline.calibration", "draws", "--config", str(cfg), "--params", str(params),
         "--nonlocal", *fields[nonlocal_case], "--out", str(draws)], out / "logs" / "draws.log")
    cases = [c for c in fields if c != "rheometer"]
    models = config["models"]["names"]
    tasks = []
    for case in cases:
        for model in models:
            (out / "models" / case).mkdir(parents=True, exist_ok=True)
            (out / "model_draws" / case).mkdir(parents=True, exist_ok=True)
            tasks.append(([py, "-m", "pipeline.models", "planar", "--config", str(cfg), "--params", str(params),
                           "--case", case, "--model", model, "--fields", *fields[case],
                           "--out", str(out / "models" / case / f"{model}.nc"), "--draws", str(draws),
                           "--draws-out", str(out / "model_draws" / case / f"{model}.nc")],
                          out / "logs" / "models" / case / f"{model}.log"))
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        list(pool.map(lambda t: run(*t), tasks))
    model_files = [str(out / "models" / c / f"{m}.nc") for c in cases for m in models]
    draw_files = [str(out / "model_draws" / c / f"{m}.nc") for c in cases for m in models]
    scored = [f for c in cases for f in fields[c]]
    v = out / "validation"
    v.mkdir(parents=True, exist_ok=True)
    run([py, "-m", "pipeline.scoring", "scores", "--config", str(cfg), "--fields", *scored, "--models", *model_files,
         "--model-draws", *draw_files, "--params", str(params), "--out", str(out / "scores.csv"),
         "--verdict-out", str(v / "verdict.csv"), "--differences-out", str(v / "model_differences.csv"),
         "--scene-needs-out", str(v / "scene_needs.csv"), "--wall-out", str(v / "wall.csv")], out / "logs" / "scores.log")
    run([py, "-m", "pipeline.scoring", "decay-length", "--config", str(cfg), "--params", str(params),
         "--fields", *scored, "--models", *model_files, "--out", str(v / "decay_length.csv")],
        out / "logs" / "decay_length.log")
    return out


def summary(roots: dict[str, Path]) -> None:
    pd.set_option("display.width", 200)
    for law, out in roots.items():
        print(f"\n=== calibration.wall_slip = {law} ({out})")
        params = json.loads((out / "calibration" / "params.json").read_text())
        d = params["d"]
        wall = params["wall"]
        print(f"b = {wall['slip_length']['value'] / d:.3f} +- {wall['slip_length']['error'] / d:.3f} d ({wall['slip_length']['fitted_on']}); "
              f"rheometer {wall['rheometer']['value'] / d:.3f} +- {wall['rheometer']['error'] / d:.3f} d, chi2/dof "
              f"{wall['rheometer']['chi2_reduced']:.2f}, I trend z {wall['rheometer']['inertial_trend']['z']:+.1f}; "
              f"calibration case {wall['calibration_case'].get('value', float('nan')) / d:.3f} +- "
              f"{wall['calibration_case'].get('error', float('nan')) / d:.3f} d")
        for model, entry in params["nonlocal"].items():
            for name, e in entry.items():
                scale = 1.0 if name == "A" else 1.0 / d
                print(f"  {model} {name}{'' if name == 'A' else '/d'} = {e['value'] * scale:.4g} +- {e['error'] * scale:.2g}")
        wall_table = pd.read_csv(out / "validation" / "wall.csv")
        cols = [c for c in ("case", "source", "wall_top_shear_stress", "wall_top_shear_stress_err", "stress_minus_dem_rel",
                            "stress_minus_dem_over_dem_err", "wall_top_slip_over_v", "slip_minus_dem_over_v",
                            "wall_top_slip_length_over_d") if c in wall_table]
        print(wall_table[cols].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
        fit = pd.read_csv(out / "validation" / "decay_length_fit.csv")
        print(fit[[c for c in ("source", "windows", "beta", "beta_err", "n_windows") if c in fit]].to_string(index=False))
        verdict = pd.read_csv(out / "validation" / "verdict.csv")
        print(verdict[["case", "metric", "model", "value", "u_val", "verdict"]].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    laws = list(roots)
    for a, b in zip(laws, laws[1:]):
        print(f"\n=== verdict_stability.py {roots[a]} {roots[b]}")
        sys.stdout.flush()
        subprocess.run([sys.executable, str(REPO / "benchmarks" / "verdict_stability.py"), str(roots[a]), str(roots[b])], check=False)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--laws", nargs="+", default=["none", "rheometer"], choices=["none", "rheometer", "calibration_case"])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--summary-only", action="store_true", help="print the summary of roots already made")
    args = parser.parse_args(argv)
    roots = {law: args.out / law for law in args.laws}
    if not args.summary_only:
        for law in args.laws:
            one_law(args.root, roots[law], law, args.jobs)
    summary(roots)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
