"""Is the steady-state test's window as steady as the production after it? Planar runs of a root.

For every finished planar run (rheometer and the gravity cases) under an output root, the top
wall's friction ``|F_x| / F_z`` and its height over the steady-state test's window (its
``steady_window_chunks`` chunks: the last shear chunks, or with
``dem.precision.steady_window_is_production`` the production chunks marked ``from_steady_window``)
against the chunks produced after it. If the window still held the start-up, its friction would
differ from the later chunks' one way, run after run; realisation noise scatters the differences
about zero, with a chi2 per run near 1 (errors: batch means of the chunks, one chunk a batch).
The height difference is in grain diameters: a positive one is a bed still compacting.

Usage: ``python benchmarks/steady_window_check.py --root /work/results-night``
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.wall_series import read_wall_series  # noqa: E402


def chunk_means(run_dir: Path, chunks: list[dict]) -> pd.DataFrame:
    """Per chunk: the wall friction |F_x| / F_z and the mean wall height (m)."""
    rows = []
    for chunk in chunks:
        wall = read_wall_series(run_dir / chunk["series"])
        rows.append({"mu": abs(float(wall["ftop_x"].mean())) / float(wall["ftop_z"].mean()),
                     "h": float(wall["h_top"].mean())})
    return pd.DataFrame(rows)


def window_and_after(state: dict, window: int) -> tuple[list[dict], list[dict]]:
    """The steady window's chunks and the production chunks after it."""
    chunks = state["chunks"]
    adopted = [c for c in chunks if c.get("from_steady_window")]
    after = [c for c in chunks if c["kind"] == "production" and not c.get("from_steady_window")]
    if adopted:
        return adopted, after
    return [c for c in chunks if c["kind"] == "shear"][-window:], after


def compare(root: Path) -> pd.DataFrame:
    rows = []
    for record_path in sorted((root / "dem").glob("*/*/run.json")):
        record = json.loads(record_path.read_text())
        if record["geometry"] != "planar_shear":
            continue
        run_dir = record_path.parent
        state = json.loads((run_dir / "state.json").read_text())
        window, after = window_and_after(state, record["provenance"]["config"]["dem"]["steady_window_chunks"])
        if len(window) < 2 or len(after) < 2:
            continue
        a, b = chunk_means(run_dir, window), chunk_means(run_dir, after)
        diff = a["mu"].mean() - b["mu"].mean()
        err = math.hypot(a["mu"].std(ddof=1) / math.sqrt(len(a)), b["mu"].std(ddof=1) / math.sqrt(len(b)))
        rows.append({"run": f"{record['case']}/{record['run']}", "window_chunks": len(window), "after_chunks": len(after),
                     "mu_window": a["mu"].mean(), "mu_after": b["mu"].mean(), "mu_diff": diff, "mu_diff_sigma": diff / err,
                     "h_diff_over_d": (a["h"].mean() - b["h"].mean()) / record["d"]})
    if not rows:
        raise SystemExit(f"{root}: no finished planar run with a window and two chunks after it")
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, required=True, help="output root with dem/<case>/<run>/run.json")
    args = parser.parse_args(argv)
    table = compare(args.root)
    pd.set_option("display.width", 200)
    print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    z = table["mu_diff_sigma"].to_numpy()
    print(f"\nwall friction, window - after: mean {z.mean():+.2f} sigma over {len(z)} runs (error of that mean "
          f"{1 / math.sqrt(len(z)):.2f}), chi2 {np.sum(z**2):.1f} for {len(z)} runs; height: window - after "
          f"{table['h_diff_over_d'].mean():+.3f} d on average (range {table['h_diff_over_d'].min():+.3f} to "
          f"{table['h_diff_over_d'].max():+.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
