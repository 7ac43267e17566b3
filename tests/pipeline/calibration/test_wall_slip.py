"""The walls' slip length from the calibration set (pipeline.calibration.wall_slip), on states
whose slips follow a known Navier law."""
from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.calibration import wall_slip
from pipeline.calibration.parameter_sets import CalibrationError, slip_length

D = 0.002


def _fake_files(monkeypatch, table: dict[str, dict[str, float]]) -> None:
    def attrs(path, names):
        row = table[str(path)]
        return {n: row[n] for n in names} | {"d": D, "run": str(path)}
    monkeypatch.setattr(wall_slip, "_attrs", attrs)


def _rheometer(monkeypatch, b_of_i, noise=0.0, seed=3):
    rng = np.random.default_rng(seed)
    inertial = np.array([0.005, 0.015, 0.05, 0.05, 0.1, 0.15, 0.25, 0.4, 0.6, 1.0, 1.6])
    files, states, table = [], [], {}
    for k, i in enumerate(inertial):
        rate = 10.0 * i  # s-1
        slip = b_of_i(i) * rate
        err = 0.02 * slip + 1e-6
        name = f"rheo{k}"
        files.append(name)
        states.append({"I": i, "I_spread": 0.1 * i, "shear_rate": rate, "shear_rate_err": 0.0, "d": D})
        table[name] = {"wall_top_slip": slip + noise * err * rng.standard_normal(), "wall_top_slip_err": err,
                       "wall_bottom_slip": slip + noise * err * rng.standard_normal(), "wall_bottom_slip_err": err}
    _fake_files(monkeypatch, table)
    return files, states


def test_a_constant_slip_length_is_found_with_its_chi2(monkeypatch):
    files, states = _rheometer(monkeypatch, lambda i: 0.45 * D, noise=1.0)
    entry = wall_slip.calibrate_wall("rheometer", files, states, [])
    rheo = entry["rheometer"]
    # the flowing states only: I >= 0.05 (9 of the 11)
    used = [s["I"] for s in rheo["states"] if s["used"]]
    assert min(used) >= wall_slip.MIN_INERTIAL and rheo["n_runs"] == 9
    assert entry["slip_length"]["value"] == pytest.approx(0.45 * D, abs=3 * rheo["error"])
    assert entry["slip_length"]["value_over_d"] == pytest.approx(0.45, rel=0.05)
    # unit-variance noise about the stated errors: chi2/dof within its 99 % range for 8 dof
    assert 0.15 < rheo["chi2_reduced"] < 2.7
    assert abs(rheo["inertial_trend"]["z"]) < 3.0
    assert slip_length({"wall": entry}) == entry["slip_length"]["value"]


def test_quasi_static_and_banded_runs_are_left_out(monkeypatch):
    # b wild where the layer does not flow homogeneously: slow states, or a spread bulk I
    files, states = _rheometer(monkeypatch, lambda i: (0.45 if i >= 0.05 else -3.0) * D)
    states[4]["I_spread"] = 0.5 * states[4]["I"]
    entry = wall_slip.calibrate_wall("rheometer", files, states, [])
    assert entry["slip_length"]["value"] == pytest.approx(0.45 * D, rel=1e-9)
    assert not entry["rheometer"]["states"][4]["used"] and entry["rheometer"]["n_runs"] == 8


def test_a_slip_length_that_grows_with_i_shows_in_the_trend_and_the_chi2(monkeypatch):
    files, states = _rheometer(monkeypatch, lambda i: (0.3 + 0.2 * math.log10(i / 0.005)) * D)
    rheo = wall_slip.calibrate_wall("rheometer", files, states, [])["rheometer"]
    assert rheo["inertial_trend"]["slope_per_decade"] == pytest.approx(0.2 * D, rel=1e-6)
    assert rheo["inertial_trend"]["z"] > 10.0
    assert rheo["chi2_reduced"] > 10.0


def test_the_calibration_case_and_none(monkeypatch):
    files, states = _rheometer(monkeypatch, lambda i: 0.45 * D)
    table = {f"sg{k}": {"wall_top_slip_length": b * D, "wall_top_slip": 0.03, "wall_top_shear_stress": 85.0}
             for k, b in enumerate([0.5, 0.6, 0.7, 0.6])}
    original = wall_slip._attrs
    monkeypatch.setattr(wall_slip, "_attrs", lambda p, n: ({m: table[str(p)][m] for m in n} | {"d": D, "run": str(p)})
                        if str(p) in table else original(p, n))
    case = wall_slip.calibrate_wall("calibration_case", files, states, list(table))
    assert case["slip_length"]["value"] == pytest.approx(0.6 * D)
    assert case["slip_length"]["error"] == pytest.approx(np.std([0.5, 0.6, 0.7, 0.6], ddof=1) / 2 * D)
    assert case["z_calibration_case_minus_rheometer"] > 1.0
    none = wall_slip.calibrate_wall("none", files, states, list(table))
    assert none["slip_length"]["value"] == 0.0 and none["rheometer"]["value"] > 0.0


def test_an_unknown_source_and_an_old_params_file_are_refused(monkeypatch):
    files, states = _rheometer(monkeypatch, lambda i: 0.45 * D)
    with pytest.raises(CalibrationError, match="calibration.wall_slip"):
        wall_slip.calibrate_wall("bulk", files, states, [])
    with pytest.raises(CalibrationError, match="wall.slip_length"):
        slip_length({"local": {}})


def test_too_few_homogeneous_runs_stop_the_rheometer_law_only(monkeypatch):
    files, states = _rheometer(monkeypatch, lambda i: 0.45 * D)
    for state in states[3:]:
        state["I_spread"] = 0.5 * state["I"]  # one homogeneous run left (I = 0.05)
    with pytest.raises(CalibrationError, match="two or more"):
        wall_slip.calibrate_wall("rheometer", files, states, [])
    none = wall_slip.calibrate_wall("none", files, states, [])
    assert none["slip_length"]["value"] == 0.0 and "two or more" in none["rheometer"]["not_measured"]
