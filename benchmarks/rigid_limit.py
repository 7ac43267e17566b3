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


def run_quantities(root: Path) -> pd.DataFrame:
    """One row per run and quantity: value, its stated error, and the run's cost and extremes."""
    import xarray as xr

    rows = []
    for fields in sorted((root / "fields").glob("*/*.nc")):
        case, run = fields.parent.name, fields.stem
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


def report(work: Path, overlaps: list[float], dts: list[float]) -> pd.DataFrame:
    frames = []
    for overlap in overlaps:
        for dt in dts:
            root = work / setting_name(overlap, dt)
            if not (root / "fields").exists():
                print(f"(no results for {root.name})")
                continue
            frames.append(run_quantities(root).assign(overlap=overlap, dt_over_tc=dt))
    table = pd.concat(frames, ignore_index=True)
    ref = (overlaps[0], dts[0])
    rows = []
    for quantity, q in table.groupby("quantity", sort=False):
        # The replica noise: the pooled variance between replicas over every setting.
        groups = [g.value.dropna().to_numpy() for _, g in q.groupby(["overlap", "dt_over_tc"])]
        dof = sum(max(len(g) - 1, 0) for g in groups)
        pooled = math.sqrt(sum(float(((g - g.mean()) ** 2).sum()) for g in groups if len(g) > 1) / dof) if dof else math.nan
        means = q.groupby(["overlap", "dt_over_tc"]).value.mean()
        counts = q.groupby(["overlap", "dt_over_tc"]).value.count()
        for (overlap, dt), mean in means.items():
            noise = pooled * math.sqrt(1.0 / max(counts[(overlap, dt)], 1) + 1.0 / max(counts.get(ref, 1), 1))
            shift = (mean - means.get(ref, math.nan)) / noise if noise > 0 else math.nan
            rows.append({"quantity": quantity, "overlap": overlap, "dt/t_c": dt, "mean": mean,
                         "replica sd": pooled, "dof": dof, "shift / noise": shift})
    shifts = pd.DataFrame(rows)
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print("\nEach quantity at each setting (mean of the replicas) and its shift from the reference "
              f"(overlap {ref[0]:g}, dt/t_c {ref[1]:g}) in units of the replica noise of that difference:")
        print(shifts.pivot_table(index="quantity", columns=["overlap", "dt/t_c"], values="mean", sort=False).round(4).to_string())
        print()
        print(shifts.pivot_table(index="quantity", columns=["overlap", "dt/t_c"], values="shift / noise", sort=False).round(2).to_string())
        cost = table.drop_duplicates(["overlap", "dt_over_tc", "case", "run"]).groupby(["overlap", "dt_over_tc", "case"]).agg(
            steps_per_strain=("steps_per_strain", "mean"), max_overlap=("max_overlap_over_d", "max"),
            ke_mean=("ke_mean", "mean"), ke_max=("ke_max", "max"))
        reference = cost.xs(ref, level=[0, 1]).steps_per_strain
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
    args = parser.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    base = yaml.safe_load(args.base.read_text())
    if not args.report_only:
        for overlap in args.overlaps:
            for dt in args.dts:
                run_setting(setting_config(base, overlap, dt, args.work / setting_name(overlap, dt), args.replicas),
                            args.work, args.cores)
    report(args.work, args.overlaps, args.dts)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
