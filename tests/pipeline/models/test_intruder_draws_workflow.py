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
from pipeline.models.intruder_sensitivities import check_passes

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
        # a propagated file (models.intruder_plastic_u_input: sensitivities) says why per scene
        by_scene = json.loads(ds.attrs.get("sensitivity_failures", "{}"))
        for i, draw in enumerate(ds.draw.values):
            missing = [str(r) for r, m in zip(ds.run.values, np.isnan(speed[i]) & predicted) if m]
            if missing:
                assert str(int(draw)) in failures or all(r in by_scene for r in missing), (model, int(draw), missing)


def test_plastic_u_input_is_propagated_over_every_draw_with_a_check_solve(reduced_results: Path) -> None:
    """With ``models.intruder_plastic_u_input: sensitivities`` (ci.yaml) each plastic model's file
    holds every draw of the ensemble in order (NaN where a draw has no parameters for it), propagated, and names its method;
    where a scene moves, either its propagation passed its check at a draw of the ensemble, or the
    scene says why not and has its first draws solved (the reduced run's fast local mu(I) rods) (the unit tests, tests/pipeline/models/
    test_intruder_sensitivities.py, hold the propagation against the draws' own solves)."""
    config = load_config(str(reduced_results / "config.effective.json"))
    assert layout.plastic_u_input(config) == "sensitivities"
    ensemble = json.loads((reduced_results / "calibration" / "draws.json").read_text())
    for path in map(Path, layout.intruder_model_draw_paths(config)):
        ds = xr.open_dataset(path)
        model = ds.attrs["model"]
        if model not in layout.PLASTIC_INTRUDER_MODELS:
            assert ds.attrs["u_input_method"] == "draws", model
            continue
        assert ds.attrs["u_input_method"] == "sensitivities", model
        # every draw of the ensemble, in order (the verdict pairs the models draw by draw)
        assert list(ds.draw.values) == [d["draw"] for d in ensemble["draws"]], model
        usable = [d["draw"] for d in ensemble["draws"] if model not in d.get("failed", {})]
        part = xr.open_dataset(path.parent / "parts" / model / "sensitivities.nc")
        reasons = json.loads(part.attrs["sensitivity_failures"])
        for j, run in enumerate(part.run.values):
            if part.rigid_nominal.values[j] or not np.isfinite(part.speed_nominal.values[j]):
                continue
            if part.propagated.values[j]:
                # a propagated scene passed its check at a draw of the ensemble
                k = int(part.check_draw.values[j])
                assert k in usable, (model, j)
                assert check_passes(part.check_dln_linear.values[j], float(part.log_offset.sel(draw=k).values[j]))
            else:
                # a scene that failed its check says so and has its first draws solved
                assert "solved instead" in reasons[str(run)], (model, run)
                assert np.isfinite(part.speed.values[:, j]).any(), (model, run)
