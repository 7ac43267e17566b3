"""The headline tables show the DEM noise floor with its own uncertainty (issue 29, item 3)."""
from __future__ import annotations

import math

import pandas as pd

from pipeline.report.scores_section import _noise


def test_noise_floor_carries_its_error_and_pairs() -> None:
    row = pd.Series({"dem_noise": 0.1234, "dem_noise_err": 0.031, "dem_noise_pairs": 3})
    assert _noise(row) == "0.123 +- 0.031, 3 pairs"
    # One pair: a floor without an error of its own, said as such.
    assert _noise(pd.Series({"dem_noise": 0.2, "dem_noise_err": math.nan, "dem_noise_pairs": 1})) == "0.2, 1 pairs"
    assert _noise(pd.Series({"dem_noise": math.nan, "dem_noise_err": math.nan, "dem_noise_pairs": 0})) == "n/a: one replica"
