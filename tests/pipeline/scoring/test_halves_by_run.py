"""The production halves per run: what steady creep would give and what it gave."""
from __future__ import annotations

import numpy as np
import pandas as pd

from pipeline.scoring.scalar_checks import halves_by_run


def _halves(rng: np.random.Generator, run: str, shift: float, n: int = 400) -> pd.DataFrame:
    """``n`` depths of one run whose halves differ by ``shift`` decades, errors 0.05 decade."""
    err = 0.05
    change = shift + err * rng.standard_normal(n)
    z = change / err
    return pd.DataFrame({"case": "bed", "run": run, "depth_over_d": np.arange(1, n + 1, dtype=float),
                         "log10_change": change, "log10_change_err": err, "z": z, "z_normal": z})


def test_a_steady_run_has_its_share_beyond_two_and_a_slowing_one_more(rng: np.random.Generator) -> None:
    halves = pd.concat([_halves(rng, "steady", 0.0), _halves(rng, "ageing", -0.15)])
    table = halves_by_run(halves).set_index("run")
    steady, ageing = table.loc["steady"], table.loc["ageing"]
    # Binomial(400, 0.0455): mean 18.2, sd 4.2; four sd either side.
    assert abs(steady.beyond_2 - steady.expected_beyond_2) < 4 * np.sqrt(400 * 0.0455 * 0.9545)
    assert abs(steady.mean_log10_change) < 4 * 0.05 / np.sqrt(400)
    # A shift of 3 errors puts about 84 % of the depths beyond 2.
    assert ageing.beyond_2 > 0.75 * 400
    assert abs(ageing.mean_log10_change + 0.15) < 4 * 0.05 / np.sqrt(400)
