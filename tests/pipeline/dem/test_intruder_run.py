"""Intruder runs: the rod's speed estimate (synthetic) and two real reduced LIGGGHTS runs.

The LIGGGHTS tests read the shallowest intruder run with the top wall moving and its control with
the wall at rest from the reduced workflow the session runs once (tests/conftest.py).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pipeline.common.config import dem_runs, intruder_run, load_config
from pipeline.dumps.reader import read_particles
from pipeline.dem.intruder_run import ARREST_DISPLACEMENT_OVER_D, creep_speed, unwrap

REPO = Path(__file__).resolve().parents[3]
D = 0.002


# ------------------------------------------------------------------------------ no LIGGGHTS
def test_creep_speed_recovers_a_noisy_drift(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 800)
    x = 1e-3 * t + 2e-6 * rng.standard_normal(t.size)
    c = creep_speed(t, x, D)
    assert not c.arrested
    assert abs(c.speed - 1e-3) < 3.0 * c.speed_err + 1e-6


def test_creep_speed_calls_jiggling_without_drift_arrested(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 800)
    x = 1e-5 * rng.standard_normal(t.size)
    assert creep_speed(t, x, D).arrested
    # A slow but steady drift that stays under the displacement floor is arrested too.
    assert creep_speed(t, 0.5 * ARREST_DISPLACEMENT_OVER_D * D * t, D).arrested


def test_unwrap_undoes_periodic_wrapping() -> None:
    lx = 0.016
    true = np.linspace(0.0, 3.5 * lx, 400)
    assert np.allclose(unwrap(np.mod(true, lx), lx), true)


@pytest.mark.parametrize("name", ["config/config.yaml", "config/ci.yaml"])
def test_configs_enumerate_depths_and_a_control(name: str) -> None:
    config = load_config(REPO / name)
    case = config["cases"]["intruder"]
    runs = [run for c, run in dem_runs(config) if c == "intruder"]
    depths = sorted({intruder_run(run)[0] for run in runs})
    assert depths == sorted(case["depths_below_top"])
    controls = [run for run in runs if intruder_run(run)[1]]
    assert controls == [f"D{min(depths):g}-control-r{k + 1}" for k in range(case["replicas"])]
    if name.endswith("ci.yaml"):
        assert len(runs) <= 3


# ------------------------------------------------------------------------------ real LIGGGHTS
def _run(root: Path, control: bool) -> dict[str, Any]:
    """run.json record of the reduced workflow's shallowest intruder run (one LIGGGHTS run each)."""
    config = load_config(root / "config.effective.json")
    depth = min(config["cases"]["intruder"]["depths_below_top"])
    run_id = f"D{depth:g}-control-r1" if control else f"D{depth:g}-r1"
    out = root / "dem" / "intruder" / run_id
    record = json.loads((out / "run.json").read_text())
    record["_dir"] = out
    return record


@pytest.fixture(scope="module")
def sheared(reduced_results: Path) -> dict[str, Any]:
    """run.json record of the shallowest reduced intruder run (top wall moving)."""
    return _run(reduced_results, control=False)


@pytest.fixture(scope="module")
def control(reduced_results: Path) -> dict[str, Any]:
    """run.json record of its control (top wall at rest, same packing and push)."""
    return _run(reduced_results, control=True)


@pytest.mark.liggghts
def test_control_without_shear_shows_no_steady_motion(control: dict[str, Any]) -> None:
    rod = control["intruder"]
    assert rod["control"] and control["wall_speed"] == 0.0
    assert rod["arrested"], rod
    assert abs(rod["displacement"]) < ARREST_DISPLACEMENT_OVER_D * control["d"]
    # The push is below the yield force, and the grains hold it: contact force = -push on average.
    assert rod["force"] < rod["yield_force_estimate"]
    assert rod["mean_contact_force_x"] == pytest.approx(-rod["force"], rel=0.05)


@pytest.mark.liggghts
def test_sheared_rod_creeps_forward(sheared: dict[str, Any], control: dict[str, Any]) -> None:
    rod = sheared["intruder"]
    assert not rod["arrested"], rod
    assert rod["speed"] > 2.0 * rod["speed_err"] > 0.0
    assert rod["speed"] < sheared["wall_speed"]
    assert rod["force"] == control["intruder"]["force"]


@pytest.mark.liggghts
@pytest.mark.parametrize("which", ["sheared", "control"])
def test_grains_and_rod_conserved_and_depth_held(which: str, request: pytest.FixtureRequest) -> None:
    record = request.getfixturevalue(which)
    rod = record["intruder"]
    dump = read_particles([record["_dir"] / p for p in record["particle_dumps"]])
    types = dump.column("type")
    z = dump.column("z")
    assert len(dump) > 0 and set(dump.counts) == {record["particle_count"]}
    for s in range(len(dump)):
        rows = slice(dump.offsets[s], dump.offsets[s + 1])
        assert np.sum(types[rows] == 1) == record["flowing_grains"]
        assert np.sum(types[rows] == 4) == rod["n_grains"]
        # Every rod grain sits at the rod's fixed height: it neither sank nor rose nor tilted.
        assert np.allclose(z[rows][types[rows] == 4], rod["z"], atol=1e-9)
    assert rod["z_drift"] < 1e-9
    # The depth is placed from the expected bed height: within a grain of the target.
    assert abs(rod["depth_over_d"] - rod["depth_target_over_d"]) < 1.0
