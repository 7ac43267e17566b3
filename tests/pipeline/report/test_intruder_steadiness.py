"""The report's steadiness table (validation/rod_steadiness.csv) and its drift table (U - U_drift
against the push), from synthetic files."""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from pipeline.report.intruder_section import drift_html, steadiness_html
from pipeline.scoring.rod_steadiness import main as write_steadiness

D = 0.002


def _run(name: str, depth: float, travel: float, force: float = 1e-3, sweep: bool = False, push: float = 0.5,
         arrested: bool = False) -> dict:
    speed = travel * D / 2.0
    rod = {"control": False, "force_sweep": sweep, "depth_target_over_d": depth, "depth_over_d": depth + 0.1,
           "push_over_yield": push, "force": force, "speed": speed, "speed_err": 0.05 * abs(speed) + 1e-9,
           "arrested": arrested, "displacement": travel * D, "window": [1.0, 3.0],
           "halves": {"first": speed, "first_err": 0.05 * abs(speed) + 1e-9, "second": speed,
                      "second_err": 0.05 * abs(speed) + 1e-9, "blocks": 8}}
    return {"case": "intruder", "run": name, "d": D, "intruder": rod}


CONFIG = {"models": {"names": ["ngf"]}}


def test_the_steadiness_table_shows_each_rod_and_the_rule(tmp_path) -> None:
    assert steadiness_html(tmp_path, "intruder") == ""
    runs = [_run("D5-r1", 5, 2.0), _run("D7-r1", 7, 0.3)]
    paths = []
    for r in runs:
        path = tmp_path / f"{r['run']}.json"
        path.write_text(json.dumps(r))
        paths.append(str(path))
    write_steadiness(["--intruder-runs", *paths, "--out", str(tmp_path / "validation" / "rod_steadiness.csv")])
    html = steadiness_html(tmp_path, "intruder")
    assert "travel / d" in html and "1 steady, 1 unsteady" in html
    assert "travel 0.3 d &lt; 1 d" in html and "intruder_speed_log_err_unsteady" in html
    assert steadiness_html(tmp_path, "other_case") == ""


def test_the_drift_table_needs_a_drift_and_says_so_without_one(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr("pipeline.report.intruder_section.model_names", lambda config: ["ngf"])
    runs = [_run("D5-r1", 5, 2.0), _run("D5-F0-r1", 5, 0.8, force=0.0, sweep=True, push=0.0)]
    note = drift_html(tmp_path, CONFIG, "intruder", runs[:1])
    assert "not stored yet" in note and "<table" not in note
    # The DEM's rod at F = 0 gives the DEM's drift; the model file its own.
    (tmp_path / "models" / "intruder").mkdir(parents=True)
    xr.Dataset({"speed": ("depth_over_d", [3e-3]), "drift_speed": ("depth_over_d", [1e-3])},
               coords={"depth_over_d": [5.1]}, attrs={"model": "ngf"}).to_netcdf(tmp_path / "models" / "intruder" / "ngf.nc")
    html = drift_html(tmp_path, CONFIG, "intruder", runs)
    assert "U - U_drift (m/s)" in html and "own F = 0 solve" in html
    dem_u, dem_drift = runs[0]["intruder"]["speed"], runs[1]["intruder"]["speed"]
    assert f"{dem_u - dem_drift:.4g}" in html
    assert f"{3e-3 - 1e-3:.4g}" in html
    assert np.isfinite(dem_u - dem_drift)
