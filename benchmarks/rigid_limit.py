"""Benchmark: the rigid limit, measured. Do the scored quantities change with the contact stiffness
and the time step, and what does a softer contact save?

Run as ``python benchmarks/rigid_limit.py --work DIR`` (DEM runs, about an hour on 2 cores with the
defaults) or ``--report-only`` on a finished DIR. For every pair of ``material.design_overlap``
(default 0.001, 0.002, 0.004) and ``material.dt_over_contact_time`` (0.04, 0.05) it writes a config
derived from ``--base`` (config/config.yaml) holding only:

- the rheometer at I = 0.005 and 0.05 (600 Pa: the quasi-static end and the middle) and the
  fastest state a scored bed reaches, I = 0.6 at 10 Pa (shear_gravity_fast's top wall reaches
  I ~ 0.7), with its chain from I = 0.25 at 50 Pa and 0.4 at 20 Pa (``continue_above``), two
  replicas with their shared fills;
- ``shear_gravity`` (two replicas, no size study), produced until its creep is resolved to 0.15
  decade down to 12 d below the top wall or 6 strain (a case ``precision`` and ``production_strain``
  of its own), so the creep at 6, 9 and 12 d can be compared;
- ``material.max_overlap`` = 10 x the design overlap (the default's ratio), so a softer contact is
  held to the same relative bound and the largest overlaps it reaches are reported, not refused;

and runs the workflow's own rules on it (Snakemake, the fields of those runs only), one setting
after the other, with the same seeds. It then prints, per quantity (bulk mu and nu of each
rheometer state; log10 of the creep speed over V at 6, 9, 12 d below the top contact plane), its
value at each setting (mean of the replicas), the shift from the 0.001 / 0.04 reference in units
of the replica noise (the pooled scatter between replicas over every setting: the noise of a
difference of two means of two replicas each), the particle-steps per strain of each run, the
largest overlap and the kinetic energy per grain over (m V^2 / 2) of each setting.
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from scipy import stats

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.common.observables import creep_speed  # noqa: E402
from pipeline.dem.wall_series import read_wall_series  # noqa: E402

STATES = [(0.005, 600.0), (0.05, 600.0), (0.25, 50.0), (0.4, 20.0), (0.6, 10.0)]
SCORED_STATES = ("I0.005-P600", "I0.05-P600", "I0.6-P10")
DEPTHS = (6.0, 9.0, 12.0)


def setting_name(overlap: float, dt: float) -> str:
    return f"overlap{overlap:g}-dt{dt:g}"


def setting_config(base: dict, overlap: float, dt: float, root: Path, replicas: int) -> dict:
    config = copy.deepcopy(base)
    config["output_root"] = str(root)
    config["material"].update(design_overlap=overlap, dt_over_contact_time=dt, max_overlap=10.0 * overlap)
    rheo = config["cases"]["rheometer"]
    rheo.update(inertial_numbers=[STATES[0][0], STATES[1][0]], wall_pressure=STATES[0][1], replicas=replicas,
                extra_states=[{"inertial_number": i, "wall_pressure": p} for i, p in STATES[2:]])
    sg = copy.deepcopy(config["cases"]["shear_gravity"])
    sg.pop("size_study", None)
    sg.update(replicas=replicas, production_strain=6.0,
              precision={**config["dem"]["precision"], "log_speed_depth_over_d": 12.0, "log_speed": 0.15})
    for key in ("min_production_strain", "steady_window_is_production"):
        sg["precision"].pop(key, None)
    config["cases"] = {"rheometer": rheo, "shear_gravity": sg}
    config["calibration"] = {"nonlocal_case": "shear_gravity", "nonlocal_runs": "all",
                             "bulk_margin_over_d": base["calibration"].get("bulk_margin_over_d", 3.0)}
    return config


def targets(config: dict) -> list[str]:
    root = Path(config["output_root"])
    reps = [f"r{k + 1}" for k in range(config["cases"]["rheometer"]["replicas"])]
    out = [str(root / "fields" / "rheometer" / f"I{i:g}-P{p:g}-{r}.nc") for i, p in STATES for r in reps]
    return out + [str(root / "fields" / "shear_gravity" / f"{r}.nc") for r in reps]


def run_setting(config: dict, work: Path, cores: int) -> None:
    path = work / f"{Path(config['output_root']).name}.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    cmd = [sys.executable, "-m", "snakemake", "--cores", str(cores), "--configfile", str(path),
           "--snakefile", str(REPO / "Snakefile"), "--directory", str(REPO), *targets(config)]
    print("running", " ".join(cmd[-3 - len(targets(config)):][:3]), f"... ({Path(config['output_root']).name})", flush=True)
    log = work / f"{Path(config['output_root']).name}.log"
    with log.open("w") as handle:
        proc = subprocess.run(cmd, cwd=REPO, stdout=handle, stderr=subprocess.STDOUT)
    if proc.returncode != 0:
        raise SystemExit(f"rigid_limit: the workflow failed for {config['output_root']} (see {log})")


def settled_fields(root: Path, case: str, run: str, settle_strain: float) -> Path:
    """The run's fields averaged after its first ``settle_strain`` strain units of production
    (a copy of the run folder whose run.json's window starts that much later; the dumps linked)."""
    import shutil
    import tempfile

    from pipeline.coarse_graining.fields import run_fields
    from pipeline.common.atomic import write_netcdf

    source = root / "dem" / case / run
    record = json.loads((source / "run.json").read_text())
    t0, t1 = record["steady_state_window"]
    start = t0 + settle_strain * float(record["settled_gap"]) / float(record["wall_speed"])
    out = root / "settled_fields" / case / f"{run}.nc"
    if out.exists():
        return out
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / run
        copy.mkdir()
        for item in source.iterdir():
            if item.name != "run.json":
                (copy / item.name).symlink_to(item)
        record["steady_state_window"] = [start, t1]
        (copy / "run.json").write_text(json.dumps(record))
        config = json.loads((root / "config.effective.json").read_text())
        result, _ = run_fields(config, copy, checks=False)
        out.parent.mkdir(parents=True, exist_ok=True)
        write_netcdf(result.dataset, out)
    shutil.rmtree(copy, ignore_errors=True) if copy.exists() else None
    return out


def run_quantities(root: Path, settle_strain: float = 0.0) -> pd.DataFrame:
    """One row per run and quantity: value, its stated error, and the run's cost and extremes.
    With ``settle_strain``, the rheometer states are averaged after that many strain units of their
    production (their production may start at the fill: the steady-state test passes on the wall's
    force and height before the bulk's shear rate has settled)."""
    import xarray as xr

    rows = []
    for fields in sorted((root / "fields").glob("*/*.nc")):
        case, run = fields.parent.name, fields.stem
        if case == "rheometer" and settle_strain > 0:
            fields = settled_fields(root, case, run, settle_strain)
        record = json.loads((root / "dem" / case / run / "run.json").read_text())
        chunk_strain = float(record["provenance"]["config"]["dem"]["chunk_strain"])
        steps_per_strain = record["particle_count"] * record["chunk_steps"] / chunk_strain
        series = pd.concat([read_wall_series(root / "dem" / case / run / "series" / p.name)
                            for p in sorted((root / "dem" / case / run / "series").glob("production_*.txt"))]
                           + [read_wall_series(p) for p in sorted((root / "dem" / case / run / "series").glob("shear_*.txt"))
                              if not p.name.startswith("pairsum")], ignore_index=True)
        d, v = float(record["d"]), float(record["wall_speed"])
        m_grain = float(record["density"]) * math.pi * d**3 / 6.0
        ke = series["ke"].to_numpy() / record["flowing_grains"] / (0.5 * m_grain * v * v)
        base = {"case": case, "run": run, "steps_per_strain": steps_per_strain,
                "max_overlap_over_d": float(record["max_overlap_over_d"]),
                "ke_mean": float(ke.mean()), "ke_max": float(ke.max()), "dt": float(record["time_step"])}
        with xr.open_dataset(fields) as ds:
            if case == "rheometer":
                state = run.rsplit("-", 1)[0]
                for name in ("mu", "nu"):
                    rows.append(base | {"quantity": f"{state} {name}", "value": float(ds.attrs[f"bulk_{name}"]),
                                        "error": float(ds.attrs[f"bulk_{name}_err"])})
                rows.append(base | {"quantity": f"{state} I", "value": float(ds.attrs["bulk_I"]),
                                    "error": float(ds.attrs["bulk_I_err"])})
            else:
                u, err, _ = creep_speed(ds)
                depth = (float(ds.attrs["z_top_contact_plane"]) - ds.z.values) / d
                order = np.argsort(depth)
                for target in DEPTHS:
                    value = float(np.interp(target, depth[order], u[order]))
                    error = float(np.interp(target, depth[order], err[order]))
                    resolved = value > 2.0 * error
                    rows.append(base | {"quantity": f"log10 u/V at {target:g} d",
                                        "value": math.log10(value / v) if resolved else math.nan,
                                        "error": error / (value * math.log(10.0)) if resolved else math.nan})
    return pd.DataFrame(rows)


def report(work: Path, overlaps: list[float], dts: list[float], settle_strain: float = 0.0,
           null_seeds: tuple[int, ...] = ()) -> pd.DataFrame:
    """The table of the module docstring; ``null_seeds``: the reference setting rerun with those
    seeds (``null-seed<S>``), a comparison in which nothing but the seed changes, so its shifts show
    what the noise model calls a shift when there is none."""
    frames = []
    roots = [(work / setting_name(o, dt), o, dt, "config") for o in overlaps for dt in dts]
    roots += [(work / f"null-seed{seed}", overlaps[0], dts[0], str(seed)) for seed in null_seeds]
    for root, overlap, dt, seed in roots:
        if not (root / "fields").exists():
            print(f"(no results for {root.name})")
            continue
        frames.append(run_quantities(root, settle_strain).assign(overlap=overlap, dt_over_tc=dt, seed=seed))
    table = pd.concat(frames, ignore_index=True)
    keys = ["overlap", "dt_over_tc", "seed"]
    ref = (overlaps[0], dts[0], "config")
    rows = []
    for quantity, q in table.groupby("quantity", sort=False):
        # The replica noise: the pooled variance between replicas over every setting.
        groups = [g.value.dropna().to_numpy() for _, g in q.groupby(keys)]
        dof = sum(max(len(g) - 1, 0) for g in groups)
        pooled = math.sqrt(sum(float(((g - g.mean()) ** 2).sum()) for g in groups if len(g) > 1) / dof) if dof else math.nan
        means = q.groupby(keys).value.mean()
        counts = q.groupby(keys).value.count()
        for key, mean in means.items():
            noise = pooled * math.sqrt(1.0 / max(counts[key], 1) + 1.0 / max(counts.get(ref, 1), 1))
            shift = (mean - means.get(ref, math.nan)) / noise if noise > 0 else math.nan
            rows.append({"quantity": quantity, "overlap": key[0], "dt/t_c": key[1], "seed": key[2], "mean": mean,
                         "replica sd": pooled, "dof": dof, "shift / noise": shift})
    shifts = pd.DataFrame(rows)
    columns = ["overlap", "dt/t_c", "seed"]
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print("\nEach quantity at each setting (mean of the replicas) and its shift from the reference "
              f"(overlap {ref[0]:g}, dt/t_c {ref[1]:g}) in units of the replica noise of that difference:")
        print(shifts.pivot_table(index="quantity", columns=columns, values="mean", sort=False).round(4).to_string())
        print()
        print(shifts.pivot_table(index="quantity", columns=columns, values="shift / noise", sort=False).round(2).to_string())
        summary = []
        for key, g in shifts.groupby(columns):
            z = g["shift / noise"].dropna()
            z = z[g.loc[z.index, "seed"].notna()]
            if tuple(key) == (ref[0], ref[1], ref[2]) or z.empty:
                continue
            chi2 = float((z**2).sum())
            summary.append({"overlap": key[0], "dt/t_c": key[1], "seed": key[2], "quantities": len(z),
                            "sum of shift^2": chi2, "p (chi2)": float(stats.chi2.sf(chi2, len(z))),
                            "largest |shift|": float(z.abs().max())})
        print("\nAll quantities together (sum of the squared shifts against chi2 with one dof each, if the "
              "noise model holds):")
        print(pd.DataFrame(summary).round(4).to_string(index=False))
        cost = table[table.seed == "config"].drop_duplicates(["overlap", "dt_over_tc", "case", "run"]).groupby(
            ["overlap", "dt_over_tc", "case"]).agg(
            steps_per_strain=("steps_per_strain", "mean"), max_overlap=("max_overlap_over_d", "max"),
            ke_mean=("ke_mean", "mean"), ke_max=("ke_max", "max"))
        reference = cost.xs(ref[:2], level=[0, 1]).steps_per_strain
        cost["steps_per_strain / reference"] = [r.steps_per_strain / reference[c] for (o, t, c), r in cost.iterrows()]
        print("\nParticle-steps per strain, the largest overlap / d and the kinetic energy per grain over m V^2 / 2:")
        print(cost.round(4).to_string())
    return shifts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, required=True, help="folder for the settings' output roots")
    parser.add_argument("--base", type=Path, default=REPO / "config" / "config.yaml")
    parser.add_argument("--overlaps", type=float, nargs="+", default=[0.001, 0.002, 0.004])
    parser.add_argument("--dts", type=float, nargs="+", default=[0.04, 0.05])
    parser.add_argument("--replicas", type=int, default=2)
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--report-only", action="store_true", help="read a finished --work folder, run nothing")
    parser.add_argument("--null-seeds", type=int, nargs="*", default=[],
                        help="also run the reference setting with these seeds: the shifts of nothing but the seed")
    parser.add_argument("--settle-strain", type=float, default=1.0,
                        help="average the rheometer states after this many strain units of production (default 1)")
    args = parser.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    base = yaml.safe_load(args.base.read_text())
    if not args.report_only:
        for overlap in args.overlaps:
            for dt in args.dts:
                run_setting(setting_config(base, overlap, dt, args.work / setting_name(overlap, dt), args.replicas),
                            args.work, args.cores)
        for seed in args.null_seeds:
            config = setting_config(base, args.overlaps[0], args.dts[0], args.work / f"null-seed{seed}", args.replicas)
            run_setting(config | {"seed": seed}, args.work, args.cores)
    report(args.work, args.overlaps, args.dts, args.settle_strain, tuple(args.null_seeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
