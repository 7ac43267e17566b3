"""Does each claim of the verdict hold in another output root? (issue 56, item 6)

A claim is a pair of models told apart at the verdict's confidence for one case and metric
(``validation/model_differences.csv``, ``a_better`` or ``b_better``). Another root of the same cases
made with one thing changed (the contact law: ``config/studies/damping_off_liggghts.yaml`` against
the default; or the seed) says of the same pair: the same (``confirmed``), cannot tell apart
(``lost``), the opposite (``contradicted``); a pair only the other root tells apart is ``new``. A claim
that is contradicted, or lost, under a second contact law is a claim about the contact law as much
as about the rheologies.

The comparison is :func:`pipeline.scoring.claims.compare_claims` (the same statuses as the
verdict against less DEM), with this root as the reference. Pairs an infinite score left out of
``model_differences.csv`` are judged from ``verdict.csv`` as there (:func:`pipeline.scoring.claims.claims`).

Usage: ``python -m pipeline.scoring claims-across --root ROOT --other LABEL=ROOT2 [...] --out CSV``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from pipeline.common import atomic
from pipeline.scoring.claims import TOLD_APART, claims, compare_claims

COLUMNS = ["other_label", "other_root", "case", "metric", "model_a", "model_b", "claim_here", "claim_other", "status",
           "holds_in_both"]


def read_claims(root: Path) -> dict[tuple[str, str, str, str], str]:
    """(case, metric, model_a, model_b) -> claim of ``root``'s verdict (``validation/``)."""
    folder = root / "validation"
    for name in ("model_differences.csv", "verdict.csv"):
        if not (folder / name).exists():
            raise FileNotFoundError(f"{folder / name}: not found (is {root} a scored output root?)")
    return claims(pd.read_csv(folder / "model_differences.csv"), pd.read_csv(folder / "verdict.csv"))


def claims_across(here: dict, other: dict, label: str, other_root: str) -> pd.DataFrame:
    """One row per pair either root tells apart (on the case-metrics this root judged):
    each root's claim, the status (module docstring) and whether the claim holds in both."""
    rows = []
    for (case, metric, a, b), (status, claim_other, _) in compare_claims(here, other).items():
        claim_here = here.get((case, metric, a, b), "cannot_tell_apart")
        if claim_here not in TOLD_APART and claim_other not in TOLD_APART:
            continue
        rows.append({"other_label": label, "other_root": other_root, "case": case, "metric": metric, "model_a": a,
                     "model_b": b, "claim_here": claim_here, "claim_other": claim_other or "not_scored",
                     "status": status, "holds_in_both": status == "confirmed"})
    return pd.DataFrame(rows, columns=COLUMNS)


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Counts per other root and case: claims here, confirmed, lost, contradicted, new."""
    out = []
    for (label, case), sub in table.groupby(["other_label", "case"], sort=True):
        counts = sub["status"].value_counts()
        out.append({"other_label": label, "case": case,
                    "claims_here": int(sub["claim_here"].isin(TOLD_APART).sum()),
                    **{s: int(counts.get(s, 0)) for s in ("confirmed", "lost", "contradicted", "new")}})
    return pd.DataFrame(out)


def _other(text: str) -> tuple[str, Path]:
    label, sep, path = text.partition("=")
    if not sep or not label or not path:
        raise argparse.ArgumentTypeError(f"--other {text!r}: LABEL=ROOT wanted")
    return label, Path(path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", required=True, type=Path, help="this output root")
    parser.add_argument("--other", required=True, nargs="+", type=_other, help="LABEL=ROOT of each other root")
    parser.add_argument("--out", required=True, type=Path, help="validation/claims_across_roots.csv")
    args = parser.parse_args(argv)
    here = read_claims(args.root)
    table = pd.concat([claims_across(here, read_claims(path), label, str(path)) for label, path in args.other],
                      ignore_index=True)
    atomic.write_csv(table, args.out)
    with pd.option_context("display.width", 200):
        print(summary(table).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
