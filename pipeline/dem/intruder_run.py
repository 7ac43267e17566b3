"""DEM runs of the intruder case: a rigid rod along y, pushed along +x, in planar shear with gravity.

The geometry is that of ``shear_gravity`` (periodic in x and y, bottom rough wall at rest, top
rough wall at ``wall_speed`` along +x under ``wall_pressure``, gravity along -z) with a rod of
diameter ``rod_diameter`` d spanning the periodic y direction, its axis ``depth`` d below the top
wall's centres. The rod is a line of overlapping type-4 grains made one rigid body (LIGGGHTS
``fix rigid single``) that is free along x only: its height and orientation are held, because the
measurement is the creep speed *at a given depth* (a rod free along z would sink or rise). A
constant total force ``F`` along +x is shared equally by its grains (``fix addforce``).

``F`` is a fraction (``force``) of the rod's yield force at the shallowest depth when nothing
else flows, ``F_yield = yield_coefficient * p * D * L``, with ``p`` the hydrostatic estimate of
the pressure at the rod's axis (:func:`hydrostatic_pressure`), ``D`` its diameter and ``L`` the
cell length along y. ``yield_coefficient`` is measured with :class:`YieldProbe` (top wall at rest,
a staircase of forces; ``python -m pipeline.dem --probe-yield``) and written in the
config. All runs of a case use the same ``F``; the control run (``D<depth>-control-r<k>``) repeats
the shallowest run with the top wall at rest, from the same settled packing (poured once,
``fill-D<depth>-r<k>``: :mod:`pipeline.dem.shared_fill`). With ``shared_bed`` every run of a replica
instead inserts its rod into the replica's bed, sheared to steady state once
(``fill-sheared-r<k>``: :mod:`pipeline.dem.sheared_bed`). The rod's speed statistics are
:mod:`pipeline.dem.rod_speed`'s.

Run ids: ``D<depth in d>-r<k>`` and ``D<depth in d>-control-r<k>``. Sign conventions: x is the
flow direction, z up, gravity along -z; the rod's speed is positive along +x (the push and the
top wall's motion).

Usage::

    python -m pipeline.dem --config config/ci.yaml --case intruder --run D4-r1 --out /tmp/i
    python -m pipeline.dem --config config/ci.yaml --case intruder --run D4-control-r1 --probe-yield --out /tmp/p
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.common import atomic
from pipeline.dem import liggghts_render as render
from pipeline.dem.contact_law import tangential_damping
from pipeline.dem import precision
from pipeline.common.config import intruder_push, intruder_run, is_sheared_bed_case, mean_grain_volume
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.planar_run import PlanarShearRun
from pipeline.dem import sheared_bed
from pipeline.scoring.rod_steadiness import classify, split_durations
# The rod's speed statistics (re-exported: runs, benchmarks and tests import them from here).
from pipeline.dem.rod_speed import (SPEED_BLOCKS, CreepSpeed, creep_speed, is_arrested, production_halves,  # noqa: F401
                                    rod_speed_settled)

#: Solid fraction assumed for the settled bed when placing the rod (the real depth is recorded).
BED_SOLID_FRACTION = 0.6
#: Height (in d) added to the bed's solid height / BED_SOLID_FRACTION to get the wall-to-wall gap
#: under shear: the wall layers and the loose top of the poured bed (+2.2 d at the fill) less the
#: compaction under the load and shear (-0.9 d), both measured on a reduced intruder run.
WALL_LAYERS_OVER_D = 1.3
#: Spacing (in d) of the rod's grains along y: the bumps of the rod's surface are 0.02 d deep at D = 3 d.
ROD_SPACING_OVER_D = 0.5
#: Smallest clearance (in d) between the rod's surface and the bottom wall's centres.
MIN_BOTTOM_CLEARANCE_OVER_D = 2.0
#: Columns of the intruder series (``fix ave/time`` in liggghts_inputs/intruder/shear.in).
INTRUDER_COLUMNS = ("step", "time", "x", "vx", "z", "fx_contact", "fz_contact")
#: Yield probe: push forces, as multiples of p D L, held one chunk each (0 first: the bed settles under the load).
PROBE_COEFFICIENTS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)
#: Yield probe: a step in which the rod moves more than this (in d) is above the yield force.
PROBE_YIELD_DISPLACEMENT_OVER_D = 0.5


def rest_speed_of(config: dict[str, Any], case_name: str) -> float:
    """Speed (m/s) at or below which a case's rod is at rest: ``dem.precision.rod_arrest_speed_over_v``
    times the case's wall speed, or 0 (only the 2-sigma rule) where the config names none."""
    bound = (config["dem"].get("precision") or {}).get("rod_arrest_speed_over_v")
    return 0.0 if bound is None else float(bound) * float(config["cases"][case_name]["wall_speed"])


def hydrostatic_pressure(wall_pressure: float, rho_s: float, gravity: float, depth: float,
                         solid_fraction: float = BED_SOLID_FRACTION) -> float:
    """Vertical stress (Pa, compressive positive) at ``depth`` (m) below the top wall: P + nu rho_s g depth."""
    return wall_pressure + solid_fraction * rho_s * gravity * depth


def unwrap(x: np.ndarray, lx: float) -> np.ndarray:
    """Positions (m) wrapped into a periodic cell of length ``lx`` made continuous (jumps below lx / 2)."""
    return np.unwrap(np.asarray(x, dtype=float), period=lx)


def read_intruder_series(path: Path) -> pd.DataFrame:
    """One intruder series file: step, time (s), x, z (m, rod centre of mass; x wrapped into the
    cell, see :func:`unwrap`), vx (m/s), fx_contact, fz_contact (N, force of the grains on the rod,
    the push excluded)."""
    if not path.exists():
        raise DEMRunError(f"{path}: intruder series file not found")
    data = np.loadtxt(path, comments="#", ndmin=2)
    if data.shape[1] != len(INTRUDER_COLUMNS) or not np.all(np.isfinite(data)):
        raise DEMRunError(f"{path}: expected {len(INTRUDER_COLUMNS)} finite columns, found shape {data.shape}")
    return pd.DataFrame(data, columns=list(INTRUDER_COLUMNS))


class IntruderRun(PlanarShearRun):
    """One run of the intruder case (see the module docstring); reuses the planar-shear stages."""

    def __init__(self, config: dict[str, Any], case_name: str, run_id: str, run_dir: Path,
                 fill_from: Path | None = None) -> None:
        super().__init__(config, case_name, run_id, run_dir, fill_from=fill_from)
        # A control and its sheared twin share their fill (fill-D<depth>-r<k>) and so its seed:
        # one settled packing, walls and rod; the control differs by the wall at rest only.
        self.depth_over_d, self.control, _ = intruder_run(run_id)
        self.push_fraction = intruder_push(run_id)
        d = self.mat["d"]
        self.rod_diameter = float(self.case["rod_diameter"]) * d
        self.rod_length = float(self.case["cell_y"]) * d
        self.n_rod = max(1, int(round(self.case["cell_y"] / ROD_SPACING_OVER_D)))
        #: The rod goes into the replica's shared pre-sheared bed (pipeline.dem.sheared_bed).
        self.from_sheared_bed = is_sheared_bed_case(self.case)

    def run(self) -> dict[str, Any]:
        """Run (or resume) the stages; a run of a case with ``shared_bed`` starts from its replica's bed."""
        if self.from_sheared_bed and self.fill_from is None:
            raise DEMRunError(f"{self.label}: cases.{self.case_name}.shared_bed: the rod goes into its replica's sheared bed; "
                              "give --fill-from that bed's folder (dem/<case>/fill-sheared-r<k>, made with --fill-only)")
        return super().run()

    def _adopt_fill(self, source: Path) -> None:
        """A shared fill's packing (the control and its twin), or the replica's sheared bed with
        this run's rod inserted (:func:`pipeline.dem.sheared_bed.insert_rod`)."""
        if self.from_sheared_bed:
            sheared_bed.insert_rod(self, source)
        else:
            super()._adopt_fill(source)

    # ----------------------------------------------------------------------------- the force
    def yield_force_estimate(self) -> float:
        """Yield force (N) of the rod at rest at the case's shallowest depth (config ``yield_coefficient``)."""
        d = self.mat["d"]
        shallowest = min(self.case["depths_below_top"]) * d
        p = hydrostatic_pressure(self.wall_pressure, self.mat["rho_s"], self.case["gravity"], shallowest)
        return float(self.case["yield_coefficient"]) * p * self.rod_diameter * self.rod_length

    def yield_force_here(self) -> float:
        """Yield force (N) of the rod at rest at its own depth (config ``yield_coefficient``)."""
        d = self.mat["d"]
        p = hydrostatic_pressure(self.wall_pressure, self.mat["rho_s"], self.case["gravity"], self.depth_over_d * d)
        return float(self.case["yield_coefficient"]) * p * self.rod_diameter * self.rod_length

    def cell_area(self) -> float:
        """The periodic cell's area L_x L_y (m2) in the wall plane."""
        d = self.mat["d"]
        return float(self.case["cell_x"]) * d * float(self.case["cell_y"]) * d

    def push_force(self) -> float:
        """Total push on the rod along +x (N): ``force`` x the shallowest depth's yield force, the same for
        every depth of the depth sweep and for the control; a force-sweep run's own fraction of the yield
        force at its own depth."""
        if self.push_fraction is not None:
            return self.push_fraction * self.yield_force_here()
        return float(self.case["force"]) * self.yield_force_estimate()

    # ------------------------------------------------------------------------- planar hooks
    def wall_speed(self) -> float:
        """Top-wall speed (m/s): the case's, or 0 for the control run."""
        return 0.0 if self.control else float(self.case["wall_speed"])

    def reference_speed(self) -> float:
        """The case's wall speed even for the control: its chunks last as long as the sheared runs'."""
        return float(self.case["wall_speed"])

    def _write_fill_bodies(self, first_id: int, z_bottom: float) -> int:
        """Write ``intruder.in`` (the rod's grains) and return their number.

        The rod's height comes from the expected bed: ``n_grains`` grains at solid fraction
        :data:`BED_SOLID_FRACTION` plus the rod's own cross-section, over the cell area, plus the
        wall layers. The depth actually reached is measured after the fill and recorded.
        """
        d, rho = self.mat["d"], self.mat["rho_s"]
        lx, ly = self.case["cell_x"] * d, self.rod_length
        radius = 0.5 * self.rod_diameter
        v_grains = self.case["n_grains"] * mean_grain_volume(d, self.mat["polydispersity"], self.mat["n_sizes"])
        gap = (v_grains / BED_SOLID_FRACTION + math.pi * radius**2 * ly) / (lx * ly) + WALL_LAYERS_OVER_D * d
        z_rod = z_bottom + gap - self.depth_over_d * d
        if z_rod - radius - z_bottom < MIN_BOTTOM_CLEARANCE_OVER_D * d:
            raise DEMRunError(
                f"{self.label}: a rod {self.depth_over_d:g} d below the top of an expected {gap / d:.1f} d bed is within "
                f"{MIN_BOTTOM_CLEARANCE_OVER_D:g} d of the bottom wall (more grains or a shallower depth)"
            )
        spacing = ly / self.n_rod
        # Density such that the rod weighs what a solid cylinder of grain material would.
        rho_rod = rho * (math.pi * radius**2 * ly) / (self.n_rod * math.pi * self.rod_diameter**3 / 6.0)
        x_rod = 0.25 * lx
        lines = [f"create_atoms 4 single {x_rod!r} {(k + 0.5) * spacing!r} {z_rod!r} units box" for k in range(self.n_rod)]
        for k in range(self.n_rod):
            lines.append(f"set atom {first_id + k} diameter {self.rod_diameter!r}")
            lines.append(f"set atom {first_id + k} density {rho_rod!r}")
        (self.run_dir / "intruder.in").write_text("\n".join(lines) + "\n")
        self.state["intruder"] = {"first_id": first_id, "n_grains": self.n_rod, "x0": x_rod, "z": z_rod,
                                  "expected_gap": gap, "grain_density": rho_rod, "spacing": spacing}
        return self.n_rod

    def _chunk_variables(self, stage: str) -> dict[str, object]:
        out: dict[str, object] = {"rod_force_per_grain": self._chunk_force(stage) / self.n_rod,
                                  "intruder_file": f"series/intruder_{stage}.txt"}
        if self.from_sheared_bed and not self.state["chunks"]:
            # A sheared bed already flows: its velocities are kept (a Couette ramp would replace its
            # creep profile by a linear one). A control's wall is at rest: the ramp to 0 stops the grains.
            out["first_chunk"] = int(self.control)
        return out

    def _chunk_force(self, stage: str) -> float:
        """Total push (N) during one chunk: constant here; a staircase in :class:`YieldProbe`."""
        return self.push_force()

    # --------------------------------------------------------------------------- analysis
    def intruder_series(self, t_start: float, t_end: float) -> pd.DataFrame:
        """The rod's series of all committed chunks, restricted to ``t_start <= time <= t_end`` (s)."""
        frames = [read_intruder_series(self.run_dir / "series" / f"intruder_{c['stage']}.txt")
                  for c in self.state["chunks"] if c["t_end"] >= t_start and c["t_start"] <= t_end]
        data = pd.concat(frames, ignore_index=True)
        data["x"] = unwrap(data["x"].to_numpy(), self.case["cell_x"] * self.mat["d"])
        return data[(data["time"] >= t_start) & (data["time"] <= t_end)].reset_index(drop=True)

    def rest_speed(self) -> float:
        """Speed (m/s) at or below which the rod is at rest (:func:`rest_speed_of`)."""
        return rest_speed_of(self.config, self.case_name)

    def rod_creep(self, t_start: float, t_end: float, n_blocks: int = SPEED_BLOCKS) -> CreepSpeed:
        """The rod's speed over committed chunks between ``t_start`` and ``t_end`` (s)."""
        series = self.intruder_series(t_start, t_end)
        return creep_speed(series["time"].to_numpy(), series["x"].to_numpy(), n_blocks, self.rest_speed())

    def _steady_test(self, window_chunks: list[dict[str, Any]]) -> dict[str, Any]:
        """The wall's steady-state test, and the rod's: its speed over the window agrees with its
        speed over as many shear chunks before (:func:`rod_speed_settled`, ``tol`` =
        ``dem.steady_rod_speed_tol``).

        Why two windows: the rod is pushed from the first shear chunk, jumps by about a grain and
        slows for 1-1.5 s (2-3 strain units) to a plateau, while the wall is steady after
        0.3-0.6 s. On the fixed design's six sheared rods (whole series, docs/dem_cost.md) the
        earlier test, the two halves of one window, passed at its first chance for all six, and
        five then gave 1.8-5.5 times their plateau speed.
        """
        test = super()._steady_test(window_chunks)
        tol = self.dem.get("steady_rod_speed_tol")
        if tol is None:
            return test
        shear = [c for c in self.state["chunks"] if c["kind"] == "shear"]
        first = next(k for k, c in enumerate(shear) if c["t_start"] == window_chunks[0]["t_start"])
        latest = self.rod_creep(window_chunks[0]["t_start"], window_chunks[-1]["t_end"], n_blocks=4)
        before = None
        if first >= len(window_chunks):
            earlier = shear[first - len(window_chunks):first]
            before = self.rod_creep(earlier[0]["t_start"], earlier[-1]["t_end"], n_blocks=4)
        rod = rod_speed_settled(before, latest, float(tol), self.rest_speed())
        return test | {"rod": rod, "stationary": bool(test["stationary"] and rod["stationary"])}

    def _steady_summary(self, test: dict[str, Any]) -> str:
        rod = test.get("rod")
        if rod is None:
            return super()._steady_summary(test)
        if "speed_before" not in rod:
            where = "at rest" if rod["at_rest"] else "no earlier window yet"
            return f"{super()._steady_summary(test)}; rod {rod['speed'] * 1e3:.3g} mm/s, {where}"
        change = abs(rod["speed_before"] - rod["speed"])
        # A rod held still to the last digit (a weak push with the wall at rest) has nothing allowed and no change.
        share = change / rod["allowed"] if rod["allowed"] > 0 else (0.0 if change == 0 else math.inf)
        return (f"{super()._steady_summary(test)}; rod {rod['speed'] * 1e3:.3g} mm/s against "
                f"{rod['speed_before'] * 1e3:.3g} before, {share:.2f} of allowed")

    def _window_is_production(self) -> bool:
        """Only a control's steady window (its rod at rest over it) starts the production.

        A moving rod's window stays out: replayed on the fixed design's whole rod series, the
        window that passes the rod test still holds the end of the start-up in some runs, and
        counting it measured D5-r2 at 0.96 mm/s and D9-r2 at 0.30 against plateaus of 0.64 and
        0.17 (the production after it: 0.46, 0.13) (docs/dem_cost.md, section 12).
        """
        return self.control and super()._window_is_production()

    def precision_targets(self, precision_cfg: dict[str, Any]) -> dict[str, float]:
        """The intruder is scored on its rod's creep speed: its relative error is the target, or
        for a rod at rest the bound on its speed."""
        names = ("rod_speed_rel", "rod_arrest_speed_over_v") + (() if self.control else ("rod_min_travel_over_d",))
        return {k: float(precision_cfg[k]) for k in names if k in precision_cfg}

    def production_precision(self, produced: list[dict[str, Any]], precision_cfg: dict[str, Any]) -> dict[str, Any]:
        """Relative error of the rod's speed over the production so far (``rod_speed_rel``), and
        its speed's 2-sigma bound over the wall speed (``rod_arrest_speed_over_v``): either target
        met stops the production, since for a rod at rest (the controls) more averaging only
        confirms a speed below anything scored."""
        targets = {k: v for k, v in self.precision_targets(precision_cfg).items() if k != "rod_min_travel_over_d"}
        creep = self.rod_creep(produced[0]["t_start"], produced[-1]["t_end"])
        # The targets are met by the error's upper confidence bound (pipeline.dem.precision.judge).
        upper_err = creep.speed_err * precision.error_bound_factor(SPEED_BLOCKS)
        reached: dict[str, float] = {}
        bound: dict[str, float] = {}
        if "rod_speed_rel" in targets:
            reached["rod_speed_rel"] = abs(creep.speed_err / creep.speed) if creep.speed != 0 else math.inf
            bound["rod_speed_rel"] = abs(upper_err / creep.speed) if creep.speed != 0 else math.inf
        if "rod_arrest_speed_over_v" in targets:
            reached["rod_arrest_speed_over_v"] = (abs(creep.speed) + 2.0 * creep.speed_err) / self.reference_speed()
            bound["rod_arrest_speed_over_v"] = (abs(creep.speed) + 2.0 * upper_err) / self.reference_speed()
        judged = precision.judge(reached, targets, SPEED_BLOCKS, bound)
        at_rest = bool(judged["met"].get("rod_arrest_speed_over_v", False))
        resolved = bool(judged["met"].get("rod_speed_rel", False))
        min_travel = precision_cfg.get("rod_min_travel_over_d")
        if min_travel is not None and not self.control:
            # A moving rod's speed counts once the rod has left the cage it started in (issue 55,
            # pipeline.scoring.rod_steadiness): its travel is a lower bound, not an error, so it is
            # judged apart from the errors' upper bounds.
            travel = abs(creep.displacement) / self.mat["d"]
            judged["reached"]["rod_min_travel_over_d"] = travel
            judged["bound"]["rod_min_travel_over_d"] = travel
            judged["met"]["rod_min_travel_over_d"] = bool(travel >= float(min_travel))
            resolved = resolved and judged["met"]["rod_min_travel_over_d"]
        # Either suffices: a resolved speed (over the travel asked for), or a bound below anything
        # scored (a rod at rest).
        return judged | {"all_met": at_rest or resolved}

    def _record(self, plan: dict[str, int]) -> dict[str, Any]:
        record = super()._record(plan)
        d = self.mat["d"]
        rod = self.state["intruder"]
        record["particle_count"] += rod["n_grains"]
        inserted = rod.get("inserted")
        if inserted is not None:
            # The grains left around the rod in the sheared bed, not the case's n_grains.
            record["particle_count"] += inserted["flowing_grains"] - record["flowing_grains"]
            record["flowing_grains"] = inserted["flowing_grains"]
        # The measuring window is the production window, after the wall's steady state was
        # detected: the rod's own start-up (it starts at rest in a bed just loaded by the wall and
        # the Couette start of the first chunk) lasts longer than the wall's. Seen on reduced runs:
        # a control pushed 0.4 d in its first chunk, then still to 1e-5 d; a rod 7 d deep moved
        # 2.5 d in the first chunk and slowed down through the second.
        t_start, t_end = record["production_window"]
        series = self.intruder_series(t_start, t_end)
        wall = self.series()
        wall = wall[(wall["time"] >= t_start) & (wall["time"] <= t_end)]
        creep = creep_speed(series["time"].to_numpy(), series["x"].to_numpy(), rest_speed=self.rest_speed())
        depth = float(wall["h_top"].mean() - series["z"].mean())
        wall_shear_force = abs(float(wall["ftop_x"].mean()))  # N, the top wall's over the production
        everything = self.intruder_series(-math.inf, math.inf)
        record["intruder"] = {
            "control": self.control,
            "depth_target_over_d": self.depth_over_d,
            "depth": depth,
            "depth_over_d": depth / d,
            "depth_at_fill_over_d": (self.state["fill"]["z_top_wall"] - rod["z"]) / d,
            "z": float(series["z"].mean()),
            "z_drift": float(everything["z"].max() - everything["z"].min()),
            "diameter": self.rod_diameter,
            "length": self.rod_length,
            "n_grains": rod["n_grains"],
            "grain_spacing": rod["spacing"],
            "force": self.push_force(),
            "force_fraction": float(self.case["force"]) if self.push_fraction is None else self.push_fraction,
            "force_sweep": self.push_fraction is not None,
            # The push over the yield force at the rod's own depth (yield_coefficient p D L, p hydrostatic there).
            "push_over_yield": self.push_force() / self.yield_force_here(),
            # Below the top wall's grain centres, as the run id's depth (the fields' contact planes are 0.4 d lower).
            "depth_below_top_over_d": depth / d,
            "yield_force_estimate": self.yield_force_estimate(),
            "yield_force_here": self.yield_force_here(),
            "yield_coefficient": float(self.case["yield_coefficient"]),
            "yield_source": "config yield_coefficient * (P + nu rho_s g h_min) * D * L; coefficient measured with "
                            "pipeline.dem.intruder_run --probe-yield (top wall at rest, staircase of forces)",
            "mean_contact_force_x": float(series["fx_contact"].mean()),
            # The push's share of the cell's shear-stress budget (issue 55): in the periodic cell the
            # whole push loads the layer below the rod, whose x-averaged sigma_xz is the top wall's
            # plus F / (L_x L_y). A share of 0.2 or less is a local push.
            "push_per_area": self.push_force() / self.cell_area(),
            "top_wall_shear_stress": wall_shear_force / self.cell_area(),
            "push_budget_share": self.push_force() / wall_shear_force,
            "speed": creep.speed,
            "speed_err": creep.speed_err,
            "speed_over_wall_speed": creep.speed / self.reference_speed(),
            "displacement": creep.displacement,
            "window": [t_start, t_end],
            "arrested": creep.arrested,
            "speed_blocks": SPEED_BLOCKS,
            "halves": production_halves(series["time"].to_numpy(), series["x"].to_numpy(), self.rest_speed()),
            # None, or the sheared bed the rod went into: its grains removed, the settling allowed for.
            "inserted": inserted,
        }
        halves = record["intruder"]["halves"]
        if halves is not None:
            # The halves' own durations (s), so that each half's travel is exact (issue 55).
            halves["first_duration"], halves["second_duration"] = split_durations(series["time"].to_numpy())
        # The rod's travel over the production and each half, in d, and whether its U is steady:
        # the functions the scoring applies to older records too (pipeline.scoring.rod_steadiness).
        steadiness = classify(record)
        record["intruder"].update({k: steadiness[k] for k in ("travel_over_d", "travel_first_half_over_d",
                                                              "travel_second_half_over_d", "travel_source")})
        record["intruder"]["steadiness"] = {k: steadiness[k] for k in ("steady", "rod_class", "reason", "halves_z_normal")}
        return record


class YieldProbe(IntruderRun):
    """The yield force of the rod at rest: top wall at rest, a staircase of pushes, one chunk each.

    Pushes are ``PROBE_COEFFICIENTS * p D L`` (p: :func:`hydrostatic_pressure` at the rod's axis).
    The first step (no push) lets the bed settle under the wall load. The yield force lies
    between the last push under which the rod moved less than
    :data:`PROBE_YIELD_DISPLACEMENT_OVER_D` d in its step and the first one above; the probe
    stops there. Written to ``yield.json`` in the run folder.
    """

    def __init__(self, config: dict[str, Any], case_name: str, run_id: str, run_dir: Path) -> None:
        super().__init__(config, case_name, run_id, run_dir)
        self.control = True
        d = self.mat["d"]
        self.scale = hydrostatic_pressure(self.wall_pressure, self.mat["rho_s"], self.case["gravity"],
                                          self.depth_over_d * d) * self.rod_diameter * self.rod_length

    KEEPS_STEADY_WINDOW = False

    def _chunk_force(self, stage: str) -> float:
        return PROBE_COEFFICIENTS[int(stage.split("_")[-1])] * self.scale

    def run(self) -> dict[str, Any]:
        self.run_dir.mkdir(parents=True, exist_ok=True)
        render.copy_templates(self.case["geometry"], self.run_dir, tangential_damping(self.mat))
        self._load_state()
        if "fill" not in self.state:
            self._fill()
        plan = self._chunk_plan()
        d = self.mat["d"]
        steps = []
        for k, coefficient in enumerate(PROBE_COEFFICIENTS):
            done = [c for c in self.state["chunks"] if c["kind"] == "shear"]
            chunk = done[k] if k < len(done) else self._run_chunk("shear", k, plan)
            rod = read_intruder_series(self.run_dir / "series" / f"intruder_{chunk['stage']}.txt")
            rod["x"] = unwrap(rod["x"].to_numpy(), self.case["cell_x"] * d)
            half = rod.iloc[len(rod) // 2 :]
            steps.append({"coefficient": coefficient, "force": coefficient * self.scale,
                          "displacement_over_d": float(rod["x"].iloc[-1] - rod["x"].iloc[0]) / d,
                          "late_speed": float(np.polyfit(half["time"], half["x"], 1)[0])})
            if steps[-1]["displacement_over_d"] > PROBE_YIELD_DISPLACEMENT_OVER_D:
                break
        moved = [s for s in steps if s["displacement_over_d"] > PROBE_YIELD_DISPLACEMENT_OVER_D]
        held = [s for s in steps if s["displacement_over_d"] <= PROBE_YIELD_DISPLACEMENT_OVER_D]
        result = {
            "case": self.case_name, "run": self.run_id, "depth_over_d": self.depth_over_d,
            "depth_at_fill_over_d": (self.state["fill"]["z_top_wall"] - self.state["intruder"]["z"]) / d,
            "p_D_L": self.scale, "step_duration": plan["chunk_steps"] * self.design.dt, "steps": steps,
            "largest_held_coefficient": held[-1]["coefficient"] if held else None,
            "first_moving_coefficient": moved[0]["coefficient"] if moved else None,
            "criterion": f"rod moves more than {PROBE_YIELD_DISPLACEMENT_OVER_D} d during one step",
            "wall_clock_seconds": self.state["wall_seconds"],
        }
        atomic.write_json(result, self.run_dir / "yield.json")
        return result
