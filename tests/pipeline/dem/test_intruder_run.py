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

import math

import pandas as pd

from pipeline.common.config import (dem_runs, fill_owner_run, fill_physics, intruder_push, intruder_run, load_config,
                                    mean_grain_volume, shared_fill_ids, shared_fill_of)
from pipeline.dumps.reader import read_particles
from pipeline.dem.intruder_run import CreepSpeed, creep_speed, production_halves, rod_speed_settled, unwrap
from pipeline.dem.sheared_bed import (BED_SOLID_FRACTION, SETTLING_SHARE, bed_config, displaced_grains, expected_settling,
                                      overlapping, plan_insertion)

REPO = Path(__file__).resolve().parents[3]
D = 0.002
#: A control rod moves less than a tenth of a grain over its production (the top wall at rest).
CONTROL_DISPLACEMENT_OVER_D = 0.1


# ------------------------------------------------------------------------------ no LIGGGHTS
def test_creep_speed_recovers_a_noisy_drift(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 800)
    x = 1e-3 * t + 2e-6 * rng.standard_normal(t.size)
    c = creep_speed(t, x)
    assert not c.arrested
    assert abs(c.speed - 1e-3) < 3.0 * c.speed_err + 1e-6


def test_creep_speed_calls_jiggling_without_drift_arrested(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 1.0, 800)
    x = 1e-5 * rng.standard_normal(t.size)
    assert creep_speed(t, x).arrested
    # A steady drift at or below the rest speed is at rest, however well it is resolved.
    assert creep_speed(t, 1e-7 * t, rest_speed=1e-6).arrested


def test_arrest_depends_on_the_speed_not_on_the_window(rng: np.random.Generator) -> None:
    """A slow rod resolved from zero moves, over a short window as over a long one (the rule on
    the displacement over the window called the same rod arrested over the short window)."""
    speed = 2e-5  # m/s: 0.004 d over 0.4 s
    for duration in (0.4, 4.0):
        t = np.linspace(0.0, duration, 800)
        x = speed * t + 1e-8 * rng.standard_normal(t.size)
        c = creep_speed(t, x, rest_speed=1e-6)
        assert not c.arrested, (duration, c)
        assert c.speed == pytest.approx(speed, rel=0.01)


def test_halves_agree_for_a_steady_rod_and_part_for_a_slowing_one(rng: np.random.Generator) -> None:
    """A steady drift: each half's speed is the drift within 3 of its errors. A rod whose speed
    halves at the window's middle: the halves are the two speeds, apart by far more than their errors."""
    t = np.linspace(0.0, 1.0, 1600)
    steady = production_halves(t, 1e-3 * t + 2e-6 * rng.standard_normal(t.size))
    for half in ("first", "second"):
        assert abs(steady[half] - 1e-3) < 3.0 * steady[f"{half}_err"]
    x = np.where(t < 0.5, 1e-3 * t, 5e-4 + 5e-4 * (t - 0.5)) + 2e-6 * rng.standard_normal(t.size)
    slowing = production_halves(t, x)
    assert slowing["first"] == pytest.approx(1e-3, rel=0.05) and slowing["second"] == pytest.approx(5e-4, rel=0.05)
    assert slowing["first"] - slowing["second"] > 10.0 * np.hypot(slowing["first_err"], slowing["second_err"])
    # Too few samples for a half's blocks: no halves rather than an error from too few blocks.
    assert production_halves(t[:40], x[:40]) is None


def _relaxing_rod(t: np.ndarray, plateau: float, excess: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Rod position (m) whose speed relaxes from ``plateau + excess`` to ``plateau`` (m/s) over ``tau`` (s)."""
    return plateau * t + excess * tau * (1.0 - np.exp(-t / tau)) + 1e-7 * rng.standard_normal(t.size)


def test_rod_settles_only_once_its_speed_stops_falling(rng: np.random.Generator) -> None:
    """Windows of 4 chunks of 0.1 s over a speed that relaxes exponentially to a plateau: the
    test fails while the two windows' mean speeds differ by more than ``tol`` of the latter, and
    the first window it passes on measures the plateau to within that ``tol``."""
    plateau, excess, tau, tol, chunk, window = 1e-4, 2e-3, 0.2, 0.3, 0.1, 4
    t = np.linspace(0.0, 4.0, 16001)
    x = _relaxing_rod(t, plateau, excess, tau, rng)

    def speed(k0: int, k1: int) -> CreepSpeed:
        m = (t >= k0 * chunk) & (t <= k1 * chunk)
        return creep_speed(t[m], x[m], n_blocks=4, rest_speed=1e-6)

    def mean_speed(a: float, b: float) -> float:
        return plateau + excess * tau * (np.exp(-a / tau) - np.exp(-b / tau)) / (b - a)

    settled_at = None
    for k in range(window, 40):
        before = speed(k - 2 * window, k - window) if k >= 2 * window else None
        test = rod_speed_settled(before, speed(k - window, k), tol, rest_speed=1e-6)
        if before is None:
            assert not test["stationary"], "a moving rod is not settled without an earlier window"
            continue
        true_before = mean_speed((k - 2 * window) * chunk, (k - window) * chunk)
        true_latest = mean_speed((k - window) * chunk, k * chunk)
        if true_before - true_latest > 1.5 * tol * true_latest:
            assert not test["stationary"], (k, test)
        if test["stationary"]:
            settled_at = k
            break
    assert settled_at is not None
    assert abs(speed(settled_at - window, settled_at).speed - plateau) <= tol * plateau


def test_rod_at_rest_is_settled_without_an_earlier_window(rng: np.random.Generator) -> None:
    t = np.linspace(0.0, 0.4, 800)
    x = 1e-9 * rng.standard_normal(t.size)
    assert rod_speed_settled(None, creep_speed(t, x, n_blocks=4, rest_speed=1e-6), 0.3, 1e-6)["stationary"]
    assert not rod_speed_settled(None, creep_speed(t, x, n_blocks=4), 0.3, 0.0)["stationary"]


def test_unwrap_undoes_periodic_wrapping() -> None:
    lx = 0.016
    true = np.linspace(0.0, 3.5 * lx, 400)
    assert np.allclose(unwrap(np.mod(true, lx), lx), true)


@pytest.mark.parametrize("name", ["config/config.yaml", "config/ci.yaml"])
def test_configs_enumerate_depths_and_a_control(name: str) -> None:
    config = load_config(REPO / name)
    case = config["cases"]["intruder"]
    every = [run for c, run in dem_runs(config) if c == "intruder"]
    runs = [run for run in every if intruder_push(run) is None]
    depths = sorted({intruder_run(run)[0] for run in runs})
    assert depths == sorted(case["depths_below_top"])
    controls = [run for run in runs if intruder_run(run)[1]]
    assert controls == [f"D{min(depths):g}-control-r{k + 1}" for k in range(case["replicas"])]
    # The force sweep: every push of the config at its depth, once per replica, none a control.
    sweep = [run for run in every if intruder_push(run) is not None]
    assert sorted({intruder_push(run) for run in sweep}) == sorted(case["force_sweep"]["forces"])
    assert {intruder_run(run)[0] for run in sweep} == {case["force_sweep"]["depth"]}
    assert len(sweep) == len(case["force_sweep"]["forces"]) * case["replicas"]
    assert not any(intruder_run(run)[1] for run in sweep)
    if name.endswith("ci.yaml"):
        assert len(every) <= 5


# ------------------------------------------------------------------- the shared sheared bed
def _random_bed(rng: np.random.Generator, lx: float, ly: float, height: float, n: int) -> pd.DataFrame:
    """Flowing grains (type 1) at uniformly random centres (a Poisson bed) with the default's five
    diameters in equal numbers, and a flat top-wall layer (type 3) at ``height``."""
    diameters = D * np.array([0.8, 0.9, 1.0, 1.1, 1.2])
    grains = pd.DataFrame({"id": np.arange(1, n + 1), "type": 1, "x": rng.uniform(0, lx, n), "y": rng.uniform(0, ly, n),
                           "z": rng.uniform(0, height, n), "radius": 0.5 * rng.choice(diameters, n)})
    top = pd.DataFrame({"id": np.arange(n + 1, n + 11), "type": 3, "x": rng.uniform(0, lx, 10), "y": rng.uniform(0, ly, 10),
                        "z": height, "radius": 0.5 * D})
    return pd.concat([grains, top], ignore_index=True)


def test_overlap_is_the_rod_radius_plus_the_grain_s_across_the_periodic_boundary() -> None:
    lx, radius = 8 * D, 1.5 * D
    # Grains just inside and just outside contact, one of them through the periodic x boundary.
    grains = pd.DataFrame({"x": [0.25 * lx + 1.999 * D, 0.25 * lx + 2.001 * D, 0.25 * lx - 1.999 * D + lx, 0.25 * lx - 2.001 * D + lx],
                           "z": [0.0, 0.0, 0.0, 0.0], "radius": [0.5 * D] * 4})
    assert list(overlapping(grains, 0.25 * lx, 0.0, radius, lx)) == [True, False, True, False]


def test_the_rod_goes_in_without_overlap_at_its_depth(rng: np.random.Generator) -> None:
    lx, ly, height = 8 * D, 3 * D, 14 * D
    n = int(BED_SOLID_FRACTION * lx * ly * height / mean_grain_volume(D, 0.2, 5))
    bed = _random_bed(rng, lx, ly, height, n)
    radius, depth, settling = 1.5 * D, 5 * D, 0.4 * D
    plan = plan_insertion(bed, 0.25 * lx, depth, radius, lx, settling)
    grains = bed[bed["type"] == 1]
    gone = grains["id"].isin(plan.removed_ids).to_numpy()
    hit = overlapping(grains, 0.25 * lx, plan.z_rod, radius, lx)
    # Exactly the grains the rod overlaps leave: none left overlaps it, none leaves needlessly.
    assert np.array_equal(gone, hit) and gone.any()
    # The axis lies depth below the top wall once the top wall has fallen by the settling.
    assert height - settling - plan.z_rod == pytest.approx(depth)


def test_the_bed_is_poured_with_the_grains_the_rod_displaces(rng: np.random.Generator) -> None:
    """displaced_grains is the expected count of grains overlapping the rod in a bed at the bed's
    solid fraction: on Poisson beds (60 draws) the mean count agrees within 3 standard errors."""
    config = load_config(REPO / "config/config.yaml")
    case = config["cases"]["intruder"]
    d = config["material"]["d"]
    lx, ly, height = case["cell_x"] * d, case["cell_y"] * d, 16 * d
    n = int(round(BED_SOLID_FRACTION * lx * ly * height / mean_grain_volume(d, 0.2, 5)))
    counts = []
    for _ in range(60):
        bed = _random_bed(rng, lx, ly, height, n)
        counts.append(overlapping(bed[bed["type"] == 1], 0.5 * lx, 0.5 * height, 0.5 * case["rod_diameter"] * d, lx).sum())
    expected = displaced_grains(config, case)
    assert abs(np.mean(counts) - expected) < 3.0 * np.std(counts, ddof=1) / math.sqrt(len(counts)) + 0.5
    # The settling is the share of the displaced grains' bulk volume the rod does not fill.
    bulk = expected * mean_grain_volume(d, 0.2, 5) / BED_SOLID_FRACTION - math.pi * (0.5 * case["rod_diameter"] * d) ** 2 * ly
    assert expected_settling(config, case) == pytest.approx(SETTLING_SHARE * bulk / (lx * ly))
    planar = bed_config(config, "intruder")["cases"]["intruder"]
    assert planar["geometry"] == "planar_shear" and planar["n_grains"] == case["n_grains"] + expected
    assert "rod_diameter" not in planar and planar["wall_speed"] == case["wall_speed"]


def test_a_replica_s_runs_share_one_sheared_bed_and_replicas_do_not() -> None:
    config = load_config(REPO / "config/config.yaml")
    case = config["cases"]["intruder"] | {"shared_bed": True}
    config["cases"]["intruder"] = case
    runs = [run for c, run in dem_runs(config) if c == "intruder"]
    beds = shared_fill_ids("intruder", case)
    assert beds == [f"fill-sheared-r{k + 1}" for k in range(case["replicas"])]
    for run in runs:
        assert shared_fill_of("intruder", case, run) == f"fill-sheared-{intruder_run(run)[2]}"
    # Each bed is poured from its own seed; it is set up from a run of its own replica.
    seeds = {fill_physics(config, "intruder", bed)["seed"] for bed in beds}
    assert len(seeds) == len(beds)
    assert all(fill_owner_run("intruder", case, bed) in runs and fill_owner_run("intruder", case, bed).endswith(bed[-3:])
               for bed in beds)
    # A bed made at another wall speed or load is not this config's bed.
    other = {**config, "cases": {"intruder": case | {"wall_speed": 0.2}}}
    assert fill_physics(other, "intruder", beds[0]) != fill_physics(config, "intruder", beds[0])


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
def sheared(reduced_dem: Path) -> dict[str, Any]:
    """run.json record of the shallowest reduced intruder run (top wall moving)."""
    return _run(reduced_dem, control=False)


@pytest.fixture(scope="module")
def control(reduced_dem: Path) -> dict[str, Any]:
    """run.json record of its control (top wall at rest, same packing and push)."""
    return _run(reduced_dem, control=True)


@pytest.mark.liggghts
def test_control_without_shear_shows_no_steady_motion(control: dict[str, Any]) -> None:
    rod = control["intruder"]
    assert rod["control"] and control["wall_speed"] == 0.0
    assert rod["arrested"], rod
    assert abs(rod["displacement"]) < CONTROL_DISPLACEMENT_OVER_D * control["d"]
    # The push is below the yield force, and the grains hold it: contact force = -push on average.
    assert rod["force"] < rod["yield_force_estimate"]
    assert rod["mean_contact_force_x"] == pytest.approx(-rod["force"], rel=0.05)


@pytest.mark.liggghts
def test_sheared_rod_creeps_forward(sheared: dict[str, Any], control: dict[str, Any]) -> None:
    rod = sheared["intruder"]
    assert not rod["arrested"], rod
    assert rod["speed"] > 2.0 * rod["speed_err"] > 0.0
    assert rod["speed"] < sheared["wall_speed"]
    # The production's halves average to the whole window's displacement speed (equal durations).
    halves = rod["halves"]
    assert 0.5 * (halves["first"] + halves["second"]) == pytest.approx(rod["speed"], rel=0.02)
    assert rod["force"] == control["intruder"]["force"]
    # Production began only when the rod's speed over the window agreed with its speed over as
    # many chunks before: a moving rod needs two windows of shear at the least.
    config = load_config(sheared["_dir"].parents[2] / "config.effective.json")
    window = config["dem"]["steady_window_chunks"]
    settled = sheared["steady_state_test"]["rod"]
    assert settled["stationary"] and not settled["at_rest"], settled
    assert abs(settled["speed_before"] - settled["speed"]) <= settled["allowed"]
    # The window itself may be the production's start (counted there, not in shear_chunks).
    assert sheared["shear_chunks"] + sheared["production_chunks_from_steady_window"] >= 2 * window


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
