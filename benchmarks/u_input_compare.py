"""Every score's u_input in two output roots side by side (issue 57, item 1: u_input before and after).

Reads ``scores.csv`` of both roots (the same config's cases, models and metrics), pairs the rows
by (case, model, metric) and prints, per case and model, the range of u_input after / before and
the row with the largest |ln ratio|, then the largest over all finite pairs. A u_input that is
0 in both (a rigid prediction at every draw) or not finite in both is counted apart; one that is 0
or not finite on one side only is listed by name, never folded into a ratio.

Usage: ``python benchmarks/u_input_compare.py BEFORE_ROOT AFTER_ROOT``
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

KEYS = ["case", "model", "metric"]


def paired(before: Path, after: Path) -> pd.DataFrame:
    """The two roots' scores, one row per (case, model, metric) present in both."""
    frames = []
    for root in (before, after):
        path = root / "scores.csv"
        if not path.exists():
            raise SystemExit(f"{path}: missing (a finished output root has scores.csv)")
        scores = pd.read_csv(path)
        missing = {*KEYS, "u_input"} - set(scores.columns)
        if missing:
            raise SystemExit(f"{path}: no column {', '.join(sorted(missing))}")
        frames.append(scores[[*KEYS, "u_input", *(["u_input_method"] if "u_input_method" in scores else [])]])
    both = frames[0].merge(frames[1], on=KEYS, suffixes=("_before", "_after"), how="outer", indicator=True)
    one_side = both[both["_merge"] != "both"]
    if len(one_side):
        print(f"{len(one_side)} scores in one root only: "
              + "; ".join(f"{r.case}/{r.model}/{r.metric} ({r._merge})" for r in one_side.itertuples()))
    return both[both["_merge"] == "both"].drop(columns="_merge")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    args = parser.parse_args(argv)
    both = paired(args.before, args.after)
    a, b = both["u_input_before"].to_numpy(float), both["u_input_after"].to_numpy(float)
    zero = (a == 0) & (b == 0)
    undefined = ~np.isfinite(a) & ~np.isfinite(b)
    usable = np.isfinite(a) & np.isfinite(b) & (a > 0) & (b > 0)
    odd = both[~zero & ~undefined & ~usable]
    both = both.assign(ratio=np.where(usable, b / np.where(usable, a, 1.0), np.nan))
    print(f"{len(both)} scores in both roots: {int(usable.sum())} with a finite positive u_input in both, "
          f"{int(zero.sum())} zero in both (rigid at every draw), {int(undefined.sum())} not finite in both, "
          f"{len(odd)} other")
    for r in odd.itertuples():
        print(f"  {r.case}/{r.model}/{r.metric}: u_input {r.u_input_before!r} -> {r.u_input_after!r}")
    rows = both[usable]
    for (case, model), group in rows.groupby(["case", "model"]):
        worst = group.loc[np.abs(np.log(group["ratio"])).idxmax()]
        print(f"{case:20s} {model:16s} {len(group):3d} scores: after / before {group['ratio'].min():.3g} to "
              f"{group['ratio'].max():.3g}; largest |ln| {worst['metric']} {worst['u_input_before']:.3g} -> {worst['u_input_after']:.3g}")
    if len(rows):
        worst = rows.loc[np.abs(np.log(rows["ratio"])).idxmax()]
        print(f"largest ratio over all: {worst['ratio']:.3g} ({worst['case']}/{worst['model']}/{worst['metric']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
