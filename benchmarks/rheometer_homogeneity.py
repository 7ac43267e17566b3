"""Which rheometer states of a root calibrate the wall's slip length: each state's bulk I, its bulk
I spread over I and its slip length b, and whether the calibration uses it (I >= 0.05, spread
under 0.25 I: pipeline/calibration/wall_slip.py), from the root's fields files. For several roots
(realisations of one config) it shows how robust the selection is: the calibration needs two.

Usage: ``python benchmarks/rheometer_homogeneity.py ROOT [ROOT ...] [--margin 3.0]``
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.calibration.calibrate import bulk_state  # noqa: E402
from pipeline.calibration.wall_slip import calibrates_slip, rheometer_state  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("roots", nargs="+", type=Path)
    parser.add_argument("--margin", type=float, default=3.0, help="calibration.bulk_margin_over_d of the roots' config")
    args = parser.parse_args()
    counts = []
    for root in args.roots:
        files = sorted((root / "fields" / "rheometer").glob("*.nc"))
        if not files:
            sys.exit(f"error: {root}/fields/rheometer holds no fields file")
        cells, used = [], 0
        for path in files:
            state = rheometer_state(path, bulk_state(path, args.margin))
            ok = calibrates_slip(state)
            used += ok
            cells.append(f"{path.stem} I {state['I']:.3f} spread {state['I_spread_over_I']:.2f} I, "
                         f"b {state['slip_length_over_d']:.2f} d{' (used)' if ok else ''}")
        counts.append(used)
        print(f"{root}: {used} states used\n  " + "\n  ".join(cells))
    print(f"states used per root: {counts}; fewest {min(counts)} (the calibration needs 2)")


if __name__ == "__main__":
    main()
