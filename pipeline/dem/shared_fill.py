"""One fill (pour, settle, walls made) shared by the states of a rheometer replica.

The rheometer's states of one replica differ only in their wall speed and load, set at the shear
stage; the fill reads neither. So with ``cases.rheometer.shared_fill`` the replica's fill runs
once, in ``dem/rheometer/fill-r<k>/``, and every state of that replica copies its restart and
shears from it to its own steady state (:meth:`PlanarShearRun._adopt_fill`). Replicas keep their
own fills (their seeds differ), so the replica scatter stays the scatter of independent packings.

``fill.json`` (written last, under a temporary name) is the fill's record: the physics it was made
with (:func:`pipeline.common.config.fill_physics`, checked by every run that adopts it), its
settled packing's numbers, its steps and seconds (counted once in the DEM bill, not per state).

Usage: ``python -m pipeline.dem --config <per-run config> --case rheometer --run fill-r1 --fill-only``
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from pipeline.common.config import derived_seed, fill_owner_run, fill_physics
from pipeline.common.formats import RUN_FORMAT_VERSION
from pipeline.common.provenance import provenance
from pipeline.dem import liggghts_render as render
from pipeline.dem.planar_run import PlanarShearRun


class SharedFill(PlanarShearRun):
    """The fill stage of a planar run alone, seeded by the fill's own id (not by any state's)."""

    def __init__(self, config: dict[str, Any], case_name: str, fill: str, run_dir: Path) -> None:
        # The fill's settings are those of any state of the replica (it reads none of a state's
        # own); the owner state only supplies a valid run id to the shared set-up.
        super().__init__(config, case_name, fill_owner_run(case_name, config["cases"][case_name], fill), run_dir)
        self.fill_id = fill
        self.seed = derived_seed(config["seed"], case_name, fill)
        self.label = f"DEM fill {case_name}/{fill}"

    def run(self) -> dict[str, Any]:
        """Pour and settle; return the ``fill.json`` record."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        render.copy_templates(self.case["geometry"], self.run_dir)
        physics = fill_physics(self.config, self.case_name, self.fill_id)
        self.state = {"fingerprint": physics, "chunks": [], "steady": None, "wall_seconds": 0.0}
        self._fill()
        fill = self.state["fill"]
        return {
            "format_version": RUN_FORMAT_VERSION,
            "case": self.case_name,
            "run": self.fill_id,
            "physics": physics,
            "seed": self.seed,
            "fill": fill,
            "particle_count": self.case["n_grains"] + fill["n_bottom_wall_grains"] + fill["n_top_wall_grains"],
            "steps_by_stage": {"fill": int(fill["steps"])},
            "wall_seconds_by_stage": {"fill": float(fill["wall_seconds"])},
            "mpi_ranks": self.dem["mpi_ranks"],
            "mpi_launcher": self.dem["mpi_launcher"],
            "provenance": provenance(self.config),
        }
