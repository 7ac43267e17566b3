"""A fill (pour, settle, walls and bodies made) poured once for several runs.

Two kinds of runs start from the same settled packing (:func:`pipeline.common.runs.shared_fill_ids`):

- the rheometer's states of one replica, with ``cases.rheometer.shared_fill``: they differ only in
  the wall speed and load of their shear stage, which the fill does not read;
- an intruder case's shallowest run and its control (the same run with the top wall at rest),
  which by design share their packing: the control used to pour it again from the same seed;
- with ``cases.<intruder>.shared_bed``, every run of an intruder replica: the fill is then a bed
  poured without the rod and sheared to steady state (:mod:`pipeline.dem.sheared_bed`), into
  which each run inserts its rod.

The fill runs once in ``dem/<case>/fill-<...>/`` as its owner run's own fill would (the owner's
config and bodies, the fill's own seed); each run that starts from it copies its restart
(:meth:`PlanarShearRun._adopt_fill`) and shears from there to its own steady state. Replicas keep
their own fills, so the replica scatter stays the scatter of independent packings.

``fill.json`` (written last, under a temporary name) is the fill's record: the physics it was made
with (:func:`pipeline.common.runs.fill_physics`, checked by every run that adopts it), its
settled packing's numbers, its bodies (the intruder's rod), its steps and seconds (counted once in
the DEM bill, not per run).

Usage: ``python -m pipeline.dem --config <owner's per-run config> --case rheometer --run fill-r1 --fill-only``
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from pipeline.common.config import fill_owner_run, fill_physics, is_sheared_bed_case
from pipeline.common.formats import RUN_FORMAT_VERSION
from pipeline.common.provenance import provenance
from pipeline.dem import liggghts_render as render
from pipeline.dem.contact_law import tangential_damping
from pipeline.dem.intruder_run import IntruderRun
from pipeline.dem.planar_run import PlanarShearRun
from pipeline.dem.sheared_bed import ShearedBed


def run_shared_fill(config: dict[str, Any], case_name: str, fill: str, run_dir: Path) -> dict[str, Any]:
    """Pour and settle the fill ``fill`` of ``case_name`` into ``run_dir``; return its ``fill.json`` record."""
    case = config["cases"][case_name]
    owner = fill_owner_run(case_name, case, fill)
    if is_sheared_bed_case(case):
        # Poured without the rod and sheared to steady state; each run inserts its own rod.
        return ShearedBed(config, case_name, fill, run_dir).run()
    runner_class = IntruderRun if case["geometry"] == "intruder" else PlanarShearRun
    # The owner run's own set-up (cell, bodies), filling this folder instead of its own.
    runner = runner_class(config, case_name, owner, run_dir)
    runner.label = f"DEM fill {case_name}/{fill}"
    physics = fill_physics(config, case_name, fill)
    runner.seed = physics["seed"]
    run_dir.mkdir(parents=True, exist_ok=True)
    render.copy_templates(case["geometry"], run_dir, tangential_damping(config["material"]))
    runner.state = {"fingerprint": physics, "chunks": [], "steady": None, "wall_seconds": 0.0}
    runner._fill()
    made = runner.state["fill"]
    bodies = runner.state.get("intruder")
    return {
        "format_version": RUN_FORMAT_VERSION,
        "case": case_name,
        "run": fill,
        "owner": owner,
        "physics": physics,
        "seed": runner.seed,
        "fill": made,
        "bodies": bodies,
        "particle_count": case["n_grains"] + made["n_bottom_wall_grains"] + made["n_top_wall_grains"]
                          + (bodies["n_grains"] if bodies else 0),
        "steps_by_stage": {"fill": int(made["steps"])},
        "wall_seconds_by_stage": {"fill": float(made["wall_seconds"])},
        "mpi_ranks": runner.dem["mpi_ranks"],
        "mpi_launcher": runner.dem["mpi_launcher"],
        "mpi_start": runner.engine.start,
        "provenance": provenance(config),
    }
