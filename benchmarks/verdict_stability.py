"""Benchmark: does the verdict survive a rerun? Two output roots of one config that differ in ``seed`` only.

Run as ``python benchmarks/verdict_stability.py ROOT_A ROOT_B``. Prints, per held-out case and
metric, each root's set of models that cannot be told apart from the best (best first), then every
claim "a better than b" at the verdict's confidence (``validation/model_differences.csv``) made in
either root and what the other root says of the same pair: confirmed (the same claim), lost
(cannot tell apart) or contradicted (the opposite claim): :mod:`pipeline.scoring.claims_across_roots`,
which the workflow runs for ``scoring.compare_roots``. Intervals wide enough to make
every pair a tie would have no contradiction and say nothing, so the claims each root makes are
counted too. It also prints the non-local lengths of both calibrations against their errors.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from pipeline.scoring.claims_across_roots import claims_across  # noqa: E402
from pipeline.scoring.claims import TOLD_APART, claims  # noqa: E402


def read_root(root: Path) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    folder = root / "validation"
    missing = [p for p in (folder / "verdict.csv", folder / "model_differences.csv", root / "calibration" / "params.json")
               if not p.exists()]
    if missing:
        raise SystemExit(f"verdict_stability: {missing[0]}: not found (is {root} a finished output root?)")
    return (pd.read_csv(folder / "verdict.csv"), pd.read_csv(folder / "model_differences.csv"),
            json.loads((root / "calibration" / "params.json").read_text()))


def config_difference(a: dict, b: dict) -> list[str]:
    """Top-level config keys that differ between the two calibrations' configs (besides the root)."""
    ca, cb = a["provenance"]["config"], b["provenance"]["config"]
    return sorted(k for k in set(ca) | set(cb) if k != "output_root" and ca.get(k) != cb.get(k))


def tied_set(frame: pd.DataFrame) -> str:
    best = frame[frame.verdict == "best"]
    tied = frame[frame.verdict == "cannot_tell_apart"].sort_values("value")
    return ", ".join(list(best.model) + list(tied.model)) or "none"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root_a", type=Path)
    parser.add_argument("root_b", type=Path)
    args = parser.parse_args(argv)
    va, da, pa = read_root(args.root_a)
    vb, db, pb = read_root(args.root_b)
    differ = config_difference(pa, pb)
    print(f"A = {args.root_a} (seed {pa['provenance']['config'].get('seed')}), "
          f"B = {args.root_b} (seed {pb['provenance']['config'].get('seed')})")
    if differ != ["seed"]:
        print(f"warning: the configs differ in {differ or 'nothing'}, not in seed only", file=sys.stderr)
    print("\nnon-local parameters (value +- replica-based error; per replica):")
    for model, entry in pa.get("nonlocal", {}).items():
        for name, ea in entry.items():
            eb = pb["nonlocal"][model][name]
            z = (ea["value"] - eb["value"]) / math.hypot(ea["error"], eb["error"])
            print(f"  {model} {name}: A {ea['value']:.4g} +- {ea['error']:.2g}, B {eb['value']:.4g} +- {eb['error']:.2g}: "
                  f"difference {z:+.2f} combined errors")
            if "error_with_age" in ea and "error_with_age" in eb:
                z_aged = (ea["value"] - eb["value"]) / math.hypot(ea["error_with_age"], eb["error_with_age"])
                print(f"      with the creep's age in the errors (+- {ea['error_with_age']:.2g}, +- {eb['error_with_age']:.2g}): "
                      f"{z_aged:+.2f}")
    print("\nper held-out case and metric: models that cannot be told apart from the best (best first)")
    keys = sorted(set(zip(va.case, va.metric)) | set(zip(vb.case, vb.metric)))
    rows = []
    for case, metric in keys:
        fa = va[(va.case == case) & (va.metric == metric)]
        fb = vb[(vb.case == case) & (vb.metric == metric)]
        ta, tb = tied_set(fa), tied_set(fb)
        best_a = fa[fa.verdict == "best"].model.tolist()
        best_b = fb[fb.verdict == "best"].model.tolist()
        overlap = bool(set(ta.split(", ")) & set(tb.split(", ")))
        rows.append({"case": case, "metric": metric, "A": ta, "B": tb,
                     "best": "same" if best_a == best_b else "differs",
                     "sets overlap": "yes" if overlap else "no"})
    table = pd.DataFrame(rows)
    with pd.option_context("display.max_colwidth", 60, "display.width", 200):
        print(table.to_string(index=False))
    ca, cb = claims(da, va), claims(db, vb)
    ab = claims_across(ca, cb, "B", str(args.root_b))
    ba = claims_across(cb, ca, "A", str(args.root_a))
    print(f"\nclaims 'a better than b' at the verdicts' confidence: A makes {sum(v in TOLD_APART for v in ca.values())}, "
          f"B makes {sum(v in TOLD_APART for v in cb.values())} (of {len(da)} and {len(db)} pairs judged)")
    for name, result in (("A's claims in B", ab), ("B's claims in A", ba)):
        mine = result[result.claim_here.isin(TOLD_APART)]
        print(f"  {name}: " + ", ".join(f"{k} {int((mine.status == k).sum())}" for k in ("confirmed", "lost", "contradicted")))
        for r in mine[mine.status == "contradicted"].itertuples():
            better, worse = (r.model_a, r.model_b) if r.claim_here == "a_better" else (r.model_b, r.model_a)
            print(f"    contradicted: {r.case} {r.metric}: {better} better than {worse}")
    contradicted = int((ab.status == "contradicted").sum())
    print(f"\ncontradicted claims: {contradicted}; best model differs in {int((table.best == 'differs').sum())} of "
          f"{len(table)} case-metrics; cannot-tell-apart sets disjoint in {int((table['sets overlap'] == 'no').sum())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
