"""The adopted-packing test's shifts over realisations (tests/pipeline/dem/test_adopted_packing.py).

Each engine settles ci.yaml's shear_gravity r1 bed, the other adopts it and settles it again
(damping off, one law); for several seeds and rank counts this prints what the test bounds: the
95th percentile of the buried grains' shifts, the bed's mean height change, the grains past the
bound (rattlers) and the largest shift, against the test's bound (the Coulomb stretch times the
layers) and the smallest grain's radius. The test's bounds come from the contact law; this shows
how far inside them the realisations fall.

Usage: ``python benchmarks/adopted_packing_spread.py --seeds 7 8 9 10 --ranks 1 2``
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from tests.pipeline.dem.test_adopted_packing import packing_shifts, settled_bed  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[7, 8, 9, 10])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    worst = {"p95": 0.0, "mean_dz": 0.0, "rattler_fraction": 0.0, "largest": 0.0}
    for ranks in args.ranks:
        for seed in args.seeds:
            for pourer, shearer in (("liggghts", "lammps"), ("lammps", "liggghts")):
                with tempfile.TemporaryDirectory() as tmp:
                    source = settled_bed(Path(tmp) / "source", pourer, None, seed, ranks)
                    adopted = settled_bed(Path(tmp) / "adopted", shearer, Path(tmp) / "source", seed, ranks)
                    shift, dz, buried, bound, radius = packing_shifts(source, adopted)
                s = shift[buried]
                row = {"p95": float(np.percentile(s, 95)), "mean_dz": float(abs(dz.mean())),
                       "rattler_fraction": float((s > bound).mean()), "largest": float(s.max())}
                worst = {k: max(worst[k], row[k]) for k in worst}
                print(f"ranks {ranks} seed {seed} {pourer} -> {shearer}: 95 % shift {row['p95']:.4f} d, |mean dz| "
                      f"{row['mean_dz']:.4f} d (bound {bound:.4f} d); past the bound {int((s > bound).sum())} of {s.size}; "
                      f"largest {row['largest']:.3f} d (smallest radius {radius:.3f} d)", flush=True)
    print("worst: " + ", ".join(f"{k} {v:.4f}" for k, v in worst.items()))


if __name__ == "__main__":
    main()
