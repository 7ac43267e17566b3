"""The report's check that the planar creep is steady: each run's production, first half against
second half (``validation/creep_halves.csv``, :func:`pipeline.scoring.scalar_checks.creep_halves`)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import pandas as pd

from pipeline.report.html import table_html
from pipeline.scoring.scalar_checks import STEADY_BEYOND_TWO, beyond_two, halves_by_run


def creep_halves_section(root: Path, figures: Any) -> str:
    """Per planar case a panel of each run's log10 change between the production's halves against
    depth, with its 2-sigma band, and the per-run table; empty without the file or its planar rows."""
    path = root / "validation" / "creep_halves.csv"
    if not path.exists():
        return ""
    halves = pd.read_csv(path)
    halves = halves[halves.case != "intruder"]
    if halves.empty:
        return ""
    cases = sorted(halves.case.unique())
    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.8), sharey=True, squeeze=False)
    for ax, case in zip(axes[0], cases):
        for k, (run, sub) in enumerate(halves[halves.case == case].groupby("run", sort=True)):
            ax.errorbar(sub.depth_over_d + 0.08 * k, sub.log10_change, yerr=2.0 * sub.log10_change_err, fmt="o-",
                        ms=3, lw=0.8, capsize=2, label=f"{run}")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_title(case, fontsize=9)
        ax.set_xlabel("depth below the top contact plane (d)")
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("log10 (u second half / u first half), +- 2 sigma")
    table = halves_by_run(halves)
    total_beyond, known = beyond_two(halves)
    total_expected = STEADY_BEYOND_TWO * known
    return ("<h3>Is the creep steady? The production's halves</h3><p class='note'>Each planar run's displacement "
            "creep speed over the second half of its production against the first, at every whole d below the top "
            "contact plane where both halves are resolved; error bars 2 sigma of the halves' time errors (the "
            "packing, common to both halves, cancels). A steady run scatters about zero with "
            f"{100 * STEADY_BEYOND_TWO:.1f} % of its depths beyond 2 (normal-equivalent z of each depth's Student t): here {total_beyond} beyond 2 against "
            f"{total_expected:.1f} expected. Negative: the creep slowed during the production (the deep creep "
            "ages as the bed compacts: docs/dem.md). Per depth: <code>validation/creep_halves.csv</code>.</p>"
            + figures.add("creep_halves", fig, "Production halves of each planar run: log10 of the second half's creep "
                          "speed over the first's against depth, with 2-sigma bars.")
            + table_html(table))
