"""The DEM jobs' scheduling priorities (pipeline/workflow/priorities.py): upward ranks."""
from __future__ import annotations

import copy
from pathlib import Path

import pytest

from pipeline.common.config import calibration_runs, dem_fills, dem_runs, load_config
from pipeline.workflow.priorities import (AFTER_DEM_PRIORITY, PARTICLE_STEPS_PER_SECOND, _dependents, dem_priority, estimated_seconds,
                                         fill_steps, upward_rank)

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module", params=[False, True], ids=["own-beds", "shared-bed"])
def config(request: pytest.FixtureRequest) -> dict:
    config = load_config(REPO / "config/config.yaml")
    config["cases"]["intruder"]["shared_bed"] = request.param
    return config


def test_a_job_outranks_every_job_that_waits_for_it(config: dict) -> None:
    """The rank of a job is its own estimated time plus its longest dependent chain: a shared fill,
    a sheared bed or a rheometer state that others continue from ranks above each of them, by at
    least its own time."""
    chained = 0
    for case, job in dem_fills(config) + dem_runs(config):
        for after in _dependents(config, case, job):
            chained += 1
            assert upward_rank(config, case, job) >= upward_rank(config, case, after) + estimated_seconds(config, case, job) - 1e-6
    assert chained > 0


def test_the_rank_is_the_longest_chain_to_the_report(config: dict) -> None:
    """The calibration case's replicas (16 strain units each, then the calibration and every model)
    rank above every rod of the held-out intruder; every DEM rank is below the rules after the DEM."""
    ranks = {(c, j): dem_priority(config, c, j) for c, j in dem_fills(config) + dem_runs(config)}
    calibration = min(v for (c, j), v in ranks.items() if c == "shear_gravity" and j.startswith("r"))
    rods = max(v for (c, j), v in ranks.items() if c == "intruder" and not j.startswith("fill"))
    assert calibration > rods
    assert max(ranks.values()) < AFTER_DEM_PRIORITY


def test_the_estimate_follows_the_steps_per_strain() -> None:
    """Steps per strain unit are gap / wall speed / dt: doubling a case's wall speed halves the
    estimate of a run without a fill of its own's shear and production (the fill's fall is the same)."""
    config = load_config(REPO / "config/config.yaml")
    faster = copy.deepcopy(config)
    faster["cases"]["shear_gravity_fast"]["wall_speed"] *= 2.0
    case = config["cases"]["shear_gravity_fast"]
    fill = case["n_grains"] * fill_steps(config, case) / PARTICLE_STEPS_PER_SECOND
    slow = estimated_seconds(config, "shear_gravity_fast", "r1") - fill
    fast = estimated_seconds(faster, "shear_gravity_fast", "r1") - fill
    assert fast == pytest.approx(0.5 * slow)


def test_the_rods_run_before_the_held_out_planar_replicas(config: dict) -> None:
    """The intruder's 2D model stage (tens of CPU minutes) waits for every rod: the rods (and the
    beds they start from) rank above the held-out planar cases' replicas, whose short runs then
    fill the slots beside that stage."""
    ranks = {(c, j): dem_priority(config, c, j) for c, j in dem_fills(config) + dem_runs(config)}
    rods = min(v for (c, j), v in ranks.items() if c == "intruder")
    planar = max(v for (c, j), v in ranks.items() if c in ("shear_gravity_fast", "shear_gravity_heavy"))
    assert rods > planar


def test_every_intruder_model_is_ordered_and_all_start_before_the_other_rules_after_the_dem() -> None:
    """The intruder's 2D models' jobs start slowest model first, above every other rule after the
    DEM (:data:`INTRUDER_MODELS_SLOWEST_FIRST`), and the order names every intruder model the
    workflow runs (one left out would start after all the others)."""
    from pipeline.common import layout
    from pipeline.workflow.priorities import INTRUDER_MODELS_SLOWEST_FIRST, intruder_model_priority
    assert set(INTRUDER_MODELS_SLOWEST_FIRST) == set(layout.INTRUDER_MODELS)
    priorities = [intruder_model_priority(m) for m in INTRUDER_MODELS_SLOWEST_FIRST]
    assert priorities == sorted(set(priorities), reverse=True)
    assert min(priorities) > AFTER_DEM_PRIORITY


def test_the_calibration_set_runs_before_every_other_dem_job(config: dict) -> None:
    """Every model waits for the calibration: each calibration-set job (its fills and runs) ranks
    above every other case's run, the rods included, whose corrected estimates (a rod in the
    creeping zone runs to its production cap) give them longer chains than the rheometer's; the
    other cases' shared fills and sheared beds, which gate their runs, rank with the calibration set."""
    calibration = {c for c, _ in calibration_runs(config)}
    ranks = {(c, j): dem_priority(config, c, j) for c, j in dem_fills(config) + dem_runs(config)}
    lowest_calibration = min(v for (c, _), v in ranks.items() if c in calibration)
    highest_other = max(v for (c, j), v in ranks.items() if c not in calibration and (c, j) in dem_runs(config))
    assert lowest_calibration > highest_other
    other_fills = [v for (c, j), v in ranks.items() if c not in calibration and (c, j) in dem_fills(config)]
    assert not other_fills or min(other_fills) > highest_other
    assert max(upward_rank(config, "intruder", j) for c, j in dem_runs(config) if c == "intruder") > \
        min(upward_rank(config, c, j) for c, j in dem_fills(config) + dem_runs(config) if c == "rheometer")


def test_a_pushed_rod_asked_to_travel_is_estimated_at_its_production_cap(config: dict) -> None:
    """With ``rod_min_travel_over_d`` a pushed rod's production is its strain cap (the default's
    rods ran to it), without it twice its minimum: the estimate falls by the difference's steps."""
    relaxed = copy.deepcopy(config)
    relaxed["cases"]["intruder"]["precision"].pop("rod_min_travel_over_d")
    relaxed["dem"].get("precision", {}).pop("rod_min_travel_over_d", None)
    capped = estimated_seconds(config, "intruder", "D4.5-r1")
    short = estimated_seconds(relaxed, "intruder", "D4.5-r1")
    assert capped > short
    control_capped = estimated_seconds(config, "intruder", "D4.5-control-r1")
    assert control_capped == pytest.approx(estimated_seconds(relaxed, "intruder", "D4.5-control-r1"))
