"""The report's section on the wall: what the rough DEM wall does, and what each model's wall does.

Reads ``calibration/params.json`` (``wall``: the slip length the models take and both of its
measurements) and ``validation/wall.csv`` (the planar cases' top wall, DEM and models; written by
the scoring stage, :mod:`pipeline.scoring.wall_scores`).
"""
from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from pipeline.report.html import table_html


def slip_figure(params: dict[str, Any]):
    """The rheometer states' slip length against I, the calibrated value's band, and the
    calibration case's top wall."""
    wall, d = params["wall"], float(params["d"])
    states = pd.DataFrame(wall["rheometer"]["states"])
    fig, ax = plt.subplots(figsize=(7, 3.6))
    used = states["used"].astype(bool) if "used" in states else np.ones(len(states), dtype=bool)
    ax.errorbar(states["I"][used], states["slip_length"][used] / d, yerr=states["slip_length_err"][used] / d, fmt="o",
                color="C0", label="rheometer runs: (s_top + s_bottom) / (2 gammadot)")
    if (~used).any():
        ax.errorbar(states["I"][~used], states["slip_length"][~used] / d, yerr=states["slip_length_err"][~used] / d,
                    fmt="o", mfc="none", color="C0", alpha=0.6, label="left out: quasi-static or not homogeneous")
    rheo = wall["rheometer"]
    if math.isfinite(rheo["value"]):
        ax.axhspan((rheo["value"] - rheo["error"]) / d, (rheo["value"] + rheo["error"]) / d, color="C0", alpha=0.2,
                   label=f"rheometer mean {rheo['value'] / d:.3f} +- {rheo['error'] / d:.3f} d")
    case = wall.get("calibration_case") or {}
    if math.isfinite(case.get("value", math.nan)):
        err = case.get("error", math.nan)
        ax.axhspan((case["value"] - (err if math.isfinite(err) else 0)) / d,
                   (case["value"] + (err if math.isfinite(err) else 0)) / d, color="C1", alpha=0.25,
                   label=f"calibration case's top wall {case['value'] / d:.3f} +- {err / d:.3f} d")
    ax.axhline(wall["slip_length"]["value"] / d, color="k", lw=1, label=f"the models' b ({wall['slip_length']['fitted_on']})")
    ax.set_xscale("log")
    ax.set_xlabel("inertial number I (-)")
    ax.set_ylabel("Navier slip length b / d (-)")
    ax.legend(fontsize=7)
    return fig


def wall_section(root: Path, figures: Any) -> str:
    """HTML of the wall section (empty where the calibration has no wall entry)."""
    params = json.loads((root / "calibration" / "params.json").read_text())
    if "wall" not in params:
        return ""
    wall, d = params["wall"], float(params["d"])
    rheo, case = wall["rheometer"], wall.get("calibration_case") or {}
    trend = rheo["inertial_trend"]
    z = wall.get("z_calibration_case_minus_rheometer", math.nan)
    text = (
        "<h2>The wall</h2><p class='note'>The models' walls are the DEM's contact planes. The DEM's rough walls "
        "do not carry the bed's grains at their own speed: the grains at the contact plane lag the wall by the "
        "<em>slip</em> s. The models take a Navier slip length b (the grains at a wall move relative to it by "
        "b times the shear rate there), measured on the calibration set only "
        f"(<code>calibration.wall_slip</code> = {html.escape(str(wall['source']))}): "
        f"<b>b = {wall['slip_length']['value'] / d:.3f} +- {wall['slip_length']['error'] / d:.3f} d</b>. "
        f"Rheometer: {rheo['value'] / d:.3f} +- {rheo['error'] / d:.3f} d over {rheo['dof'] + 1} runs "
        f"(reduced chi2 {rheo['chi2_reduced']:.2f}; slope against log10 I {trend['slope_per_decade'] / d:+.3f} d per "
        f"decade, {trend['z']:+.1f} errors). Calibration case's top wall: {case.get('value', math.nan) / d:.3f} +- "
        f"{case.get('error', math.nan) / d:.3f} d (difference from the rheometer's {z:+.1f} errors). "
        "A rate-independent model's wall stress does not depend on the wall's slip (critical state, the "
        "volume-averaged model: mu_s p; Cosserat: its couple-stress wall condition): their wall stress error "
        "is theirs. Scores: <code>wall_shear_stress_rel_err</code> and <code>wall_slip_err</code> "
        "in <code>scores.csv</code>; the table below is <code>validation/wall.csv</code>.</p>")
    out = text + figures.add("wall_slip", slip_figure(params), "Navier slip length of the DEM walls: the rheometer "
                             "runs against I, their mean, and the calibration case's top wall.")
    path = root / "validation" / "wall.csv"
    if path.exists():
        table = pd.read_csv(path)
        dem = table[table["source"] == "dem"]
        cols = ["case", "role", "replicas", "wall_top_shear_stress", "wall_top_shear_stress_err", "wall_top_slip_over_v",
                "wall_top_slip", "wall_top_slip_err", "wall_top_slip_length_over_d", "wall_friction", "wall_friction_err"]
        out += "<h3>The DEM's top wall (replica means, standard errors from the replicas)</h3>" + table_html(
            dem[[c for c in cols if c in dem.columns]])
        models = table[table["source"] != "dem"]
        cols = ["case", "role", "source", "wall_top_shear_stress", "stress_minus_dem_rel", "stress_minus_dem_over_dem_err",
                "wall_top_slip_over_v", "slip_minus_dem_over_v", "wall_top_slip_length_over_d"]
        out += ("<h3>Each model's top wall against the DEM's</h3><p class='note'>stress_minus_dem_rel = "
                "tau_model / tau_DEM - 1; over_dem_err: the same difference in the DEM mean's standard errors.</p>"
                + table_html(models[[c for c in cols if c in models.columns]].replace([np.inf, -np.inf], np.nan)))
    return out
