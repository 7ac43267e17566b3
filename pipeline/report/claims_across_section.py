"""The report's line per claim: does it hold in the other roots of ``scoring.compare_roots``
(another contact law, another seed)? Reads ``validation/claims_across_roots.csv``
(:mod:`pipeline.scoring.claims_across_roots`); empty without it."""
from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

from pipeline.report.html import table_html
from pipeline.scoring.claims_across_roots import summary
from pipeline.scoring.claims import TOLD_APART

#: How each status reads in the report's line.
SAYS = {"confirmed": "holds in both", "lost": "lost there (cannot tell apart)", "contradicted": "contradicted there",
        "new": "made there only"}


def claim_lines(table: pd.DataFrame) -> pd.DataFrame:
    """A row per claim: the better and worse model as the claim says, and what the other root says."""
    rows = []
    for r in table.itertuples(index=False):
        claim = r.claim_here if r.claim_here in TOLD_APART else r.claim_other
        better, worse = (r.model_a, r.model_b) if claim == "a_better" else (r.model_b, r.model_a)
        rows.append({"other root": r.other_label, "case": r.case, "metric": r.metric,
                     "claim": f"{better} better than {worse}", "here": r.claim_here, "there": r.claim_other,
                     "holds under both": "yes" if r.holds_in_both else "no", "status": SAYS.get(r.status, r.status)})
    return pd.DataFrame(rows)


def claims_across_section(root: Path) -> str:
    """HTML: the counts per other root and case, then a line per claim."""
    path = root / "validation" / "claims_across_roots.csv"
    if not path.exists():
        return ""
    table = pd.read_csv(path)
    roots = ", ".join(f"{html.escape(str(label))} (<code>{html.escape(str(where))}</code>)"
                      for label, where in table[["other_label", "other_root"]].drop_duplicates().itertuples(index=False))
    text = ("<h2>The claims in another root</h2><p class='note'>Each claim of this root's verdict (a pair of models "
            "told apart at the confidence, <code>validation/model_differences.csv</code>) against the same pair in "
            f"{roots or 'no other root'}: the same claim there (holds in both), cannot tell apart there (lost), the "
            "opposite (contradicted); and the pairs only the other root tells apart. A claim that does not hold under a "
            "second contact law is not a claim about the rheologies alone "
            "(<code>python -m pipeline.scoring claims-across</code>; issue 56).</p>")
    if table.empty:
        return text + "<p>Neither root tells any pair apart.</p>"
    return text + table_html(summary(table)) + table_html(claim_lines(table))
