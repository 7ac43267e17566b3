"""Benchmark (issue 57, item 4): the x-z contact stress by the Gauss-Legendre rule along each branch
(``pipeline.coarse_graining.plane``, the pipeline's) against the exact line integral for every
contact (``LONG_BRANCH = 0``: the code path every contact took before), side by side in one process
on real rod runs (alternating, CPU seconds by time.process_time; never a test).

For each run folder it prints the CPU of ``rod_frame_fields`` both ways and, for each stress field,
the largest difference from the exact one over its largest magnitude, over its standard error
(bin by bin), and the share of bins where it exceeds 1 % of the standard error. The velocity and
solid fraction do not depend on the rule (reported as a check: 0).

Run: ``python benchmarks/plane_rule.py CONFIG RUN_DIR [RUN_DIR ...] [--repeats 1]``
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pipeline.coarse_graining import plane  # noqa: E402
from pipeline.coarse_graining.rod_frame import rod_frame_fields  # noqa: E402
from pipeline.common.config import load_config  # noqa: E402

FIELDS = ("sigma_xz_contact", "sigma_zx_contact", "sigma_xx", "sigma_zz", "sigma_xz", "p", "mu", "nu", "u_x")


def timed(config: dict, run_dir: Path, long_branch: float):
    plane.LONG_BRANCH = long_branch
    t0 = time.process_time()
    ds = rod_frame_fields(config, run_dir)
    return time.process_time() - t0, ds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", type=Path)
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    if not args.config.is_file():
        parser.error(f"config: {args.config}: no such file")
    for run in args.runs:
        if not (run / "run.json").is_file():
            parser.error(f"run: {run}: no run.json (a run folder of an intruder case, RESULTS/dem/intruder/RUN)")
    config = load_config(args.config)
    rule = plane.LONG_BRANCH
    print(f"rule: {plane.CONTACT_POINTS} Gauss-Legendre points, branches over {rule} w exact")
    totals = {"exact": 0.0, "rule": 0.0}
    for run in args.runs:
        for rep in range(args.repeats):
            order = (("exact", 0.0), ("rule", rule)) if rep % 2 == 0 else (("rule", rule), ("exact", 0.0))
            got = {name: timed(config, run, lb) for name, lb in order}
            for name in got:
                totals[name] += got[name][0]
            print(f"{run.name}: CPU exact {got['exact'][0]:.1f} s, rule {got['rule'][0]:.1f} s, "
                  f"ratio {got['exact'][0] / got['rule'][0]:.2f}")
        exact, ruled = got["exact"][1], got["rule"][1]
        for v in FIELDS:
            x, y, err = ruled[v].values, exact[v].values, exact[v + "_err"].values
            ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(err) & (err > 0)
            d = np.abs(x - y)[ok]
            scale = float(np.abs(y[ok]).max()) or 1.0
            print(f"  {v:18s} max|d|/max|exact| {d.max() / scale:.1e}  max|d|/err {np.max(d / err[ok]):.3f}  "
                  f"bins over 0.01 err {np.mean(d / err[ok] > 0.01):.4f}")
    plane.LONG_BRANCH = rule
    print(f"total CPU s: exact {totals['exact']:.1f}, rule {totals['rule']:.1f}, "
          f"ratio {totals['exact'] / totals['rule']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
