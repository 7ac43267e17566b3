"""The DEM noise of a score: the metric between replica pairs (synthetic profiles, no LIGGGHTS)."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from pipeline.scoring import metrics
from pipeline.scoring.intruder_scores import intruder_noise_terms, moving_rod_speeds
from pipeline.scoring.scores import dem_noise, pair_values


def _replica(z: np.ndarray, nu: np.ndarray) -> xr.Dataset:
    return xr.Dataset({"nu": ("z", nu), "nu_err": ("z", np.full(z.size, 1e-3))}, coords={"z": z})


def test_pair_values_are_the_metric_between_each_pair() -> None:
    """Three replicas offset by 0, 0.01 and 0.03 in nu: the RMS between pairs is each pair's
    offset, and the noise is their mean."""
    z = np.linspace(0.0, 0.04, 41)
    reps = [_replica(z, 0.58 + offset + 0.0 * z) for offset in (0.0, 0.01, 0.03)]
    mask = np.ones(z.size, dtype=bool)
    values = pair_values(reps, "nu", lambda m, d, e: metrics.rmse(m, d), mask)
    assert values == pytest.approx([0.01, 0.03, 0.02])
    assert dem_noise(reps, "nu", lambda m, d, e: metrics.rmse(m, d), mask) == pytest.approx(0.02)
    assert np.isnan(dem_noise(reps[:1], "nu", lambda m, d, e: metrics.rmse(m, d), mask))


def _rod(depth: float, speed: float, arrested: bool = False, control: bool = False) -> dict:
    return {"intruder": {"depth_target_over_d": depth, "speed": speed, "arrested": arrested, "control": control}}


def test_intruder_noise_pairs_rods_at_one_depth_that_move() -> None:
    runs = [_rod(5, 1e-4), _rod(5, 1e-3), _rod(7, 2e-4), _rod(7, 1e-9, arrested=True), _rod(5, 0.0, control=True)]
    by_depth = moving_rod_speeds(runs)
    assert by_depth == {5.0: [1e-4, 1e-3], 7.0: [2e-4]}
    assert intruder_noise_terms(by_depth) == pytest.approx([1.0])
    # A rod creeping backwards has no log speed: no term.
    assert intruder_noise_terms({5.0: [1e-4, -1e-4]}) == []


def test_two_intruder_cases_are_refused_by_name(tmp_path, capsys) -> None:
    """The intruder's scores pool one case's rods: model files of two intruder cases (a cell-length
    study's) are refused before anything is read, naming both cases."""
    from pipeline.scoring.scores import main
    with pytest.raises(SystemExit) as stop:
        main(["--fields", "f.nc", "--models", "m.nc", "--params", "p.json", "--out", str(tmp_path / "s.csv"),
              "--intruder-models", "r/models/intruder/ngf.nc", "r/models/intruder_long/ngf.nc"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "intruder, intruder_long" in err and "one case" in err
    assert not (tmp_path / "s.csv").exists()
