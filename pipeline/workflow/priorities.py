"""Scheduling priorities of the DEM jobs: the longest chain to the report starts first (issue 45).

On the 2-core machine Snakemake keeps two jobs running and, among the jobs that are ready, starts
those of highest ``priority`` first. Without priorities it started them in DAG order, and the
default of 2026-12-03 ended with one slot idle for about 10 minutes while the last calibration
replica (16 strain units) ran alone: 92 % of the slot-time busy. Here each DEM job's priority is
its *upward rank*, the estimated seconds from its start to the report along its longest chain of
dependents (list scheduling by critical path, as HEFT does):

    rank(job) = seconds(job) + max(rank(dependent)),   and seconds(job) + tail(case) at a chain's end

with ``seconds`` the DEM cost model :func:`estimated_seconds` (particle-steps from the config's
cell, grains, wall speed, time step and strains, over :data:`PARTICLE_STEPS_PER_SECOND`) and
``tail`` the work after the DEM on the way to the report (:data:`TAIL_SECONDS`: the calibration
set's runs feed the calibration, the draws and every model; a held-out run its fields, its models
and the scores; the calibration set's and the intruder's runs also the intruder's 2D model
stage, :data:`INTRUDER_MODEL_SECONDS`). The long replicas of the calibration case then start first, the chains of
continued rheometer states and the beds that several rods wait for next, and the short rods last,
where they fill the slots to the end. The calibration set's jobs, and every shared fill or sheared
bed, go before every other DEM job (:data:`CALIBRATION_SET_FIRST`), since every model waits for
the calibration and a fill gates several runs. The non-DEM rules run as soon as they are ready
(:data:`AFTER_DEM_PRIORITY`, above every DEM rank): each is short, and they are the tail; among
them the intruder models' jobs start first, slowest model first (:func:`intruder_model_priority`).

The ranks are estimates for ordering only; nothing a run computes depends on them.
"""
from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

from pipeline.common.config import (RHEOMETER, calibration_runs, case_production, dem_runs, intruder_run, mean_grain_volume,
                                    predecessor_state, run_case, run_state, shared_fill_ids, shared_fill_of)
from pipeline.dem.contact_scaling import contact_design

#: LIGGGHTS particle-steps per second of one rank on the 2-core machine, two jobs running
#: (docs/dem_cost.md, sections 9-10: 4.4-5.0 M; 5.3-6.0 M alone on a production bed).
PARTICLE_STEPS_PER_SECOND = 4.5e6
#: Seconds after a DEM run's last chunk to the report along its chain: a calibration-set run feeds
#: the calibration, its draws and every model before the scores; a held-out run its fields, its own
#: models and the scores (the 2026-12-03 default: about 100 s of calibration, draws, models, scores
#: and report after the last DEM, docs/dem_cost.md section 15).
TAIL_SECONDS = {"calibration": 200.0, "held_out": 100.0}
#: Seconds of the intruder's 2D model stage on its longest chain: the slowest model's nominal
#: solves, then one part of its draws (``models.intruder_draw_jobs``). Measured 2026-12-05 on the
#: default (volume-averaged, alone on a core): about 250 CPU s nominal, 8 draws x 6 scenes at about
#: 30 s, so about 700 s per part of two. The intruder's rods and, before them, the calibration
#: (every intruder model needs its parameters) carry it in their tail, so they run before the
#: held-out planar cases' short replicas, which then fill the slots beside the model stage.
INTRUDER_MODEL_SECONDS = 1000.0
#: Priority of every rule after the DEM (above any DEM rank): they are short and are the tail (the
#: intruder models' jobs a few above it, :func:`intruder_model_priority`).
AFTER_DEM_PRIORITY = 1_000_000
#: The intruder's 2D models, slowest first: the order their jobs (nominal solves, grid study,
#: sensitivities or draws) start in when several are ready. Each model's chain (nominal solves,
#: then its grid study and u_input, then the merge the scores wait for) is the longest after the
#: DEM, and the slowest started last ran alone at the end: in the suite's reduced run of
#: 2026-12-07 the volume-averaged sensitivities (36-93 s) started after every other model's jobs
#: and were 36-50 s of the last minute with one slot idle (docs/dem_cost.md 30). The order is the
#: reduced run's CPU seconds per model (nominal, grid study and sensitivities together).
INTRUDER_MODELS_SLOWEST_FIRST = ("volume_averaged", "cosserat", "critical_state", "ngf", "local_mu_i")
#: Raise of every calibration-set DEM job's priority, above any upward rank: every model job (the
#: work that fills the second slot beside the DEM) waits for the calibration, so the calibration
#: set runs first whatever the ranks. Upward ranks alone see one chain at a time: with the rods'
#: estimate corrected (2.7 times short before, docs/dem_cost.md 31) the 18 rods outranked the
#: rheometer's chains, and the model stage would have waited for all of them. The shared fills and
#: sheared beds of every case are raised too: each gates several runs, and started after the
#: calibration set (the intruder's three beds, about 130 s each, for its 18 rods) they left a slot
#: idle while the rods waited (+67 s of wall in benchmarks/schedule_estimate.py on the default).
CALIBRATION_SET_FIRST = 100_000
#: Solid fraction of a settled bed (the gap estimate) and of the fill's loose pour.
BED_SOLID_FRACTION = 0.6
POUR_SOLID_FRACTION = 0.25
#: Fall times a fill takes to settle (rest measured at 1.1-1.25, docs/dem_cost.md section 6).
FILL_FALL_TIMES = 1.25
#: Shear strain a pushed rod takes before its speed settles (9-19 chunks of 0.25, docs/dem_cost.md).
ROD_SHEAR_STRAIN = 3.0


def _gap(config: dict[str, Any], case: dict[str, Any]) -> float:
    """Expected wall-to-wall gap (m) of a case's settled bed."""
    mat = config["material"]
    d = mat["d"]
    area = case["cell_x"] * case["cell_y"] * d * d
    return case["n_grains"] * mean_grain_volume(d, mat["polydispersity"], mat["n_sizes"]) / (BED_SOLID_FRACTION * area) + 1.3 * d


def _time_step(config: dict[str, Any]) -> float:
    return contact_design(config).dt  # the DEM's own rule for dt


def fill_steps(config: dict[str, Any], case: dict[str, Any]) -> float:
    """Time steps of a fill: the loose pour falling to rest (:data:`FILL_FALL_TIMES` fall times)."""
    mat = config["material"]
    d = mat["d"]
    area = case["cell_x"] * case["cell_y"] * d * d
    lz = case["n_grains"] * mean_grain_volume(d, mat["polydispersity"], mat["n_sizes"]) / (POUR_SOLID_FRACTION * area) + 4.0 * d
    g = case["gravity"] if case["gravity"] > 0 else 9.81
    return FILL_FALL_TIMES * math.sqrt(2.0 * lz / g) / _time_step(config)


def _run_strain(config: dict[str, Any], case_name: str, case: dict[str, Any], run: str) -> float:
    """Strain units of shear and production a run is expected to take."""
    dem = case_production(config["dem"], case)
    window = dem["steady_window_chunks"] * dem["chunk_strain"]
    adopted = bool((dem.get("precision") or {}).get("steady_window_is_production", False))
    cap = float(dem["production_strain"])
    if case["geometry"] == "intruder":
        _, control, _ = intruder_run(run)
        precision = dem.get("precision") or {}
        minimum = float(precision.get("min_production_strain", cap))
        if control:  # at rest after its window
            return window + minimum
        # A pushed rod settles in about three strain units. Asked to travel a distance
        # (``rod_min_travel_over_d``), a rod in the creeping zone runs to its cap: 17 of the 18
        # pushed rods of the 2026-12-07 default did (travel 0.08-0.98 d at 8 strain units), and
        # without this the estimate was 2.7 times short (docs/dem_cost.md 31).
        production = cap if "rod_min_travel_over_d" in precision else min(cap, 2 * minimum)
        return max(ROD_SHEAR_STRAIN, 2 * window) + production
    shear = float(dem.get("min_shear_strain", 0.0)) + window
    return shear + cap - (window if adopted else 0.0)


def estimated_seconds(config: dict[str, Any], case_name: str, run: str) -> float:
    """Estimated LIGGGHTS seconds of one DEM job (a run, a shared fill or a sheared bed): its
    particle-steps (grains x steps; steps per strain unit = gap / wall speed / dt) over
    :data:`PARTICLE_STEPS_PER_SECOND`."""
    base = config["cases"][case_name]
    dt = _time_step(config)
    if run in shared_fill_ids(case_name, base):
        steps = fill_steps(config, base)
        if base.get("shared_bed") and base["geometry"] == "intruder":
            dem = case_production(config["dem"], base)
            strain = float(dem.get("min_shear_strain", 0.0)) + 2 * dem["steady_window_chunks"] * dem["chunk_strain"]
            steps += strain * _gap(config, base) / float(base["wall_speed"]) / dt
        return base["n_grains"] * steps / PARTICLE_STEPS_PER_SECOND
    case = run_case(base, run)
    gap = _gap(config, case)
    if case_name == RHEOMETER:
        inertial, pressure = run_state(run)
        speed = inertial * math.sqrt(pressure / config["material"]["rho_s"]) / config["material"]["d"] * gap
    else:
        speed = float(case["wall_speed"])
    steps = _run_strain(config, case_name, case, run) * gap / speed / dt
    if shared_fill_of(case_name, case, run) is None and predecessor_state(case_name, case, run) is None:
        steps += fill_steps(config, case)
    return case["n_grains"] * steps / PARTICLE_STEPS_PER_SECOND


def _dependents(config: dict[str, Any], case_name: str, job: str) -> list[str]:
    """The DEM jobs of the case that start from ``job`` (a shared fill's runs, a state's continuations)."""
    case = config["cases"][case_name]
    runs = [r for c, r in dem_runs(config) if c == case_name]
    if job in shared_fill_ids(case_name, case):
        return [r for r in runs if shared_fill_of(case_name, case, r) == job and predecessor_state(case_name, case, r) is None]
    return [r for r in runs if predecessor_state(case_name, case, r) == job]


def upward_rank(config: dict[str, Any], case_name: str, job: str) -> float:
    """Estimated seconds from the start of DEM job ``job`` to the report along its longest chain."""
    calibration = {c for c, _ in calibration_runs(config)}
    tail = TAIL_SECONDS["calibration" if case_name in calibration else "held_out"]
    intruders = [c for c, spec in config["cases"].items() if spec["geometry"] == "intruder"]
    if intruders and (case_name in calibration or case_name in intruders):
        tail += INTRUDER_MODEL_SECONDS

    @lru_cache(maxsize=None)
    def rank(name: str) -> float:
        after = [rank(r) for r in _dependents(config, case_name, name)]
        return estimated_seconds(config, case_name, name) + (max(after) if after else tail)

    return rank(job)


def dem_priority(config: dict[str, Any], case_name: str, job: str) -> int:
    """Snakemake ``priority`` of a DEM job: its upward rank in whole seconds, raised by
    :data:`CALIBRATION_SET_FIRST` for the calibration set's jobs and every shared fill or sheared
    bed (below :data:`AFTER_DEM_PRIORITY`)."""
    calibration = case_name in {c for c, _ in calibration_runs(config)}
    first = CALIBRATION_SET_FIRST if calibration or job in shared_fill_ids(case_name, config["cases"][case_name]) else 0
    return min(int(round(upward_rank(config, case_name, job))) + first, AFTER_DEM_PRIORITY - 1)


def intruder_model_priority(model: str) -> int:
    """Snakemake ``priority`` of an intruder model's jobs: above every other rule after the DEM,
    the slowest model's first (:data:`INTRUDER_MODELS_SLOWEST_FIRST`; a model not listed after
    them). Ordering only: nothing a job computes depends on it."""
    order = INTRUDER_MODELS_SLOWEST_FIRST
    rank = order.index(model) if model in order else len(order)
    return AFTER_DEM_PRIORITY + 1 + len(order) - rank
