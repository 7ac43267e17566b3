"""The report's intruder section: the rod's speed against depth and against its push, the flow
around it in its frame, whether each rod is steady and the drift apart from the push (run.json of
the intruder runs, models/intruder/*.nc, fields_xz/, validation/force_sweep.csv,
validation/rod_steadiness.csv)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common.config import dem_runs
from pipeline.common.layout import intruder_cases, model_names
from pipeline.models.intruder_drift import drift_table
from pipeline.report.html import table_html
from pipeline.report.style import MODEL_STYLE
from pipeline.scoring.rod_steadiness import HALVES_Z_LIMIT, MIN_TRAVEL_OVER_D, classify


def intruder_section(root: Path, config: dict[str, Any], figures: Any) -> str:
    parts = ["<h2>Intruder: secondary rheology</h2>",
             "<p class='note'>A rod along y (3 d across) pushed along +x by a constant force below its yield force, "
             "held at its depth, in the creeping zone of shear with gravity. Control: the same push with the "
             "top wall at rest. Arrested runs (speed within 2 standard errors of zero, or moved under 0.1 d) "
             "are drawn at the bottom, not as speeds. Each model's speed is its own 2D solution around the rod "
             "where it has a 2D solver (NGF: the fluidity equation coupled to the flow around the rod; the "
             "method column of the model files says which), with the band of its parameter draws (2.5-97.5 %); "
             "dashed: the registry's approximations of a model (ngf_frozen: NGF's far-field fluidity kept around "
             "the rod; the 1D estimates of the other models), never its score (hollow markers: upper bound set "
             "by the fluidity floor; docs/intruder.md).</p>"]
    for case in intruder_cases(config):
        every = [json.loads((root / "dem" / c / r / "run.json").read_text()) for c, r in dem_runs(config) if c == case]
        # The depth sweep here; the force sweep's runs (other pushes at one depth) in their own figure.
        runs = [r for r in every if not r["intruder"].get("force_sweep")]
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        rows = []
        floor = None
        moving = [r["intruder"]["speed"] for r in runs if not r["intruder"]["arrested"] and r["intruder"]["speed"] > 0]
        floor = 0.1 * min(moving) if moving else 1e-9
        for r in runs:
            rod = r["intruder"]
            label = "DEM control (wall at rest)" if rod["control"] else "DEM"
            if rod["arrested"]:
                ax.plot(rod["depth_over_d"], floor, "kv" if rod["control"] else "ko", mfc="none", label=label + ", arrested")
            else:
                ax.errorbar(rod["depth_over_d"], rod["speed"], yerr=2 * rod["speed_err"], fmt="ks", label=label)
            verdict = classify(r)
            rows.append({"run": r["run"], "depth / d": rod["depth_over_d"], "force (N)": rod["force"],
                         "speed (m/s)": rod["speed"], "error": rod["speed_err"], "arrested": str(rod["arrested"]),
                         "travel / d": verdict["travel_over_d"], "steady": verdict["rod_class"]})
        refused = []
        for model in model_names(config):
            path = root / "models" / case / f"{model}.nc"
            if not path.exists():
                continue
            sol = xr.open_dataset(path)
            color, ls = MODEL_STYLE.get(model, ("grey", "-"))
            speeds = np.where(sol.speed.values > 0, sol.speed.values, floor)
            if sol.sizes["depth_over_d"]:
                ax.plot(sol.depth_over_d.values, speeds, color=color, ls=ls, marker="x", label=model)
                band = draws_band(root / "model_draws" / case / f"{model}.nc", sweep=False)
                if band is not None:
                    ax.fill_between(band[0], band[1], band[2], color=color, alpha=0.15, lw=0)
                for label, suffix in json.loads(sol.attrs.get("approximations", "{}")).items():
                    if f"speed_{suffix}" in sol:
                        ax.plot(sol.depth_over_d.values, sol[f"speed_{suffix}"].values, color=color, ls="--",
                                marker="+", label=f"{label} (approximation)")
                if "speed_is_upper_bound" in sol and sol.speed_is_upper_bound.values.any():
                    bound = sol.speed_is_upper_bound.values.astype(bool)
                    ax.plot(sol.depth_over_d.values[bound], speeds[bound], "o", color=color, mfc="none", ms=9)
            for reason in json.loads(sol.attrs.get("refused", "[]")):
                refused.append({"model": model, "refused": reason})
            sol.close()
        ax.set_yscale("log")
        ax.set_xlabel("rod depth below the top wall / d (-)")
        ax.set_ylabel("rod speed (m/s), log axis (bottom: zero / arrested)")
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles))
        ax.legend(unique.values(), unique.keys(), fontsize=7)
        parts.append(figures.add("intruder", fig, f"{case}: rod speed against depth, DEM (2 standard errors) and models."))
        parts.append(rod_frame_figure(root, case, runs, figures))
        parts.append(table_html(pd.DataFrame(rows)))
        parts.append(steadiness_html(root, case))
        parts.append(drift_html(root, config, case, every))
        if any(r["intruder"].get("force_sweep") for r in every):
            parts.append(force_sweep_figure(root, figures, case))
        if refused:
            parts.append(table_html(pd.DataFrame(refused)))
    return "\n".join(parts)


def rod_frame_figure(root: Path, case: str, runs: list[dict[str, Any]], figures: Any) -> str:
    """The DEM flow around the rod, in its frame: u_x minus the rod's speed, one panel per run."""
    # One replica per depth: the panels show the flow's shape, the replicas' speeds are in the table.
    sheared = [r for r in runs if not r["intruder"]["control"] and r["run"].endswith("-r1")]
    fig, axes = plt.subplots(1, len(sheared), figsize=(4.2 * len(sheared), 4.2), squeeze=False, sharey=True)
    for ax, r in zip(axes[0], sheared):
        ds = xr.open_dataset(root / "fields_xz" / case / f"{r['run']}.nc")
        d, V = float(ds.attrs["d"]), float(ds.attrs["wall_speed"])
        x = (ds.x.values - float(ds.attrs["rod_centre_x"])) / d
        z = (ds.z.values - float(ds.attrs["z_bottom_wall"])) / d
        # Where no flowing grains are (the rod) the velocity means nothing.
        empty = ds.rho_body.values < 0.2 * float(np.nanmax(ds.rho_body.values))
        rel = np.where(empty, np.nan, ds.u_x_rel.values / V)
        # Symmetric log colours: the creep around the rod is 1e-4 to 1e-2 of V, the band above it ~1.
        norm = mcolors.SymLogNorm(linthresh=1e-4, vmin=-1.0, vmax=1.0, base=10)
        mesh = ax.pcolormesh(x, z, rel.T, cmap="RdBu_r", norm=norm, shading="nearest")
        ax.set_title(f"{r['run']}: rod {r['intruder']['depth_over_d']:.1f} d below the top", fontsize=9)
        ax.set_xlabel("x from the rod's centre / d (-)")
        fig.colorbar(mesh, ax=ax, label="(u_x - U_rod) / V (-), symlog")
        ds.close()
    axes[0][0].set_ylabel("height above the bottom wall / d (-)")
    return figures.add("intruder_field", fig, "DEM flow around the rod in its frame (x-z coarse-grained fields of "
                       "fields_xz/, also as VTK): velocity along x minus the rod's mean speed, over the wall speed, "
                       "on a symmetric log scale (linear within 1e-4); blank: the rod.")




#: The steadiness table's columns in the report, and their headings.
STEADINESS_COLUMNS = {"run": "run", "depth_over_d": "depth / d", "push_over_yield": "F / F_y",
                      "push_budget_share": "F / (L_x L_y tau_top)",
                      "speed": "U (m/s)", "travel_over_d": "travel / d", "travel_first_half_over_d": "1st half / d",
                      "travel_second_half_over_d": "2nd half / d", "first_half_speed": "U 1st half (m/s)",
                      "second_half_speed": "U 2nd half (m/s)", "halves_z_normal": "halves' z",
                      "rod_class": "class", "reason": "reason"}


def steadiness_html(root: Path, case: str) -> str:
    """Each rod's travel over its production, its halves and its class
    (``validation/rod_steadiness.csv``, :mod:`pipeline.scoring.rod_steadiness`), with the rule; ""
    where the table is not there."""
    path = root / "validation" / "rod_steadiness.csv"
    if not path.exists():
        return ""
    table = pd.read_csv(path)
    table = table[table["case"] == case]
    if table.empty:
        return ""
    shown = table.reindex(columns=list(STEADINESS_COLUMNS)).rename(columns=STEADINESS_COLUMNS)
    shown = shown.astype(object).where(pd.notna(shown), "n/a")
    counts = table.loc[~table.control.astype(bool), "rod_class"].value_counts()
    tally = ", ".join(f"{counts[k]} {k.replace('_', ' ')}" for k in ("steady", "unsteady", "at_rest", "unknown")
                      if k in counts)
    return ("<h3>Is the rod steady? Its travel over the production</h3><p class='note'>A rod's speed U is "
            f"<b>steady</b> when the rod travelled at least {MIN_TRAVEL_OVER_D:g} grain diameter during its "
            f"production <b>and</b> the production's two halves agree (|z| &lt; {HALVES_Z_LIMIT:g}, z the halves' "
            "speed difference over their batch-means errors, read as a normal deviate). Below a grain of travel the "
            "rod has not left the cage of grains it started in: U is the creep of one frozen neighbourhood, and "
            "another replica's neighbourhood gives another U; the halves share that neighbourhood and cannot see "
            "it. The halves see what the travel cannot: a rod still slowing from its start-up or ageing travels "
            "several d at no steady speed. A rod at rest (arrested) is its own class. The depth sweep's score "
            "<code>intruder_speed_log_err</code> uses the steady rods only (its <code>points</code> name the depths "
            "that have one); the moving rods that are not steady are scored apart as "
            "<code>intruder_speed_log_err_unsteady</code>. Sheared rods here: " + (tally or "none") + ". "
            "Travel in grain diameters d along +x (the halves' travels add up to the production's); "
            "F / (L_x L_y tau_top): the push's share of the cell's shear-stress budget, the run's own top-wall stress "
            "tau_top (in the periodic cell the whole push loads the layer below the rod; 0.2 or less is a local push); "
            "<code>validation/rod_steadiness.csv</code>.</p>" + table_html(shown))


def drift_html(root: Path, config: dict[str, Any], case: str, runs: list[dict[str, Any]]) -> str:
    """U - U_drift against the push, where both exist: each model's speed against its own F = 0
    solve at the same depth (``drift_speed``, :mod:`pipeline.models.intruder_drift`), and the DEM's
    where the case has sheared rods at F = 0; a note where no drift is stored."""
    pushed = [r for r in runs if not r["intruder"]["control"] and not r["intruder"]["arrested"]
              and float(r["intruder"].get("force", 1.0)) > 0.0]
    at_zero = [r for r in runs if not r["intruder"]["control"] and float(r["intruder"].get("force", 1.0)) == 0.0]
    rows = []
    for target in sorted({round(float(r["intruder"]["depth_target_over_d"]), 6) for r in pushed}):
        zero = [float(r["intruder"]["speed"]) for r in at_zero
                if round(float(r["intruder"]["depth_target_over_d"]), 6) == target]
        drift = float(np.mean(zero)) if zero else np.nan
        drift_err = float(np.std(zero, ddof=1) / np.sqrt(len(zero))) if len(zero) >= 2 else np.nan
        groups: dict[tuple[bool, float], list[dict]] = {}
        for r in pushed:
            rod = r["intruder"]
            if round(float(rod["depth_target_over_d"]), 6) == target:
                groups.setdefault((bool(rod.get("force_sweep")), round(float(rod.get("push_over_yield", np.nan)), 6)),
                                  []).append(r)
        for (sweep, push), group in sorted(groups.items()):
            speeds = [g["intruder"]["speed"] for g in group]
            u = float(np.mean(speeds))
            u_err = float(np.std(speeds, ddof=1) / np.sqrt(len(speeds))) if len(speeds) >= 2 else np.nan
            steady = sum(classify(g)["steady"] for g in group)
            rows.append({"source": "DEM", "depth / d": float(np.mean([g["intruder"]["depth_over_d"] for g in group])),
                         "F / F_y": push, "U (m/s)": u, "U_drift (m/s)": drift,
                         "U - U_drift (m/s)": u - drift if np.isfinite(drift) else np.nan,
                         "+- (m/s)": float(np.hypot(u_err, drift_err)),
                         "note": f"{len(group)} rod{'s' if len(group) != 1 else ''}, {steady} steady"
                                 + ("" if zero else "; no DEM rod at F = 0")})
    # The depth sweep's push of each depth (the first replica's), to put the models' depths against F.
    depth_push = {round(float(r["intruder"]["depth_over_d"]), 6): float(r["intruder"].get("push_over_yield", np.nan))
                  for r in pushed if not r["intruder"].get("force_sweep")}
    sweep_depth = [float(r["intruder"]["depth_over_d"]) for r in pushed if r["intruder"].get("force_sweep")]
    stored = False
    for model in model_names(config):
        table = drift_table(root / "models" / case / f"{model}.nc")
        if table is None:
            continue
        stored = True
        for t in table.itertuples():
            depth = t.depth_over_d if not t.sweep else (float(np.mean(sweep_depth)) if sweep_depth else np.nan)
            push = t.push_over_yield if t.sweep else next(
                (p for d, p in depth_push.items() if abs(d - t.depth_over_d) <= 0.5), np.nan)
            rows.append({"source": model, "depth / d": depth, "F / F_y": push, "U (m/s)": t.speed,
                         "U_drift (m/s)": t.drift_speed, "U - U_drift (m/s)": t.speed_minus_drift,
                         "note": "own F = 0 solve" + ("" if np.isfinite(t.drift_speed) else ": refused")})
    dem_drift = bool(at_zero)
    if not stored and not dem_drift:
        return ("<p class='note'>The drift (the rod's speed at F = 0, carried by the creep alone) is not stored yet: "
                "no model file holds its own F = 0 solve (<code>drift_speed</code>, "
                "<code>pipeline/models/intruder_drift.py</code>) and no DEM rod is sheared at F = 0, so U - U_drift "
                "cannot be drawn.</p>")
    frame = pd.DataFrame(rows)
    # Per push the DEM first, then the models in the config's order.
    frame = frame.assign(_dem=frame.source != "DEM").sort_values(["F / F_y", "_dem"], kind="stable").drop(columns="_dem")
    frame = frame.astype(object).where(pd.notna(frame), "n/a")
    return ("<h3>The drift and the push apart</h3><p class='note'>U_drift: the rod's speed at the same depth with no "
            "push (the creep of the bed carries it): each model's own F = 0 solve, the DEM's sheared rods at F = 0 "
            "where the case has them. U - U_drift is what the push adds; n/a where either is missing or refused. "
            "The DEM's U is the mean of its moving rods (the note says how many are steady); +-: the standard error "
            "of U - U_drift from the replicas' scatter of each (the models' own solves have none here: their draws "
            "are in the score tables).</p>" + table_html(frame))


def draws_band(path: Path, sweep: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(x, 2.5 %, 97.5 %) of a model's speed over its parameter draws (model_draws/<case>/<model>.nc):
    x the depth / d of the depth sweep's scenes, or F / F_y of the force sweep's; None without draws."""
    if not path.exists():
        return None
    with xr.open_dataset(path) as ens:
        if "force_sweep" not in ens or ens.sizes.get("draw", 0) < 2:
            return None
        pick = ens.force_sweep.values.astype(bool) == sweep
        x = (ens.push_over_yield if sweep else ens.depth_over_d).values[pick]
        speeds = ens.speed.values[:, pick]
    if not x.size or not np.isfinite(speeds).any(axis=0).all():
        return None
    order = np.argsort(x)
    lo, hi = np.nanpercentile(speeds, [2.5, 97.5], axis=0)
    return x[order], lo[order], hi[order]


def force_sweep_figure(root: Path, figures: Any, case: str = "intruder") -> str:
    """U against F / F_y at the sweep's depth: DEM (replica means, 2 standard errors) and every model
    with the band of its parameter draws, ngf_frozen beside NGF, and the slope table
    (validation/force_sweep.csv)."""
    table = pd.read_csv(root / "validation" / "force_sweep.csv")
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    dem = table[(table.source == "dem") & table.push_over_yield.notna()]
    ax.errorbar(dem.push_over_yield, dem.speed, yerr=2 * dem.speed_err, fmt="ks", label="DEM (replica mean)")
    for model, sub in table[(table.source != "dem") & table.push_over_yield.notna()].groupby("source"):
        color, ls = MODEL_STYLE.get(model, ("grey", "-"))
        good = sub[sub.speed > 0]
        if len(good):
            ax.plot(good.push_over_yield, good.speed, color=color, ls=ls, marker="x", label=model)
        band = draws_band(root / "model_draws" / case / f"{model}.nc", sweep=True)
        if band is not None:
            ax.fill_between(band[0], band[1], band[2], color=color, alpha=0.15, lw=0)
        path = root / "models" / case / f"{model}.nc"
        if path.exists():
            with xr.open_dataset(path) as sol:
                for label, suffix in json.loads(sol.attrs.get("approximations", "{}")).items():
                    if f"sweep_speed_{suffix}" in sol:
                        ax.plot(sol.push_over_yield.values, sol[f"sweep_speed_{suffix}"].values, color=color,
                                ls="--", marker="+", label=f"{label} (approximation)")
    ax.set_yscale("log")
    ax.set_xlabel("push / yield force at the rod's depth, F / F_y (-)")
    ax.set_ylabel("rod speed (m/s), log axis")
    ax.legend(fontsize=7)
    slopes = table[table.push_over_yield.isna()].drop(columns=[c for c in ("push_over_yield", "speed", "speed_err",
                                                                           "replicas", "resolved", "steady_replicas",
                                                                           "unsteady_replicas", "at_rest_replicas")
                                                               if c in table])
    slopes = slopes.astype(object).where(pd.notna(slopes), "n/a")
    return (figures.add("intruder_force", fig, "The rod's speed against its push at one depth (the force sweep, held "
                        "out): DEM replica means with 2 standard errors (the replicas' scatter), each model's speed with "
                        "the 2.5-97.5 % band of its parameter draws, and ngf_frozen (dashed, an approximation). "
                        "Zero speeds (rod at rest) are not drawn.")
            + "<p class='note'>Slope of log10 U against F / F_y, each model's against the DEM's: the slope excludes "
              "a model where their difference exceeds its 95 % interval (u_val: the DEM replicas' and the "
              "calibration's uncertainty).</p>" + table_html(slopes))
