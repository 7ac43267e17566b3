"""Do the rods' speeds move when they go into a shared pre-sheared bed? Old design against new.

Two output roots of the same config and seed, one made with ``cases.<case>.shared_bed`` false
(every rod pours its own bed around itself and shears it to steady state: ROOT_OLD) and one with
it true (one bed per replica, sheared once, each rod inserted into it: ROOT_NEW,
``pipeline/dem/sheared_bed.py``). Per condition, a depth of the depth sweep (``D<depth>-r<k>``) or
a push of the force sweep (``D<depth>-F<push>-r<k>``), it prints the replicas' rod speeds U of
both designs, their mean of log10 U with its standard error, and the measured depths.

The stated test, on log10 U (the scores' scale: the intruder's noise and scores are in decades):

- **common shift** (the design's likeliest effect, one on every rod alike: the bed's fabric, the
  rod's placement): per replica, the mean of log10 U over the conditions; the shift is the mean of
  those over the new replicas less that over the old, its error from their scatter (Welch). A
  replica's conditions share its bed in the new design, so this is the error that counts the
  correlation between them. Moved when |shift| > t_0.975 x its error (Welch's degrees of freedom).
- **per condition**: new - old mean log10 U against the pooled replica scatter of every
  condition of both designs (all groups' degrees of freedom), t-test at 0.05 two-sided with
  Bonferroni's correction over the conditions.

Verdict "within the replica scatter" when neither moves. A rod no faster than the rest speed
(``dem.precision.rod_arrest_speed_over_v`` x V) enters at the rest speed, marked in the table (its
log10 U is a bound); a rod the run called arrested for a speed within two errors of zero enters
with its measured speed, marked too. The controls (top wall at rest) are listed apart: arrested or not.
Benchmarks print; they assert nothing.

Usage: ``python benchmarks/shared_bed_check.py ROOT_OLD ROOT_NEW [--case intruder]``
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy import stats

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.common.config import intruder_push, intruder_run  # noqa: E402
from pipeline.dem.intruder_run import rest_speed_of  # noqa: E402


def read_root(root: Path, case: str) -> tuple[dict, list[dict]]:
    """The root's effective config and its intruder case's run records."""
    config_path = root / "config.effective.json"
    if not config_path.is_file():
        raise SystemExit(f"{root}: no config.effective.json (not a workflow output root)")
    config = json.loads(config_path.read_text())
    records = [json.loads(p.read_text()) for p in sorted((root / "dem" / case).glob("D*/run.json"))]
    if not records:
        raise SystemExit(f"{root}: no finished runs of case {case!r} (dem/{case}/D*/run.json)")
    return config, records


def condition(run: str) -> tuple[str, float, float | None, str, bool]:
    """(label, depth, push or None, replica, control) of a run id."""
    depth, control, replica = intruder_run(run)
    push = intruder_push(run)
    label = f"D{depth:g}" + (f"-F{push:g}" if push is not None else "") + ("-control" if control else "")
    return label, depth, push, replica, control


def table(records: list[dict], rest: float) -> dict[str, dict[str, dict]]:
    """label -> replica -> {log_u, u, err, bounded, depth, arrested} for the pushed rods (controls apart)."""
    out: dict[str, dict[str, dict]] = {}
    for r in records:
        label, _, _, replica, _ = condition(r["run"])
        rod = r["intruder"]
        bounded = rod["speed"] <= rest
        out.setdefault(label, {})[replica] = {
            "u": rod["speed"], "err": rod["speed_err"], "bounded": bounded, "arrested": rod["arrested"],
            "log_u": math.log10(max(rod["speed"], rest)) if rest > 0 or rod["speed"] > 0 else math.nan,
            "depth": rod["depth_over_d"]}
    return out


def mean_se(values: list[float]) -> tuple[float, float, int]:
    v = np.asarray(values, dtype=float)
    return float(v.mean()), (float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else math.nan), int(v.size)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root_old", type=Path, help="output root made with shared_bed false (every rod pours its own bed)")
    parser.add_argument("root_new", type=Path, help="output root made with shared_bed true (one sheared bed per replica)")
    parser.add_argument("--case", default="intruder", help="intruder case name (default intruder)")
    parser.add_argument("--alpha", type=float, default=0.05, help="two-sided level of the tests (default 0.05)")
    args = parser.parse_args(argv)
    (config_old, old), (config_new, new) = read_root(args.root_old, args.case), read_root(args.root_new, args.case)
    for name, config, flag in (("old", config_old, False), ("new", config_new, True)):
        if bool(config["cases"][args.case].get("shared_bed", False)) != flag:
            print(f"note: the {name} root's config has shared_bed {config['cases'][args.case].get('shared_bed', False)}, "
                  f"expected {flag}")
    if config_old["seed"] != config_new["seed"]:
        print(f"note: the seeds differ ({config_old['seed']} old, {config_new['seed']} new): replicas are independent either way")
    rest = rest_speed_of(config_old, args.case)
    tables = {"old": table(old, rest), "new": table(new, rest)}
    labels = sorted(set(tables["old"]) | set(tables["new"]), key=lambda s: (("-F" in s), ("control" in s), s))
    moving = [s for s in labels if "control" not in s and s in tables["old"] and s in tables["new"]]

    print(f"rod speeds U (mm/s) per condition; log10 U (U in m/s) mean +- standard error over replicas; depth: measured, in d;"
          f" '<' = at or below the rest speed {rest:.1e} m/s (entered at it); '*' = arrested by the run's rule (within 2 errors of 0)")
    print(f"{'condition':<16} {'design':<4} {'replicas: U +- err (mm/s)':<58} {'mean log10 U':>16} {'depth':>6}")
    for label in labels:
        for design in ("old", "new"):
            reps = tables[design].get(label, {})
            if not reps:
                continue
            cells = " ".join(f"{k}:{'<' if v['bounded'] else ''}{v['u'] * 1e3:.3g}+-{v['err'] * 1e3:.2g}{'*' if v['arrested'] else ''}"
                             for k, v in sorted(reps.items()))
            m, se, _ = mean_se([v["log_u"] for v in reps.values()])
            depth = np.mean([v["depth"] for v in reps.values()])
            print(f"{label:<16} {design:<4} {cells:<58} {m:>8.3f} +- {se:<5.3f} {depth:>6.2f}")

    if not moving:
        print("\nno pushed condition in both roots: nothing to test")
        return 0
    # Pooled replica variance of log10 U over every (condition, design) group with 2 or more replicas.
    groups = [[v["log_u"] for v in tables[d][s].values()] for s in moving for d in ("old", "new")]
    dof = sum(len(g) - 1 for g in groups)
    if dof < 1:
        print("\none replica per condition: no replica scatter to test against")
        return 0
    pooled = math.sqrt(sum((len(g) - 1) * np.var(g, ddof=1) for g in groups if len(g) > 1) / dof)
    crit = stats.t.ppf(1.0 - args.alpha / (2.0 * len(moving)), dof)
    print(f"\nper condition: new - old mean log10 U against the pooled replica scatter {pooled:.3f} decade "
          f"({dof} dof); Bonferroni over {len(moving)} conditions: |t| > {crit:.2f} moves")
    worst = 0.0
    for label in moving:
        a = [v["log_u"] for v in tables["old"][label].values()]
        b = [v["log_u"] for v in tables["new"][label].values()]
        diff = float(np.mean(b) - np.mean(a))
        se = pooled * math.sqrt(1.0 / len(a) + 1.0 / len(b))
        t = diff / se
        worst = max(worst, abs(t))
        print(f"  {label:<14} {diff:+.3f} +- {se:.3f} decade, t = {t:+.2f}, p = {2 * stats.t.sf(abs(t), dof):.3f}"
              f"{'  MOVED' if abs(t) > crit else ''}")
    # The common shift from replica means over the conditions (a replica's conditions share a bed).
    replica_means = {}
    for design in ("old", "new"):
        replicas = sorted(set.intersection(*(set(tables[design][s]) for s in moving)))
        replica_means[design] = [float(np.mean([tables[design][s][k]["log_u"] for s in moving])) for k in replicas]
    a, b = replica_means["old"], replica_means["new"]
    shift_verdict = "untested"
    if len(a) > 1 and len(b) > 1:
        welch = stats.ttest_ind(b, a, equal_var=False)
        va, vb = np.var(a, ddof=1) / len(a), np.var(b, ddof=1) / len(b)
        se = math.sqrt(va + vb)
        nu = (va + vb) ** 2 / (va**2 / (len(a) - 1) + vb**2 / (len(b) - 1))
        shift = float(np.mean(b) - np.mean(a))
        moved = abs(welch.statistic) > stats.t.ppf(1.0 - args.alpha / 2.0, nu)
        shift_verdict = "MOVED" if moved else "within"
        print(f"\ncommon shift over the {len(moving)} conditions (replica means, {len(a)} old and {len(b)} new replicas): "
              f"{shift:+.3f} +- {se:.3f} decade, Welch t = {welch.statistic:+.2f} ({nu:.1f} dof), p = {welch.pvalue:.3f}; "
              f"a shift of {2 * se:.2f} decade would show at about 2 sigma")
    else:
        print("\ncommon shift: needs two replicas or more in each design")
    controls = [s for s in labels if "control" in s]
    for label in controls:
        print(f"\ncontrol {label}: arrested " + "; ".join(
            f"{d} {sum(v['arrested'] for v in tables[d].get(label, {}).values())} of {len(tables[d].get(label, {}))}" for d in ("old", "new")))
    verdict = ("the rods' speeds moved beyond their replica scatter" if worst > crit or shift_verdict == "MOVED"
               else "within the replica scatter (no condition and no common shift moved)" if shift_verdict == "within"
               else "per condition within the replica scatter; common shift untested")
    print(f"\nverdict at {args.alpha:g}: {verdict}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
