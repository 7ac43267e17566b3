"""The report's opening: predictions on held-out cases, which models can be told apart, and what
each scene needs; then the fit quality on the calibration cases.

Reads ``scores.csv`` and ``validation/{verdict,scene_needs}.csv`` (pipeline.scoring writes them,
with their uncertainty and the paired comparisons); computes nothing of its own but the layout.
"""
from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from pipeline.report.html import table_html
from pipeline.report.style import MODEL_STYLE
from pipeline.scoring.verdict import SCENE_METRICS

#: Metrics shown first in the per-case tables and drawn in the forest plot.
HEADLINE_METRICS = ("log_velocity_rmse", "velocity_rmse_rel", "decay_length_rel_err", "shear_band_width_rel_err",
                    "intruder_speed_log_err", "nu_rmse", "mu_rmse")
VERDICT_COLOUR = {"best": "background:#a8e0a8", "cannot_tell_apart": "background:#d6f2d6",
                  "worse": "background:#f6c6c6", "no_prediction": ""}


def _pm(value: float, u: float) -> str:
    if not math.isfinite(value):
        return "inf (no creep predicted)" if value > 0 else "n/a"
    return f"{value:.3g} +- {u:.2g}" if math.isfinite(u) else f"{value:.3g}"


def _noise(score: pd.Series) -> str:
    """A score row's DEM noise floor (the replica-pair mean of the metric) with its own standard
    error over the pairs and their count: a floor from one pair has no error of its own."""
    noise = float(score.get("dem_noise", np.nan))
    if not np.isfinite(noise):
        return "n/a: one replica"
    err, pairs = float(score.get("dem_noise_err", np.nan)), score.get("dem_noise_pairs", np.nan)
    pairs_text = f", {int(pairs)} pairs" if pd.notna(pairs) else ""
    return (f"{noise:.3g} +- {err:.2g}{pairs_text}" if np.isfinite(err) else f"{noise:.3g}{pairs_text}")


def headline_table(verdicts: pd.DataFrame, scores: pd.DataFrame) -> pd.DataFrame:
    """Per held-out case and metric: the models that cannot be told apart from the best at the
    verdict's confidence, the worse ones, the best's u_val and its parts, and the DEM noise."""
    rows = []
    for (case, metric), frame in verdicts.groupby(["case", "metric"], sort=True):
        best = frame[frame.verdict == "best"]
        if best.empty:
            continue
        b = best.iloc[0]
        tied = frame[frame.verdict == "cannot_tell_apart"].sort_values("value")
        worse = frame[frame.verdict == "worse"].sort_values("value")
        none = frame[frame.verdict == "no_prediction"]
        score_rows = scores[(scores.case == case) & (scores.metric == metric)]
        shown_metric = metric if str(b.points).endswith("z points") else f"{metric} (on {b.points})"
        rows.append({
            "case": case, "metric": shown_metric,
            "cannot be told apart (best first)": "; ".join([f"{b.model} {_pm(b.value, b.u_val)}"]
                                                            + [f"{r.model} {_pm(r.value, r.u_val)}" for r in tied.itertuples()]),
            "worse": "; ".join(f"{r.model} {_pm(r.value, r.u_val)}" for r in worse.itertuples()) or "none",
            "best's u_dem / u_input / u_num": f"{b.u_dem:.2g} / {b.u_input:.2g} / {b.u_num:.2g}",
            "DEM noise (+- its error, pairs)": _noise(score_rows.iloc[0]) if len(score_rows) else "n/a: one replica",
            "not predicted by": ", ".join(sorted(none.model)) or "none",
        })
    table = pd.DataFrame(rows).astype(object)
    return table.where(pd.notna(table), "n/a")


def case_table(frame: pd.DataFrame, verdicts: pd.DataFrame | None) -> str:
    """Model x metric scores of one case, value +- u_val, coloured by the verdict where there is one."""
    metrics = [m for m in HEADLINE_METRICS if m in set(frame.metric)] + sorted(set(frame.metric) - set(HEADLINE_METRICS))
    models = sorted(set(frame.model))
    by = {(r.model, r.metric): r for r in frame.itertuples()}
    judged = {} if verdicts is None else {(r.model, r.metric): r.verdict for r in verdicts.itertuples()}
    rows, styles = [], []
    for model in models:
        row, style = {"model": model}, [""]
        for metric in metrics:
            r = by.get((model, metric))
            row[metric] = "not predicted" if r is None else _pm(r.value, r.u_val)
            style.append(VERDICT_COLOUR.get(judged.get((model, metric), ""), ""))
        rows.append(row)
        styles.append(style)
    noise = frame.groupby("metric").first()
    rows.append({"model": "DEM noise (replica vs replica, +- its error, pairs)"}
                | {m: (_noise(noise.loc[m]) if m in noise.index else "n/a: one replica") for m in metrics})
    styles.append([""] * (len(metrics) + 1))
    return table_html(pd.DataFrame(rows, columns=["model", *metrics]), cell_style=styles, css_class="scores")


def forest_figure(verdicts: pd.DataFrame, scores: pd.DataFrame, replicas: dict[str, int]) -> plt.Figure:
    """Per held-out case and headline metric: each model's score with its 95 % interval
    (+- 1.96 u_val), the DEM's own floor marked (the replica-pair noise over sqrt(2 n), the
    uncertainty of a mean of n replicas)."""
    panels = [(c, m) for (c, m), _ in verdicts.groupby(["case", "metric"], sort=True) if m in HEADLINE_METRICS]
    ncols = 3
    nrows = max(1, math.ceil(len(panels) / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.6 * ncols, 2.6 * nrows), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, (case, metric) in zip(axes.flat, panels):
        frame = verdicts[(verdicts.case == case) & (verdicts.metric == metric)].sort_values("model")
        for y, r in enumerate(frame.itertuples()):
            colour = MODEL_STYLE.get(r.model, ("k", "-"))[0]
            if np.isfinite(r.value):
                half = 1.96 * r.u_val if np.isfinite(r.u_val) else 0.0
                ax.errorbar([r.value], [y], xerr=[[min(half, r.value * 0.999) if r.value > 0 else half], [half]],
                            fmt="o", color=colour, capsize=3)
            else:
                ax.annotate("inf" if r.verdict != "no_prediction" else "none", (1.0, y), xycoords=("axes fraction", "data"),
                            ha="right", va="center", fontsize=7, color=colour)
        noise = scores[(scores.case == case) & (scores.metric == metric)]["dem_noise"]
        n = replicas.get(case, 1)
        if len(noise) and np.isfinite(noise.iloc[0]) and n > 1:
            ax.axvline(float(noise.iloc[0]) / math.sqrt(2 * n), color="grey", ls="--", lw=1)
        ax.set_yticks(range(len(frame)))
        ax.set_yticklabels([f"{r.model} ({r.verdict.replace('_', ' ')})" for r in frame.itertuples()], fontsize=7)
        finite = frame.value[np.isfinite(frame.value)]
        if len(finite) and (finite > 0).all() and finite.max() / finite.min() > 20:
            ax.set_xscale("log")
        ax.set_title(f"{case}: {metric}", fontsize=8)
        ax.tick_params(axis="x", labelsize=7)
    fig.tight_layout()
    return fig


def scene_table(scene: pd.DataFrame) -> pd.DataFrame:
    shown = scene.rename(columns={"simplest_model": "simplest adequate model", "next_model": "next richer model",
                                  "next_adds": "what it would add", "simplest_solve_ms": "its solve (ms)",
                                  "next_solve_ms": "next's solve (ms)", "metrics": "judged on"})
    shown = shown.astype(object)
    return shown.where(pd.notna(shown) & (shown != ""), "none")


def config_has_validation_cases(config: dict[str, Any]) -> bool:
    from pipeline.common.config import validation_cases

    return bool(validation_cases(config))


def score_section(root: Path, figures: Any, nonlocal_where: str, config: dict[str, Any]) -> str:
    scores = pd.read_csv(root / "scores.csv")
    verdicts = pd.read_csv(root / "validation" / "verdict.csv")
    scene = pd.read_csv(root / "validation" / "scene_needs.csv")
    held, fitted = scores[scores.role == "held_out"], scores[scores.role == "calibration"]
    confidence = float(verdicts.confidence.iloc[0]) if len(verdicts) else 0.95
    parts = ["<h2>Predictions on held-out cases</h2>",
             "<p class='note'>Every parameter frozen from the calibration runs (the rheometer, and "
             f"<b>{html.escape(nonlocal_where)}</b> for the non-local lengths); these cases fed no fit. Each value is "
             "the metric between the model and the mean of the DEM replicas, +- its validation uncertainty u_val "
             "(V&amp;V 20: the DEM mean's u_dem, the calibration's u_input over the parameter draws, the grid's u_num; "
             "docs/validation.md). Models are told apart by the paired difference of their scores, with an interval "
             f"at {confidence:.0%} (the same DEM resample and parameter draw in both): dark green the best, light green "
             "those that cannot be told apart from it, red the worse ones. The DEM noise row is the metric between two "
             "single replicas.</p>"]
    if held.empty:
        parts.append("<p><b>No held-out score in this config</b>: every score below is calibration quality.</p>")
        if config_has_validation_cases(config):
            fig = plt.figure(figsize=(4, 1))
            fig.text(0.5, 0.5, "no held-out score", ha="center")
            parts.append(figures.add("verdict", fig, "No held-out case was scored."))
    else:
        judged = verdicts.metric.isin(SCENE_METRICS)
        parts.append(f"<h3>Which models cannot be told apart from the best ({confidence:.0%})</h3>"
                     "<p class='note'>Creep and flow metrics (every other in the table below it). Values +- u_val; "
                     "'DEM noise': the metric between two single replicas.</p>"
                     + table_html(headline_table(verdicts[judged], held), css_class="scores")
                     + "<details><summary>the other metrics (solid fraction, stress ratio, fluidity)</summary>"
                     + table_html(headline_table(verdicts[~judged], held), css_class="scores") + "</details>")
        replicas = {case: int(spec.get("replicas", 1)) for case, spec in config["cases"].items()}
        parts.append(figures.add("verdict", forest_figure(verdicts, held, replicas),
                                 "Each model's held-out score with its 95 % interval (+- 1.96 u_val); dashed: the DEM's "
                                 "own floor, the replica-pair noise over sqrt(2 n) for n replicas. 'inf': no creep "
                                 "predicted where the DEM creeps."))
        parts.append("<h3>What each scene needs</h3><p class='note'>The simplest model (in the order of "
                     "docs/models.md: fields solved, lengths fitted, cost) that cannot be told apart from the best on "
                     "every creep and flow metric of the case, and what the next richer model would add.</p>"
                     + table_html(scene_table(scene), css_class="scores"))
        for case, frame in held.groupby("case"):
            parts.append(f"<h3>{html.escape(case)} (held out)</h3>" + case_table(frame, verdicts[verdicts.case == case]))
    parts.append("<h2>Fit quality on the calibration cases</h2><p class='note'>These cases' runs fed the "
                 "calibration: the non-local models' scores here measure how well they can be fitted, not how "
                 "well they predict.</p>")
    for case, frame in fitted.groupby("case"):
        parts.append(f"<h3>{html.escape(case)} (calibration)</h3>" + case_table(frame, None))
    cost = scores.groupby(["case", "model"])[["solve_seconds", "n_grid"]].first().reset_index()
    parts.append("<details><summary>model solve cost per case</summary>" + table_html(cost) + "</details>")
    return "\n".join(parts)
