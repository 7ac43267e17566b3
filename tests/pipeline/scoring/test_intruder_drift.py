"""The drift and the push apart (pipeline.models.intruder_drift): a model's own F = 0 solve, its
variables in the model's intruder file, and the table U - U_drift read back. The solve on a small bed
(12 d, cell 8 d, 2 cells per d) with ngf_frozen, one Stokes solve a scene."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from pipeline.calibration.parameter_sets import model_parameters
from pipeline.models import intruder_drift as drift
from pipeline.models.intruder import scenes_of, solve_scene, solve_scenes

from ..models.intruder_bed import PARAMS, fields, run


def test_the_frozen_fluidity_s_own_zero_force_solve_is_its_linear_drift() -> None:
    """ngf_frozen is affine in F by construction (U = U_drift + F / K at one fluidity field), so its
    own F = 0 solve equals the drift its pushed solves report, at every push of one depth; one F = 0
    solve a depth, and the pushed speed exceeds it."""
    runs = [run("D4-r1", 4, 0.8), run("D4-F0.3-r1", 4, 0.5, True, 0.3), run("D4-F0.6-r1", 4, 1.0, True, 0.6)]
    scenes = scenes_of(runs, [fields()] * len(runs), PARAMS)
    parameters = model_parameters(PARAMS, "ngf")
    results, reasons = solve_scenes("ngf_frozen", parameters, scenes, 2.0)
    assert reasons == [None] * 3
    drifts, refused = drift.solve_drifts("ngf_frozen", parameters, scenes, 2.0, results, solve_scene)
    assert refused == [] and list(drifts) == [4.0]
    linear = drift.linear_drifts(results)
    assert linear == pytest.approx([drifts[4.0]] * 3, rel=1e-6)
    assert all(r.speed > drifts[4.0] for r in results)
    assert drift.zero_force(scenes[0]).rod.force_per_length == 0.0 and scenes[0].rod.force_per_length > 0.0


def _scene(depth: float, push: float, sweep: bool) -> SimpleNamespace:
    return SimpleNamespace(depth_over_d=depth, push_over_yield=push, force_sweep=sweep, target=round(depth))


def test_the_drift_variables_follow_the_file_s_depths_and_pushes_and_read_back(tmp_path) -> None:
    """Scenes: the depth sweep at 4.1 and 7.2 d, the force sweep at 4.1 d (0.3 and 0.6 F_y); the
    file keeps only the 7.2 d depth (4.1 d refused). Each depth and push gets its depth's drift;
    U - U_drift where both are finite."""
    scenes = [_scene(4.1, 0.3, True), _scene(4.1, 0.5, False), _scene(4.1, 0.6, True), _scene(7.2, 0.43, False)]
    out = xr.Dataset({"speed": ("depth_over_d", [2e-4]), "sweep_speed": ("push_over_yield", [1e-3, np.nan])},
                     coords={"depth_over_d": [7.2], "push_over_yield": [0.3, 0.6]}, attrs={"model": "ngf"})
    drifts = {4: 4e-4, 7: 5e-5}
    written = drift.add_drifts(out, scenes, drifts, linear=[1.0, 2.0, 3.0, 4.0], refused=["F = 0: x"])
    assert written[drift.DRIFT].values.tolist() == [5e-5]
    assert written[drift.LINEAR].values.tolist() == [4.0]
    assert written[drift.SWEEP_DRIFT].values.tolist() == [4e-4, 4e-4]
    assert written[drift.SWEEP_LINEAR].values.tolist() == [1.0, 3.0]
    assert written.attrs["drift_refused"] == '["F = 0: x"]'
    path = tmp_path / "ngf.nc"
    written.to_netcdf(path)
    table = drift.drift_table(path)
    assert list(table.columns) == drift.DRIFT_COLUMNS
    assert table.sweep.tolist() == [False, True, True]
    assert table.speed_minus_drift.iloc[0] == pytest.approx(2e-4 - 5e-5)
    assert table.speed_minus_drift.iloc[1] == pytest.approx(1e-3 - 4e-4)
    assert math.isnan(table.speed_minus_drift.iloc[2])  # the model refused that push


def test_a_file_without_the_drift_gives_none(tmp_path) -> None:
    path = tmp_path / "ngf.nc"
    xr.Dataset({"speed": ("depth_over_d", [1e-3])}, coords={"depth_over_d": [5.0]}).to_netcdf(path)
    assert drift.drift_table(path) is None
    assert drift.drift_table(tmp_path / "missing.nc") is None
