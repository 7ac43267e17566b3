"""The report's creep-law section: the decay rate of creep against the stress ratio, DEM and models
on the same windows, the fits and the model selection (validation/decay_length*.csv)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from pipeline.report.html import table_html
from pipeline.report.style import MODEL_STYLE

FIT_COLUMNS = ["source", "windows", "n_windows", "beta", "beta_err", "beta_err_jackknife", "beta_half_width", "C",
               "C_err", "chi2_reduced", "delta_chi2",
               "p_value_constant", "delta_aic", "preferred", "mu_over_mu_s_min", "mu_over_mu_s_max"]


def decay_length_section(root: Path, figures: Any) -> str:
    """The decay rate d / xi against mu / mu_s: DEM windows (every planar case) and each model on
    the same windows, with the DEM's fits."""
    folder = root / "validation"
    dem = pd.read_csv(folder / "decay_length.csv")
    models = pd.read_csv(folder / "decay_length_models.csv")
    fits = pd.read_csv(folder / "decay_length_fit.csv")
    params = json.loads((root / "calibration" / "params.json").read_text())
    d, mu_s = float(params["d"]), float(params["local"]["mu_s"]["value"])
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    markers = "os^vD<>"
    for k, (case, sub) in enumerate(dem.groupby("case")):
        ax.errorbar(sub.mu_over_mu_s, sub.slope * d, yerr=sub.slope_err * d, fmt=markers[k % len(markers)], ms=4,
                    color="k", mfc="white" if sub.role.iloc[0] == "held_out" else "k", alpha=0.7,
                    label=f"DEM {case} ({sub.role.iloc[0].replace('_', '-')})")
    for model, sub in models.groupby("model"):
        color, _ = MODEL_STYLE.get(model, ("k", "-"))
        ax.plot(sub.mu_over_mu_s, sub.slope * d, ".", color=color, ms=4, label=f"{model} on the DEM's windows")
    x = np.linspace(max(dem.mu_over_mu_s.min(), 0.05) if len(dem) else 0.3, 0.995, 100)
    for f, style in zip(fits[fits.source == "dem"].itertuples(), ("-", "--")):
        if np.isfinite(getattr(f, "beta", np.nan)):
            ax.plot(x, (mu_s * (1 - x)) ** f.beta / f.C, color="grey", ls=style, lw=2, alpha=0.7,
                    label=f"DEM fit ({f.windows}): beta = {f.beta:.2f}"
                          + (f", 95 % interval +- {f.beta_half_width:.2f}" if np.isfinite(getattr(f, "beta_half_width", np.nan))
                             else f" +- {f.beta_err:.2f} (fit)"))
    ax.axhline(0.0, color="k", lw=0.5)
    if len(dem):
        # The DEM's own range: a fitted law with a negative exponent diverges at yield.
        low = float(np.nanmin(dem.slope * d - dem.slope_err * d))
        high = float(np.nanmax(dem.slope * d + dem.slope_err * d))
        span = high - low if high > low else 1.0
        ax.set_ylim(min(low, 0.0) - 0.1 * span, high + 0.3 * span)
    ax.set_xlabel("local stress ratio mu / mu_s (-)")
    ax.set_ylabel("local creep decay rate d / xi = d (d ln u / dz) (-)")
    ax.legend(fontsize=7)
    scale = float(fits.slope_error_scale.iloc[0]) if "slope_error_scale" in fits and len(fits) else float("nan")
    shown = fits[[c for c in FIT_COLUMNS if c in fits.columns]].astype(object)
    shown = shown.where(pd.notna(shown), "n/a")
    return ("<h2>The decay-length law of creep</h2><p class='note'>Decay rate d / xi = d (d ln u_x / dz) over windows of "
            "1 d below the top contact plane, wherever the creep below the band (u below 0.1 V) is resolved at 2 sigma, the "
            "deep end included (no cut on the slope's significance); slope errors from the fit times "
            f"{scale:.2g}, the replicas' verdict on them (windows of two replicas at one depth). NGF predicts d / xi = "
            "sqrt(mu_s - mu) / A (beta = 1/2); the volume-averaged model, in this project's derivation, d / xi = d / l "
            "(beta = 0). Fits of d / xi = (mu_s - mu)^beta / C below yield, on all windows and without those nearest the "
            "band (u / V at or above 0.01); each model's beta on exactly the same windows; model selection of xi "
            "constant against the power law (delta chi2: the likelihood ratio, one degree of freedom; delta AIC "
            "positive: the power law preferred).</p>"
            + figures.add("decay_length", fig, "Local creep decay rate against the local stress ratio, DEM of every "
                          "planar case with the fits of the power law, and each model on the DEM's windows.")
            + table_html(shown))
