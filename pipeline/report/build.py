"""Write the comparison report ``report.html`` (self-contained) and its figures as PNG files.

Reads only what the stages wrote (run.json, wall series, fields, params.json, model solutions,
scores.csv, stability tables), never recomputes them.

Usage: ``python -m pipeline.report.build --config RESULTS/config.effective.json --out RESULTS/report.html
[--figures RESULTS/figures]``
"""
from __future__ import annotations

import argparse
import html
import json
import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common.formats import open_fields
from pipeline.common import atomic
from pipeline.common.config import dem_runs, load_config
from pipeline.report.html import figure_html, page, table_html
from pipeline.common.provenance import software_versions
from pipeline.common.layout import (convergence_cases, convergence_paths, creeping_cases, fields_paths, intruder_cases, model_names, scored_cases,
                                    shared_fill_paths)
from pipeline.dem.wall_series import read_wall_series
from pipeline.report.claims_across_section import claims_across_section
from pipeline.report.claims_section import claims_section
from pipeline.report.creep_section import decay_length_section
from pipeline.report.halves_section import creep_halves_section
from pipeline.report.intruder_fields_section import intruder_fields_section
from pipeline.report.intruder_section import intruder_section
from pipeline.report.scores_section import score_section
from pipeline.report.style import MODEL_STYLE
from pipeline.report.wall_section import wall_section
from pipeline.scoring.replicas import align_replicas

#: Figures embedded as PNG (colour maps); every other one is line art, embedded as SVG.
RASTER_FIGURES = ("intruder_field", "well_posedness")


def load_runs(config: dict[str, Any]) -> list[dict[str, Any]]:
    """The run.json record of every DEM run, with its folder under ``_dir``."""
    root = Path(config["output_root"])
    runs = []
    for case, run in dem_runs(config):
        run_dir = root / "dem" / case / run
        path = run_dir / "run.json"
        if not path.exists():
            raise FileNotFoundError(f"{path}: DEM run {case}/{run} has no run.json (did the dem rule finish?)")
        record = json.loads(path.read_text())
        record["_dir"] = run_dir
        runs.append(record)
    return runs


class Figures:
    """Collects figures: embeds each in the page and saves it as PNG."""

    def __init__(self, folder: Path | None) -> None:
        self.folder = folder
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)

    def add(self, name: str, fig: plt.Figure, caption: str) -> str:
        if self.folder is not None:
            fig.savefig(self.folder / f"{name}.png", dpi=110, bbox_inches="tight")
        return figure_html(fig, caption, vector=name not in RASTER_FIGURES)


def pareto_section(root: Path, figures: Figures) -> str:
    scores = pd.read_csv(root / "scores.csv")
    table = pd.read_csv(root / "cost_accuracy.csv")
    # The chart ranks predictions: errors on held-out cases (on the calibration case only if there is none).
    held = sorted(set(scores[scores.role == "held_out"].case) & set(table.case))
    shown = held or sorted(set(table.case))
    which = "held-out cases " + ", ".join(held) if held else "the calibration case (no held-out planar case)"
    table = table[table.case.isin(shown)]
    scores = scores[scores.case.isin(shown)]
    sweep = table[table.sweep == "grid"]
    tolerance = table[table.sweep == "tolerance"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, metric in zip(axes, ("velocity_rmse_rel", "log_velocity_rmse")):
        for (case, model), sub in sweep.groupby(["case", "model"]):
            sub = sub[np.isfinite(sub[metric])]
            if sub.empty:
                continue
            color, ls = MODEL_STYLE.get(model, ("k", "-"))
            ax.plot(sub.solve_seconds * 1e3, sub[metric], color=color, ls=ls, marker="o", ms=3, label=f"{model} ({case})")
        for case, noise in scores[scores.metric == metric].groupby("case")["dem_noise"].first().dropna().items():
            ax.axhline(noise, color="grey", ls="--", lw=1, label=f"DEM noise floor ({case})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("solve time (ms), grids of 16 to 1024 nodes")
        ax.set_ylabel(metric.replace("_", " ") + " against DEM")
        ax.legend(fontsize=7)
    no_velocity = sorted(set(sweep.model) - set(sweep.dropna(subset=["velocity_rmse_rel"]).model))
    missing = (f" Not drawn: {', '.join(no_velocity)} (no finite error on any grid)." if no_velocity else "")
    # Empty error cells read back as NaN (pandas 3 keeps them missing even as str).
    errors = sweep["error"].where(sweep["error"].notna(), "").astype(str)
    failures = sweep[errors != ""]
    failed = "".join(f" {r.model} fails on {r.n_grid} nodes ({r.error[:80]})." for r in failures.itertuples())
    return ("<h2>Accuracy against cost</h2>"
            + figures.add("pareto", fig, f"Error against the DEM on {which}, of each model over a sweep of grid "
                          "resolution, against its solve time (best of 3). Points towards the lower left are better.")
            + f"<p>{html.escape(cheapest_sentence(scores) + missing + failed)}</p>"
            + "<h3>Solver tolerance</h3><p class='note'>The same errors and solve times on "
            f"{int(tolerance.n_grid.iloc[0]) if len(tolerance) else 0} nodes, against the solver's tolerance (the "
            "relative residual of the wall condition or of the yield iteration it stops at).</p>"
            + table_html(tolerance[["case", "model", "tolerance", "solve_seconds", "velocity_rmse_rel",
                                    "log_velocity_rmse", "error"]].round(6)))


def dem_convergence_section(root: Path, config: dict[str, Any], figures: Figures) -> str:
    """Field noise of the DEM against core-seconds: averaging time and system size."""
    frames = [pd.read_csv(p) for p in map(Path, convergence_paths(config))]
    table = pd.concat(frames, ignore_index=True)
    metrics_drawn = ("velocity_rmse_rel", "log_velocity_rmse", "nu_rmse")
    fig, axes = plt.subplots(1, len(metrics_drawn), figsize=(15, 4))
    for ax, metric in zip(axes, metrics_drawn):
        for (case, study), sub in table[table.metric == metric].groupby(["case", "study"]):
            sub = sub.sort_values("core_seconds")
            marker = "o" if study == "averaging_time" else "s"
            ax.plot(sub.core_seconds, sub.noise, marker=marker, label=f"{case}: {study.replace('_', ' ')}")
            if study == "system_size":
                for r in sub.itertuples():
                    ax.annotate(f"{r.cell_over_d:g} d", (r.core_seconds, r.noise), fontsize=7,
                                textcoords="offset points", xytext=(4, 4))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("core-seconds of one DEM replica (s)")
        ax.set_ylabel(f"{metric.replace('_', ' ')} between replicas (-)")
        ax.legend(fontsize=7)
    sentences = []
    for (case, metric), sub in table[table.metric.isin(metrics_drawn)].groupby(["case", "metric"]):
        best = sub.loc[sub.noise_per_sqrt_cost.idxmin()]
        how = (f"averaging {best.averaging_fraction:.2g} of the production" if best.study == "averaging_time"
               else f"a {best.cell_over_d:g} d cell")
        sentences.append(f"{case}, {metric}: the cheapest noise per sqrt(core-second) comes from {how} "
                         f"(noise {best.noise:.3g} for {best.core_seconds:.0f} core-s).")
    # A case without a size_study has its own cell alone in the system-size sweep: say so, not a flat line.
    cells = table[table.study == "system_size"].groupby("case")["cell_over_d"].nunique()
    unstudied = sorted(case for case, n in cells.items() if n < 2)
    if unstudied:
        sentences.append(f"System-size study: not run in this config for {', '.join(unstudied)} (only the case's own cell; "
                         "config/studies/size.yaml runs shear_gravity's, docs/dem_cost.md section 3).")
    shown = table[table.metric.isin(metrics_drawn)][["case", "study", "cell_over_d", "n_grains", "n_replicas",
                                                      "averaging_strain", "core_seconds", "metric", "noise"]]
    return ("<h2>DEM noise against cost</h2><p class='note'>Noise: the score metric between independent replicas "
            "(the floor of the score table). Averaging time: the replicas re-averaged over the first part of their "
            "production; system size: replicas in square cells of other lengths with the same grains per area.</p>"
            + figures.add("dem_convergence", fig, "DEM field noise against the core-seconds of one replica; circles: "
                          "averaging time (default cell), squares: system size (whole production).")
            + f"<p>{html.escape(' '.join(sentences))}</p>" + table_html(shown.round(4)))


def cheapest_sentence(scores: pd.DataFrame, metric: str = "velocity_rmse_rel", factor: float = 2.0) -> str:
    """Per case: the cheapest model within ``factor`` of the best accuracy on ``metric``."""
    out = []
    for case, frame in scores[scores.metric == metric].groupby("case"):
        finite = frame[np.isfinite(frame.value)]
        if finite.empty:
            continue
        best = finite.value.min()
        ok = finite[finite.value <= factor * best].sort_values("solve_seconds")
        row = ok.iloc[0]
        out.append(f"{case}: the cheapest model within {factor:g}x of the best {metric} ({best:.3g}) is "
                   f"{row.model} ({row.value:.3g}, {row.solve_seconds * 1e3:.2f} ms).")
    return " ".join(out)


# ---------------------------------------------------------------------------------- profiles
def profiles_section(root: Path, config: dict[str, Any], figures: Figures) -> str:
    parts = ["<h2>Profiles</h2><p class='note'>Second panel: the creep speed, u_x or the displacement-based "
             "u_x_disp where its error is smaller (deep creep). Last panel: the operational fluidity "
             "shear_rate / mu, NGF's own field.</p>"]
    panels = (("u_x", "u_x / V (-)"), ("u_creep", "creep speed / V (-), log axis"), ("nu", "solid fraction nu (-)"),
              ("mu", "stress ratio mu = |sigma_xz| / p (-)"), ("fluidity", "fluidity g = shear_rate / mu (s-1), log axis"))
    flagged = []
    for case in scored_cases(config):
        reps = align_replicas([open_fields(Path(f)) for f in fields_paths(config, case)])
        z0 = float(reps[0].attrs["z_bottom_wall"])
        d = float(reps[0].attrs["d"])
        V = float(reps[0].attrs["wall_speed"])
        scale = {"u_x": V, "u_creep": V}
        fig, axes = plt.subplots(1, len(panels), figsize=(16, 5), sharey=True)
        for k, ds in enumerate(reps):
            zz = (ds.z.values - z0) / d
            for ax, (name, _) in zip(axes, panels):
                if name not in ds:
                    continue
                y, e = ds[name].values / scale.get(name, 1.0), ds[f"{name}_err"].values / scale.get(name, 1.0)
                ax.plot(y, zz, color="k", lw=1, label="DEM replicas" if k == 0 else None)
                ax.fill_betweenx(zz, y - e, y + e, color="k", alpha=0.15)
        for model in model_names(config):
            path = root / "models" / case / f"{model}.nc"
            if not path.exists():
                continue
            sol = xr.open_dataset(path)
            if int(sol.attrs.get("outside_calibrated_range", 0)):
                flagged.append(f"{model} on {case} reaches I = {sol.attrs['I_max_solution']:.3g}, beyond the "
                               f"rheometer's largest I = {sol.attrs['I_max_calibrated']:.3g}")
            zz = (sol.z.values - z0) / d
            color, ls = MODEL_STYLE.get(model, ("grey", "-"))
            for ax, (name, _) in zip(axes, panels):
                source = "u_x" if name == "u_creep" else name
                if source in sol:
                    ax.plot(sol[source].values / scale.get(name, 1.0), zz, color=color, ls=ls, lw=1.5, label=model)
            sol.close()
        axes[1].set_xscale("log")
        axes[1].set_xlim(1e-6, 2)
        axes[4].set_xscale("log")
        for ax, (_, label) in zip(axes, panels):
            ax.set_xlabel(label, fontsize=8)
        axes[0].set_ylabel("height above the bottom wall's grain centres, z / d (-)")
        axes[0].legend(fontsize=7)
        parts.append(figures.add("profiles" if case == scored_cases(config)[0] else f"profiles_{case}", fig,
                                 f"{case}: DEM (black, one line per replica, band = standard error) and every model."))
    if flagged:
        parts.append("<p><b>Outside the calibrated range:</b> " + html.escape("; ".join(flagged))
                     + " (the local laws are extrapolated there).</p>")
    return "\n".join(parts)


# ---------------------------------------------------------------------------------- intruder
# ------------------------------------------------------------------------------- calibration
def calibration_section(root: Path, figures: Figures) -> str:
    params = json.loads((root / "calibration" / "params.json").read_text())
    states = pd.DataFrame(params["rheometer_states"])
    loc = {k: v["value"] for k, v in params["local"].items()}
    fig, (ax_mu, ax_nu) = plt.subplots(1, 2, figsize=(11, 4))
    for pressure, sub in states.groupby("wall_pressure"):
        ax_mu.errorbar(sub.I, sub.mu, xerr=sub.I_err, yerr=sub.mu_err, fmt="o", label=f"DEM, P = {pressure:g} Pa")
        ax_nu.errorbar(sub.I, sub.nu, xerr=sub.I_err, yerr=sub.nu_err, fmt="o", label=f"DEM, P = {pressure:g} Pa")
    grid = np.logspace(math.log10(states.I.min() / 2), math.log10(states.I.max() * 2), 100)
    ax_mu.plot(grid, loc["mu_s"] + (loc["mu_2"] - loc["mu_s"]) / (1 + loc["I_0"] / grid), "k-", label="fit mu(I)")
    ax_nu.plot(grid, loc["nu_c"] - loc["a"] * grid, "k-", label="fit nu(I) = nu_c - a I")
    for ax in (ax_mu, ax_nu):
        ax.set_xscale("log")
        ax.set_xlabel("inertial number I (-)")
        ax.legend(fontsize=8)
    ax_mu.set_ylabel("stress ratio mu (-)")
    ax_nu.set_ylabel("solid fraction nu (-)")
    rows = []
    for section in ("local", "critical_state"):
        for name, e in params[section].items():
            rows.append({"group": section, "parameter": name, "value": e["value"], "error": e["error"], "fitted on": e["fitted_on"]})
    for model, entry in params.get("nonlocal", {}).items():
        for name, e in entry.items():
            value, err, aged = e["value"], e["error"], e.get("error_with_age", math.nan)
            if name == "l":
                name, value, err, aged = "l / d", value / params["d"], err / params["d"], aged / params["d"]
            rows.append({"group": model, "parameter": name, "value": value, "error": err,
                         "error with the creep's age": aged, "fitted on": e["fitted_on"]})
    for name, e in params.get("normal_stresses", {}).items():
        rows.append({"group": "normal stresses", "parameter": name, "value": e["value"], "error": e["error"],
                     "fitted on": e["fitted_on"]})
    residuals = pd.DataFrame([{"model": m, **r} for m, r in params.get("nonlocal_fit_residuals", {}).items()])
    runs = ", ".join(params.get("calibration_runs", []))
    return ("<h2>Calibration</h2><p class='note'>Local laws from the rheometer bulk (3 d from each wall); "
            "errors are one standard error (covariance of weighted least squares). Reference values: glass beads "
            "mu_s = 0.3819, mu_2 = 0.6435, I_0 = 0.279; frictional spheres mu_s ~ 0.36-0.40, nu_c ~ 0.58-0.59. "
            "mu = |sigma_xz| / p with p one third of the trace everywhere; the models' p is sigma_zz / "
            "(sigma_zz / p of the rheometer), and the walls of every model cell are the planes where the wall "
            "grains' contacts act.</p>"
            + f"<p class='note'>Runs read by this calibration: {html.escape(runs)}.</p>"
            + figures.add("calibration", fig, "Rheometer states and the fitted local laws.")
            + table_html(pd.DataFrame(rows))
            + ("<h3>Non-local fits: residuals by region</h3><p class='note'>RMS of log10(u_model / u_DEM) in decades, "
               "in the shear band (u &gt; 0.1 V) and in the creep below; points weighted by their log error, floored "
               "at 0.1 decade so that the band does not decide the lengths.</p>" + table_html(residuals)
               if not residuals.empty else ""))


# --------------------------------------------------------------------------------- stability
def stability_section(root: Path, figures: Figures) -> str:
    parts = ["<h2>Stability: where methods fail</h2>"]
    wp = pd.read_csv(root / "stability" / "well_posedness.csv")
    # "glass_beads_reference+compressible" -> family "glass_beads_reference", row "local_mu_i (compressible)"
    family = wp.parameter_set.str.split("+").str[0]
    variant = wp.parameter_set.str.split("+").str[1].fillna("")
    wp = wp.assign(family=family, row=wp.model + np.where(variant != "", " (" + variant + ")", ""))
    rows = sorted(wp.row.unique())
    families = sorted(wp.family.unique())
    fig, axes = plt.subplots(1, len(families), figsize=(5.5 * len(families), 0.45 * len(rows) + 1.2),
                             sharey=True, squeeze=False)
    for ax, name in zip(axes[0], families):
        sub = wp[wp.family == name]
        for k, row in enumerate(rows):
            m = sub[sub.row == row]
            ax.scatter(m.I, [k] * len(m), c=np.where(m.well_posed, "tab:green", "tab:red"), s=14, marker="s")
        ax.set_yticks(range(len(rows)), rows, fontsize=7)
        ax.set_xscale("log")
        ax.set_xlabel("inertial number I (-)")
        ax.set_title(f"parameters: {name}", fontsize=9)
    parts.append(figures.add("well_posedness", fig, "Linear stability about simple shear: green well posed (growth bounded as the wavenumber grows), red ill posed."))
    mesh_path = root / "stability" / "mesh_convergence.csv"
    if mesh_path.exists():
        mesh = pd.read_csv(mesh_path)
        fig, ax = plt.subplots(figsize=(6, 4))
        for (case, model), sub in mesh.groupby(["case", "model"]):
            color, ls = MODEL_STYLE.get(model, ("grey", "-"))
            ax.plot(sub.dx, sub.band_width, color=color, ls=ls, marker="o" if case == "shear_gravity" else "^", ms=3,
                    label=f"{model} ({case})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("grid spacing dx (m)")
        ax.set_ylabel("shear-band width, 10-90 % of V (m)")
        ax.legend(fontsize=6)
        parts.append(figures.add("mesh_convergence", fig, "Shear-band width against grid spacing: a width that shrinks with dx is set by the grid, not by the model."))
        summary = mesh.groupby(["case", "model"]).agg(converged=("converged", "last"), finest_band_width=("band_width", "last")).reset_index()
        parts.append(table_html(summary))
    cat_path = root / "stability" / "failure_catalogue.csv"
    if cat_path.exists():
        parts.append("<h3>Failure catalogue</h3>")
        parts.append(table_html(pd.read_csv(cat_path).fillna("")))
    return "\n".join(parts)


# --------------------------------------------------------------------------------------- DEM
def dem_table(runs: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per DEM run: size, cost and the steady window."""
    return pd.DataFrame([{
        "case": r["case"], "run": r["run"], "grains": r["particle_count"],
        "wall speed (m/s)": r["wall_speed"], "wall pressure (Pa)": r["wall_pressure"], "steps": r["steps"],
        "dt (s)": r["time_step"], "LIGGGHTS seconds": r["wall_clock_seconds"], "MPI ranks": r["mpi_ranks"],
        "steady from (s)": r["steady_state_window"][0], "end (s)": r["steady_state_window"][1],
        "max overlap / d": r["max_overlap_over_d"],
        "production strain": r.get("production_strain", float("nan")),
        "production stopped": (r.get("production_stop") or {}).get("reason", "fixed length"),
    } for r in runs])


def dem_cost_table(runs: list[dict[str, Any]], fills: list[dict[str, Any]] = ()) -> pd.DataFrame:
    """Per case: runs, shared fills, particle-steps (grains x steps, fills included) and LIGGGHTS
    core-seconds, and the totals. A fill several runs start from is counted once, in its record."""
    frame = pd.DataFrame(
        [{"case": r["case"], "runs": 1, "shared fills": 0,
          "particle-steps": float(r["particle_count"]) * (float(r["steps"]) + float(r.get("steps_by_stage", {}).get("fill", 0))),
          "core-seconds": float(r["wall_clock_seconds"]) * int(r["mpi_ranks"])} for r in runs]
        + [{"case": f["case"], "runs": 0, "shared fills": 1,
            "particle-steps": float(f["particle_count"]) * float(f["steps_by_stage"]["fill"]),
            "core-seconds": float(f["wall_seconds_by_stage"]["fill"]) * int(f["mpi_ranks"])} for f in fills])
    table = frame.groupby("case", sort=False).sum().reset_index()
    total = pd.DataFrame([{"case": "all", "runs": int(table.runs.sum()), "shared fills": int(table["shared fills"].sum()),
                           "particle-steps": float(table["particle-steps"].sum()), "core-seconds": float(table["core-seconds"].sum())}])
    return pd.concat([table, total], ignore_index=True)


def wall_series_figure(runs: list[dict[str, Any]], figures: Figures) -> str:
    """Wall friction coefficient and wall height against time, steady window shaded: one column of
    small multiples per case, so that each panel holds a few runs."""
    cases = list(dict.fromkeys(r["case"] for r in runs))
    fig, axes = plt.subplots(2, len(cases), figsize=(3.2 * len(cases) + 1, 5.5), squeeze=False)
    for col, case in enumerate(cases):
        ax_mu, ax_h = axes[0, col], axes[1, col]
        for r in (r for r in runs if r["case"] == case):
            files = sorted((r["_dir"] / "series").glob("shear_*.txt")) + sorted((r["_dir"] / "series").glob("production_*.txt"))
            data = pd.concat([read_wall_series(s) for s in files], ignore_index=True).sort_values("time")
            area = r["cell"][0] * r["cell"][1]
            (line,) = ax_mu.plot(data["time"], -data["ftop_x"] / area / r["wall_pressure"], lw=0.7, label=r["run"])
            ax_h.plot(data["time"], (data["h_top"] - data["h_top"].iloc[-1]) / r["d"], lw=0.7, color=line.get_color())
            t0, t1 = r["steady_state_window"]
            ax_mu.axvspan(t0, t1, color=line.get_color(), alpha=0.08)
        ax_mu.set_title(case, fontsize=8)
        ax_h.set_xlabel("time t (s)", fontsize=8)
        if len(ax_mu.get_lines()) <= 8:
            ax_mu.legend(fontsize=5)
    axes[0, 0].set_ylabel("wall shear stress / wall pressure (-)", fontsize=8)
    axes[1, 0].set_ylabel("top-wall height - final, in d (-)", fontsize=8)
    for ax in axes.ravel():
        ax.tick_params(labelsize=6)
    fig.tight_layout()
    return figures.add("wall_series", fig, "Top-wall shear stress over the imposed normal stress, and wall height, "
                       "one column per case; shaded: steady window detected from the data.")


def fields_checks_table(root: Path, config: dict[str, Any]) -> pd.DataFrame:
    rows = []
    for case, run in dem_runs(config):
        ds = open_fields(root / "fields" / case / f"{run}.nc")
        row = {"case": case, "run": run, "snapshots": int(ds.attrs.get("number_of_snapshots", -1))}
        for key, value in ds.attrs.items():
            if (key.startswith("check_") and any(s in key for s in ("balance_", "wall_series_")) and np.isscalar(value)
                    and not key.endswith("_units")):
                row[key[6:]] = float(value)
        rows.append(row)
        ds.close()
    return pd.DataFrame(rows)


def build_report(config: dict[str, Any], figure_dir: Path | None = None) -> str:
    """The whole HTML report."""
    root = Path(config["output_root"])
    figures = Figures(figure_dir)
    runs = load_runs(config)
    params = json.loads((root / "calibration" / "params.json").read_text())
    where = sorted({e["fitted_on"] for entry in params.get("nonlocal", {}).values() for e in entry.values()})
    sections = [
        "<p>How well each continuum rheology reproduces LIGGGHTS DEM of dense granular shear: local mu(I) with "
        "nu(I), local critical-state plasticity, Cosserat plasticity, non-local granular fluidity (NGF) and the "
        "volume-averaged non-local model (Dsouza &amp; Nott), all calibrated on the DEM rheometer.</p>",
        score_section(root, figures, ", ".join(where) or "(not fitted)", config),
        decay_length_section(root, figures) if (root / "validation" / "decay_length.csv").exists() else "",
        profiles_section(root, config, figures),
        intruder_section(root, config, figures) if intruder_cases(config) else "",
        intruder_fields_section(root, config, figures) if intruder_cases(config) else "",
        calibration_section(root, figures),
        wall_section(root, figures),
        pareto_section(root, figures),
        dem_convergence_section(root, config, figures) if convergence_cases(config) else "",
        claims_section(root, figures),
        claims_across_section(root),
        stability_section(root, figures),
        "<h2>DEM runs</h2>",
        "<h3>DEM cost per case</h3>",
        table_html(dem_cost_table(runs, [json.loads(Path(p).read_text()) for p in shared_fill_paths(config)])),
        "<p class='note'>LIGGGHTS, Hertz contacts with tangential history, polydisperse spheres; rough walls "
        "made of grain monolayers. Stiffness and time step follow <code>pipeline/dem/contact_scaling.py</code>.</p>",
        table_html(dem_table(runs)),
        wall_series_figure(runs, figures),
        "<h3>Coarse-graining checks</h3><p class='note'>Momentum balance residuals in the bulk and coarse-grained "
        "stress at the walls against the wall forces LIGGGHTS reports (fractions of p).</p>",
        table_html(fields_checks_table(root, config)),
        "<h3>Error bars against the replica scatter</h3><p class='note'>chi2 = mean over the interior points of "
        "sum_r (x_r - xbar)^2 / err_r^2 / (n - 1), xbar the replicas' inverse-variance mean: 1 when the stated "
        "errors hold. Its degrees of freedom count the independent points from the residuals' correlation length "
        "along z (correlation_points); chi2_err = sqrt(2 / dof), p_value the chance of a departure from 1 at least "
        "this large if the errors hold.</p>",
        table_html(pd.read_csv(root / "validation" / "error_check.csv")) if (root / "validation" / "error_check.csv").exists() else "",
        creep_resolution_section(root),
        creep_halves_section(root, figures) if creeping_cases(config) else "",
        "<h2>Provenance</h2>",
        table_html(pd.DataFrame(sorted(software_versions().items()), columns=["software", "version"])),
        f"<details><summary>configuration</summary><pre>{html.escape(json.dumps(config, indent=1))}</pre></details>",
    ]
    return page("granular-validate: continuum rheologies against DEM", sections)


def creep_resolution_section(root: Path) -> str:
    """How far down each gravity case's replica mean resolves the creep, and what stops it
    (``validation/creep_resolution.csv``, :func:`pipeline.scoring.creep_resolution.replica_mean_resolution`)."""
    path = root / "validation" / "creep_resolution.csv"
    if not path.exists():
        return ""
    table = pd.read_csv(path)
    means = table[table.run.astype(str).str.startswith("mean of")]
    columns = [c for c in ("case", "run", "decades_best", "slowest_over_v_best", "deepest_interior_over_d",
                           "decades_in_bed", "limited_by", "role", "decades_target", "target_met", "target_depth_over_d",
                           "error_over_needed", "replicas_for_target") if c in means and means[c].notna().any()]
    return ("<h3>Creep resolved by the replica means</h3><p class='note'>Decades of u_x / V resolved above twice "
            "the replica mean's error, walking down from the top wall, and the slowest u_x / V resolved. What stops "
            "the walk: <i>wall margin</i> (the deepest point inside the walls' margin is resolved: the bed holds no "
            "more, decades_in_bed), <i>stated errors</i> (the replicas' combined time errors: a longer production or "
            "more replicas resolve deeper), <i>replica scatter</i> (only more replicas do). Against the config's target "
            "(<code>scoring.creep_decades</code>): the depth where the mean is that many decades below its fastest "
            "point, the factor by which its error would have to fall for every point down there to be resolved "
            "(error_over_needed, below 1 where the target is met) and the replicas that factor asks for, n times its "
            "square (nan where the bed is too shallow for the target). Per run: "
            "<code>validation/creep_resolution.csv</code>.</p>" + table_html(means[columns]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Write the comparison report (self-contained HTML).")
    parser.add_argument("--config", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--figures", type=Path, help="folder for the figures as PNG files")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    out = Path(args.out)
    atomic.write_text(build_report(config, args.figures), out)
    return 0
