"""The intruder models' draws and grid study as the reduced workflow writes them (real LIGGGHTS
beds, every model's own 2D solves): no scene is left without a number and without a reason."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.common import layout
from pipeline.common.config import load_config

pytestmark = pytest.mark.liggghts


def test_every_missing_draw_or_refined_speed_says_why(reduced_results: Path) -> None:
    """A draw or grid-study speed is a number or a stated reason: a draw's NaN is ``refused`` and,
    unless the nominal solve had no speed there, in ``failures``; a refined NaN where the nominal
    solve has a speed is in ``refined_failures`` (the scene's u_num then has no grid study)."""
    config = load_config(str(reduced_results / "config.effective.json"))
    for path in map(Path, layout.intruder_model_draw_paths(config)):
        ds = xr.open_dataset(path)
        model = ds.attrs["model"]
        # which scenes the nominal solve gave a speed for (the states file, in the draws' run order)
        with np.load(reduced_results / "models" / "intruder" / f"{model}.states.npz") as states:
            predicted = states["_predicted"].astype(bool)
        assert predicted.size == ds.sizes["run"], model
        failures = json.loads(ds.attrs["failures"])
        refined_failures = json.loads(ds.attrs["refined_failures"])
        speed = ds.speed.values
        assert np.all(ds.refused.values[np.isnan(speed)] == 1), model
        for j, run in enumerate(ds.run.values):
            if np.isnan(ds.speed_refined.values[j]) and predicted[j]:
                assert str(run) in refined_failures, (model, run, refined_failures)
        for i, draw in enumerate(ds.draw.values):
            if np.isnan(speed[i][predicted]).any():
                assert str(int(draw)) in failures, (model, int(draw))
