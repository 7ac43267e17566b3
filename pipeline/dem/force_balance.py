"""Action = reaction over a whole bed: the pair forces summed over all atoms, at round-off.

Every shear stage writes ``series/pairforce_<stage>.txt`` (``liggghts_inputs/pair_force.in``):
instantaneous samples (no time average, which could hide a defect whose sign changes) of the pair
forces summed over all atoms along x, y and z (N), and of their absolute values (N), the
round-off scale. Only the pair forces enter (``fix store/force`` placed before every other force),
so no body force, load or constraint does: each contact contributes its two forces, and the sums are
zero up to rounding if every contact obeys action = reaction.

With ``newton off`` (LIGGGHTS' granular pair style requires it) a contact across a periodic or
processor face is computed twice, once from each side, and its two copies must agree. In LIGGGHTS 3.8
they did not: a ``fix rigid`` wall's ghost grains carried the body mass truncated to an integer
(0 below 1 kg), so the copies damped differently, and the fill's ``create_atoms`` after a run left
some contacts with one copy's tangential history lost (docs/dem.md, "Action and reaction"). Both
gave sums of 1e-3 to 2e-2 of the summed |f| (a default bed, the test's bed); with both removed the sums
stay below 4e-13 of it (reduced planar and intruder runs, one and two MPI ranks).

Tolerance: each sum rounds at about ``eps * sum|f|`` per added force (eps = 2.2e-16), at most
``N eps sum|f|`` over N atoms (1e-13 at N = 500), and the two copies of a cross-face contact see
overlaps that differ by the rounding of the image shift, ``eps L / delta`` relative (L the cell
side, delta the overlap: 1e-12 for an 8 d cell at 0.2 % overlap). :data:`ROUND_OFF` = 1e-10 lies
two decades above both, more than two below the smallest defect seen (a 2.5 kg rigid body in a
minimal input: 4e-8) and seven below the beds'.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.dem.wall_series import read_wall_series

#: Columns of ``series/pairforce_<stage>.txt``: step, time (s), the pair forces summed over all atoms
#: along x, y, z (N) and the sums of their absolute values (N).
PAIRFORCE_COLUMNS = ("step", "time", "sum_x", "sum_y", "sum_z", "abs_x", "abs_y", "abs_z")

#: Largest |sum of pair forces| / sum of |pair forces| (per component and sample) counted as round-off.
ROUND_OFF = 1e-10


def pair_force_file(stage: str) -> str:
    """Path of a stage's pair-force samples, relative to the run folder (the ``pairforce_file`` variable)."""
    return f"series/pairforce_{stage}.txt"


def read_pair_forces(files: Sequence[Path]) -> pd.DataFrame:
    """The samples of several stages, in order. Raises ``SeriesError`` naming a bad file and line."""
    return pd.concat([read_wall_series(f, PAIRFORCE_COLUMNS) for f in files], ignore_index=True)


def pair_force_check(samples: pd.DataFrame, shear_force: float | None = None,
                     tolerance: float = ROUND_OFF) -> dict[str, Any]:
    """Largest pair-force sums over the samples, absolute (N) and over the sums of |f|; ``at_round_off``
    when every component of every sample is within ``tolerance`` of its |f| sum.

    ``shear_force`` (N, the top wall's mean shear force), when given, also scales the largest x sum.
    A sample with no force at all (no contact) counts as round-off.
    """
    out: dict[str, Any] = {"samples": int(len(samples)), "tolerance": tolerance}
    worst = 0.0
    for axis in ("x", "y", "z"):
        total = samples[f"sum_{axis}"].abs().to_numpy()
        scale = samples[f"abs_{axis}"].to_numpy()
        ratio = np.divide(total, scale, out=np.zeros_like(total), where=scale > 0)
        out[f"max_abs_sum_{axis}"] = float(total.max())
        out[f"max_sum_over_abs_{axis}"] = float(ratio.max())
        worst = max(worst, float(ratio.max()))
    if shear_force:
        out["max_sum_x_over_shear_force"] = out["max_abs_sum_x"] / abs(shear_force)
    out["at_round_off"] = worst <= tolerance
    return out


def record(run_dir: Path, stages: Sequence[str], shear_force: float | None = None) -> dict[str, Any] | None:
    """The check over the given stages of a run (its production), for ``run.json``; None when a
    stage has no pair-force file (a run made before the file existed)."""
    files = [run_dir / pair_force_file(s) for s in stages]
    if not files or not all(f.is_file() for f in files):
        return None
    return pair_force_check(read_pair_forces(files), shear_force) | {"stages": list(stages)}
