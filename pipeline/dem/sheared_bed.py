"""The intruder's shared pre-sheared bed (``cases.<case>.shared_bed``): one bed per replica, sheared
to steady state once, into which every rod run of the replica inserts its rod.

Without it every rod run (each depth, each push of the force sweep, the control) pours its own bed
around its rod and shears it to steady state: 57 % of the pushed rods' particle-steps were that
start-up (docs/dem_cost.md, section 15). With it:

1. **The bed** (``dem/<case>/fill-sheared-r<k>/``, :class:`ShearedBed`): the case's cell, load,
   gravity and wall speed without the rod, poured with :func:`displaced_grains` grains more than
   the case's (those the rod will displace), then sheared in the case's chunks until the planar
   steady-state test passes, the creep of the bed included (issue 29's test of the window's creep
   against the window before it, band by band; after the case's ``min_shear_strain``). No
   production: its record (``fill.json``) names its final restart and a snapshot of that state
   (``bed.dump``, id type x y z radius), and its fill and shear steps, counted once in the bill.
2. **A rod run** (:func:`insert_rod`, the ``insert`` stage, ``liggghts_inputs/intruder/insert.in``):
   from the bed's final restart, the flowing grains that overlap the rod (centre closer to its axis
   than the rod's radius plus their own, periodic along x) are deleted and the rod's grains created
   with its axis ``depth`` below the top wall's centres, lowered by the settling expected when the
   hole closes (:func:`plan_insertion`). The run then shears as before: its steady-state test
   (the wall's and the rod's speed over two windows, ``IntruderRun._steady_test``) measures its
   re-equilibration, and production follows. The sheared runs keep the bed's velocities (no
   Couette ramp at their first chunk); a control's first chunk sets the grains' x velocities to
   zero, its wall being at rest.

The replicas keep their own beds and seeds, so the replica scatter stays that of independent
packings; what the runs of one replica now share is the packing (the depths and pushes of one
replica are not independent of each other, as the rheometer's states of one replica are not).
``benchmarks/shared_bed_check.py`` compares the rods' speeds of both designs.
"""
from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.common.config import fill_physics, mean_grain_volume, shared_fill_of
from pipeline.common.formats import RUN_FORMAT_VERSION
from pipeline.common.provenance import provenance
from pipeline.dem import liggghts_render as render
from pipeline.dem.liggghts_log import DEMRunError, printed_value
from pipeline.dem.planar_run import FILL_RECORD, PlanarShearRun, read_settled, run_liggghts

#: Solid fraction of the sheared bed around the rod, for the grains it displaces and the settling
#: when the hole closes (the intruder's BED_SOLID_FRACTION).
BED_SOLID_FRACTION = 0.6
#: Settings of an intruder case that are the rod's, not the bed's.
ROD_KEYS = ("rod_diameter", "depths_below_top", "force", "yield_coefficient", "control", "force_sweep", "shared_bed")
#: The bed's final state, as a one-snapshot dump (id type x y z radius), in the bed's folder.
BED_SNAPSHOT = "bed.dump"
#: The bed's final restart, as a rod run copies it.
BED_RESTART = "bed.restart"
#: Include file of the insert stage: the grains to delete and the rod's grains to create.
ROD_INSERT = "rod_insert.in"
#: Share of the geometric settling (the displaced grains' bulk volume less the rod's, over the
#: cell's area) that the top wall falls once the hole around an inserted rod closes. Measured on
#: the reduced intruder (8 x 3 d, rod 3 d at 4 d): the top wall fell 0.38 d where the geometric
#: settling is 0.87 d; the rest stays as the loose layer a wall keeps around it, as a rod the
#: grains were poured around keeps too.
SETTLING_SHARE = 0.5
TEMPLATES = render.TEMPLATE_ROOT / "intruder"


def displaced_grains(config: dict[str, Any], case: dict[str, Any]) -> int:
    """Grains (count) a rod of the case displaces from a bed at :data:`BED_SOLID_FRACTION`: those
    whose centre lies within the rod's radius plus a mean grain radius of its axis, over the
    cell's length along y. The bed is poured with that many more than ``n_grains``, so that a run
    keeps about the case's grains around its rod, as when they were poured around it."""
    mat = config["material"]
    d = float(mat["d"])
    reach = 0.5 * float(case["rod_diameter"]) * d + 0.5 * d
    volume = math.pi * reach**2 * float(case["cell_y"]) * d
    return int(round(BED_SOLID_FRACTION * volume / mean_grain_volume(d, mat["polydispersity"], mat["n_sizes"])))


def bed_config(config: dict[str, Any], case_name: str) -> dict[str, Any]:
    """The config of a case's bed: a planar shear case with gravity of the case's cell, load and
    wall speed, no rod, and :func:`displaced_grains` more grains, run with LIGGGHTS."""
    case = config["cases"][case_name]
    planar = {k: v for k, v in case.items() if k not in ROD_KEYS}
    planar |= {"geometry": "planar_shear", "n_grains": int(case["n_grains"]) + displaced_grains(config, case)}
    # An intruder case runs under LIGGGHTS only (the config check refuses dem.engine: lammps with one).
    return {**config, "cases": {case_name: planar}}


class ShearedBed(PlanarShearRun):
    """One replica's bed: fill, then shear chunks until the steady-state test passes; no production."""

    def __init__(self, config: dict[str, Any], case_name: str, bed: str, run_dir: Path) -> None:
        super().__init__(bed_config(config, case_name), case_name, bed, run_dir)
        self.intruder_config = config
        self.label = f"DEM sheared bed {case_name}/{bed}"
        self.physics = fill_physics(config, case_name, bed)
        self.seed = self.physics["seed"]

    def _production_stop(self, produced: list[dict[str, Any]], plan: dict[str, int]) -> dict[str, Any] | None:
        """The bed produces nothing: its rods do, each after its own steady-state test."""
        return {"design": "sheared bed", "reason": "steady state reached: the rods inserted into the bed produce",
                "strain": 0.0, "chunks": len(produced)}

    def _record(self, plan: dict[str, int]) -> dict[str, Any]:
        """The bed's ``fill.json``: its fill, its final restart and snapshot, its steps."""
        chunks = self.state["chunks"]
        last = chunks[-1]
        shutil.copyfile(TEMPLATES / "bed_snapshot.in", self.run_dir / "bed_snapshot.in")
        render.render_stage(self.run_dir, "snapshot", "bed_snapshot.in",
                            self._base_variables() | {"restart_in": last["restart"], "snapshot_file": BED_SNAPSHOT + ".tmp"})
        seconds = run_liggghts(self.launcher, self.run_dir, "snapshot", self.label)
        (self.run_dir / (BED_SNAPSHOT + ".tmp")).replace(self.run_dir / BED_SNAPSHOT)
        snapshot = read_settled(self.run_dir / BED_SNAPSHOT)
        made = self.state["fill"]
        n_grains = int(self.case["n_grains"])
        if int((snapshot["type"] == 1).sum()) != n_grains:
            raise DEMRunError(f"{self.label}: its final snapshot holds {int((snapshot['type'] == 1).sum())} grains, not {n_grains}")
        steps = {"fill": int(made["steps"]), "shear": int(sum(c["steps"] for c in chunks))}
        return {
            "format_version": RUN_FORMAT_VERSION,
            "case": self.case_name,
            "run": self.run_id,
            "owner": None,
            "physics": self.physics,
            "seed": self.seed,
            "fill": made,
            "bed": {"restart": last["restart"], "snapshot": BED_SNAPSHOT, "n_grains": n_grains,
                    "displaced_grains": displaced_grains(self.intruder_config, self.intruder_config["cases"][self.case_name]),
                    "z_top_wall": float(snapshot.loc[snapshot["type"] == 3, "z"].mean()),
                    "time": float(last["t_end"]), "shear_chunks": len(chunks),
                    "strain": len(chunks) * float(self.dem["chunk_strain"]),
                    "steady_state_test": self.state["steady"], "snapshot_seconds": seconds},
            "bodies": None,
            "particle_count": n_grains + made["n_bottom_wall_grains"] + made["n_top_wall_grains"],
            "steps_by_stage": steps,
            "wall_seconds_by_stage": {"fill": float(made["wall_seconds"]),
                                      "shear": float(sum(c["wall_seconds"] for c in chunks))},
            "mpi_ranks": self.dem["mpi_ranks"],
            "mpi_launcher": self.dem["mpi_launcher"],
            "mpi_start": self.engine.start,
            "provenance": provenance(self.intruder_config),
        }


@dataclass(frozen=True)
class Insertion:
    """Where a rod goes into a bed, and which grains leave for it.

    Attributes:
        z_rod: height of the rod's axis (m).
        removed_ids: ids of the flowing grains that overlap the rod.
        settling: expected fall of the top wall when the hole closes (m), :func:`expected_settling`.
    """

    z_rod: float
    removed_ids: tuple[int, ...]
    settling: float


def overlapping(grains: pd.DataFrame, x_rod: float, z_rod: float, rod_radius: float, lx: float) -> np.ndarray:
    """Mask of the grains (columns x, z, radius; m) that overlap a rod along y with its axis at
    (``x_rod``, ``z_rod``): centre closer than the rod's radius plus their own, x periodic in ``lx``."""
    dx = np.asarray(grains["x"], dtype=float) - x_rod
    dx -= lx * np.round(dx / lx)
    distance = np.hypot(dx, np.asarray(grains["z"], dtype=float) - z_rod)
    return distance < rod_radius + np.asarray(grains["radius"], dtype=float)


def expected_settling(config: dict[str, Any], case: dict[str, Any]) -> float:
    """Expected fall (m) of the top wall when the hole around an inserted rod closes:
    :data:`SETTLING_SHARE` of the displaced grains' bulk volume (:func:`displaced_grains` grains
    at :data:`BED_SOLID_FRACTION`) less the rod's, over the cell's area."""
    mat = config["material"]
    d = float(mat["d"])
    ly = float(case["cell_y"]) * d
    bulk = displaced_grains(config, case) * mean_grain_volume(d, mat["polydispersity"], mat["n_sizes"]) / BED_SOLID_FRACTION
    rod = math.pi * (0.5 * float(case["rod_diameter"]) * d) ** 2 * ly
    return SETTLING_SHARE * max(0.0, bulk - rod) / (float(case["cell_x"]) * d * ly)


def plan_insertion(snapshot: pd.DataFrame, x_rod: float, depth: float, rod_radius: float, lx: float, settling: float) -> Insertion:
    """The rod's height and the grains to delete, for a rod axis ``depth`` (m) below the top wall's
    centres of ``snapshot`` (columns id type x z radius; type 1 flowing, 3 top wall) once the hole
    around it has closed, the top wall having fallen by ``settling`` (m, :func:`expected_settling`)."""
    z_top = float(snapshot.loc[snapshot["type"] == 3, "z"].mean())
    grains = snapshot[snapshot["type"] == 1]
    z_rod = z_top - depth - settling
    gone = overlapping(grains, x_rod, z_rod, rod_radius, lx)
    return Insertion(z_rod, tuple(int(i) for i in grains.loc[gone, "id"]), settling)


def insert_rod(run: Any, source: Path) -> None:
    """Start ``run`` (an :class:`pipeline.dem.intruder_run.IntruderRun`) from the sheared bed in
    ``source``: check the bed was made with the physics the run's config gives it, copy its final
    restart, delete the grains the rod overlaps and create the rod (the ``insert`` stage), and
    record the bed as the run's shared start (its steps counted once, in the bed's ``fill.json``)."""
    record_path = source / FILL_RECORD
    if not record_path.is_file():
        raise DEMRunError(f"{run.label}: --fill-from {source}: no {FILL_RECORD} there (the sheared bed has not run)")
    record = json.loads(record_path.read_text())
    own = shared_fill_of(run.case_name, run.case, run.run_id)
    if record.get("run") != own or "bed" not in record or record.get("physics") != fill_physics(run.config, run.case_name, own):
        raise DEMRunError(f"{run.label}: {record_path} is {record.get('run')!r}, not the sheared bed {own!r} this run's "
                          "config gives it (material, cell, load, DEM settings or seed differ): rerun the bed")
    bed = record["bed"]
    d = run.mat["d"]
    lx, ly = run.case["cell_x"] * d, run.rod_length
    radius = 0.5 * run.rod_diameter
    shutil.copy2(source / bed["restart"], run.run_dir / BED_RESTART)
    shutil.copy2(source / bed["snapshot"], run.run_dir / BED_SNAPSHOT)
    snapshot = read_settled(run.run_dir / BED_SNAPSHOT)
    x_rod = 0.25 * lx
    plan = plan_insertion(snapshot, x_rod, run.depth_over_d * d, radius, lx, expected_settling(run.config, run.case))
    z_bottom = float(record["fill"]["z_bottom_wall"])
    if plan.z_rod - radius - z_bottom < 2.0 * d:
        raise DEMRunError(f"{run.label}: a rod {run.depth_over_d:g} d below the top of the sheared bed is within 2 d of the "
                          "bottom wall (more grains or a shallower depth)")
    spacing = ly / run.n_rod
    # Density such that the rod weighs what a solid cylinder of grain material would.
    rho_rod = run.mat["rho_s"] * (math.pi * radius**2 * ly) / (run.n_rod * math.pi * run.rod_diameter**3 / 6.0)
    lines = []
    if plan.removed_ids:
        lines += [f"group gone id {' '.join(str(i) for i in plan.removed_ids)}", "delete_atoms group gone compress no"]
    lines += [f"create_atoms 4 single {x_rod!r} {(k + 0.5) * spacing!r} {plan.z_rod!r} units box" for k in range(run.n_rod)]
    lines += [f"set type 4 diameter {run.rod_diameter!r}", f"set type 4 density {rho_rod!r}"]
    (run.run_dir / ROD_INSERT).write_text("\n".join(lines) + "\n")
    render.render_stage(run.run_dir, "insert", "insert.in", run._base_variables() | {
        "restart_in": BED_RESTART, "restart_out": "fill.restart.tmp"}, generated=(*render.GENERATED_INCLUDES, ROD_INSERT))
    seconds = run_liggghts(run.launcher, run.run_dir, "insert", run.label)
    flowing = int(printed_value(run.run_dir / "logs" / "insert.log", "FLOW_GRAINS"))
    rod_grains = int(printed_value(run.run_dir / "logs" / "insert.log", "ROD_GRAINS"))
    if flowing != bed["n_grains"] - len(plan.removed_ids) or rod_grains != run.n_rod:
        raise DEMRunError(f"{run.label}: the insert stage left {flowing} grains and {rod_grains} rod grains "
                          f"(expected {bed['n_grains'] - len(plan.removed_ids)} and {run.n_rod})")
    (run.run_dir / "fill.restart.tmp").replace(run.run_dir / "fill.restart")
    run.state["intruder"] = {"first_id": None, "n_grains": run.n_rod, "x0": x_rod, "z": plan.z_rod, "expected_gap": None,
                             "grain_density": rho_rod, "spacing": spacing,
                             "inserted": {"bed": record["run"], "removed_grains": len(plan.removed_ids),
                                          "flowing_grains": flowing, "settling_over_d": plan.settling / d,
                                          "z_top_wall": bed["z_top_wall"], "bed_time": bed["time"]}}
    run.state["fill"] = record["fill"] | {
        "z_top_wall": bed["z_top_wall"], "steps": 0, "wall_seconds": seconds,
        "shared": {"run": record["run"], "steps": sum(record["steps_by_stage"].values()),
                   "wall_seconds": sum(record["wall_seconds_by_stage"].values())}}
    run.state["wall_seconds"] += seconds
    run._save_state()
