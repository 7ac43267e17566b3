"""The report's section on the verdict against the DEM it had (issue 57, item 2).

Reads ``validation/claims_cost.csv`` and ``validation/claims_cost_pairs.csv`` (written by
``python -m pipeline.scoring claims-cost``, :mod:`pipeline.scoring.claims_cost`); empty without them.
"""
from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import pandas as pd

from pipeline.report.html import table_html
from pipeline.scoring.claims_cost import MODELS_FIXED, claims_figure

SHOWN = ["case", "variant", "replicas", "dem_core_hours", "dem_core_hours_full", "claims_full", "confirmed", "lost",
         "contradicted", "new", "unscored"]


def case_sentences(table: pd.DataFrame) -> list[str]:
    """Per case: the cheapest variant that keeps every claim and contradicts none, and what the
    cheapest variant of all keeps."""
    out = []
    for case, sub in table.groupby("case", sort=True):
        sub = sub.sort_values("dem_core_hours")
        full = sub[sub.variant == "full"]
        total = float(sub.dem_core_hours_full.iloc[0])
        claims = int(sub.claims_full.iloc[0])
        whole = sub[(sub.variant != "full") & (sub.confirmed == sub.claims_full) & (sub.contradicted == 0)]
        cheapest = sub[sub.variant != "full"].head(1)
        text = f"{case}: the full root tells {claims} pairs apart with {total:.3g} core-hours of DEM"
        if len(full) and int(full.confirmed.iloc[0]) != claims:
            text += f" (today's scoring of the same DEM confirms {int(full.confirmed.iloc[0])} of them)"
        if len(whole):
            r = whole.iloc[0]
            text += f"; every one stands with {r.variant} ({r.dem_core_hours:.3g} core-hours, {r.dem_core_hours / total:.0%})"
            if int(r.replicas) == 1 < int(sub.replicas.max()):
                text += " (one replica: narrower intervals than two give)"
        else:
            text += "; no cheaper variant keeps them all"
        if len(cheapest):
            r = cheapest.iloc[0]
            text += (f"; the cheapest, {r.variant} ({r.dem_core_hours / total:.0%}), confirms {int(r.confirmed)}, "
                     f"loses {int(r.lost)}, contradicts {int(r.contradicted)} and adds {int(r.new)}")
        out.append(text + ".")
    return out


def claims_section(root: Path, figures: Any) -> str:
    """HTML of the section: the chart, a sentence per case, the table and the contradicted claims."""
    path = root / "validation" / "claims_cost.csv"
    if not path.exists():
        return ""
    table = pd.read_csv(path)
    if table.empty:
        return ""
    pairs_path = root / "validation" / "claims_cost_pairs.csv"
    contradicted = pd.DataFrame()
    if pairs_path.exists():
        pairs = pd.read_csv(pairs_path)
        contradicted = pairs[pairs.status == "contradicted"]
    text = ("<h2>The verdict against the DEM it had</h2><p class='note'>Each claim of "
            "<code>validation/model_differences.csv</code> (a pair of models told apart at the confidence, and "
            "which is better) judged again with less DEM: every production cut to its first 1/8, 1/4 or 1/2 "
            "(re-coarse-grained from the dumps it wrote; the rods' speeds over the same prefix), or fewer replicas. "
            f"The {html.escape(MODELS_FIXED)}: only the DEM references change. Confirmed: told apart the same way; "
            "lost: the variant cannot tell the pair apart (or cannot score it); contradicted: told apart the other "
            "way; new: told apart where the full root cannot (with one replica, or a short window, these are not "
            "evidence: one replica's u_dem is its stated errors alone). Cost: the case's LIGGGHTS core-hours, the fill and "
            "the shear to steady state in full, the production scaled by the part kept "
            "(<code>python -m pipeline.scoring claims-cost</code>; docs/dem_cost.md).</p>"
            + figures.add("claims_cost", claims_figure(table), "Claims held against the DEM core-hours of each "
                          "held-out case: confirmed (filled; circles prefixes, squares fewer replicas, star the "
                          "full root rescored), contradicted (red crosses), new (open); dashed: the full root's.")
            + f"<p>{html.escape(' '.join(case_sentences(table)))}</p>"
            + table_html(table[[c for c in SHOWN if c in table.columns]].round(4)))
    if len(contradicted):
        text += ("<h3>Contradicted claims</h3>"
                 + table_html(contradicted[["case", "variant", "metric", "model_a", "model_b", "claim_full",
                                            "claim_variant"]]))
    return text
