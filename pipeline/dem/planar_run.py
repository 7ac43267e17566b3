"""Run one planar-shear DEM case (rheometer or shear with gravity) with the configured engine.

The geometry's part of the run: the pour between two rough walls (random monolayers of frozen
grains; the top one moved as one rigid body at ``wall_speed`` under ``wall_pressure``), the
template variables of every stage, the failure checks of the wall series, the top wall's balance
and the record (``run.json``). The stages and their commits are :mod:`pipeline.dem.lifecycle`'s;
what the engine does (``dem.engine``: LIGGGHTS or LAMMPS) is :mod:`pipeline.dem.engines`'.

Usage: ``python -m pipeline.dem --config config/config.yaml --case rheometer --run I0.02-r1``
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.common.config import (case_production, derived_seed, fill_physics, liggghts_seed, mean_grain_volume, run_case,
                                    run_state, shared_fill_of, size_classes)
from pipeline.common.formats import RUN_FORMAT_VERSION
from pipeline.common.provenance import provenance
from pipeline.dem.contact_scaling import contact_design
from pipeline.dem.engines import CONTACT_COLUMNS, DELTA_COLUMN, make_engine  # noqa: F401
# Re-exported: other modules, tests and benchmarks reach the LIGGGHTS templates and launch from here.
from pipeline.dem import liggghts_render as render  # noqa: F401
from pipeline.dem import adopted_packing, force_balance
from pipeline.dem.engines.liggghts import Launcher, mpi_environment, run_liggghts  # noqa: F401
from pipeline.dem.lifecycle import (FILL_FILES, FILL_RECORD, OPTIONAL_FILL_FILES, START_RESTART,  # noqa: F401
                                    STEADY_CREEP_BANDS, ChunkedRun, read_settled, settled_timestep)
from pipeline.dem.liggghts_log import DEMRunError, printed_value
from pipeline.dem.rough_wall import WallLayer, layer_include, random_layer
from pipeline.dem.steady_state import balance_test, drift_test
from pipeline.dem.wall_series import PAIRSUM_COLUMNS, read_wall_series

#: Solid fraction assumed when estimating the height of the initial loose insertion region
#: (LIGGGHTS'; an engine may name its own, ``insertion_solid_fraction``).
INSERTION_SOLID_FRACTION = 0.25
#: Smallest wall-to-wall gap (in d) a run accepts: the bulk is sampled 3 d from each wall.
MIN_GAP_OVER_D = 6.0
#: Damping ratio of the top wall's vertical motion on the bed (see PlanarShearRun._wall_damping).
WALL_DAMPING_RATIO = 0.1
#: Kinetic energy per grain, in units of m g d, below which the poured packing counts as settled.
SETTLED_KE_PER_GRAIN = 1e-3


class PlanarShearRun(ChunkedRun):
    """One DEM run of a planar shear case (rheometer or shear with gravity)."""

    def __init__(self, config: dict[str, Any], case_name: str, run_id: str, run_dir: Path,
                 fill_from: Path | None = None, start_from: Path | None = None) -> None:
        """``fill_from``: folder of a shared fill (``fill.json``, :mod:`pipeline.dem.shared_fill`)
        the run starts from instead of pouring its own. ``start_from``: folder of a finished run
        (a slower rheometer state of the same fill) whose final packing the shear stage starts
        from instead of the fill's."""
        self.config = config
        self.fill_from = fill_from
        self.start_from = start_from
        self.case_name = case_name
        self.run_id = run_id
        self.case = run_case(config["cases"][case_name], run_id)
        self.mat = config["material"]
        # The case's own production targets and cap, where it names them.
        self.dem = case_production(config["dem"], self.case)
        self.run_dir = run_dir
        self.label = f"DEM run {case_name}/{run_id}"
        self.design = contact_design(config)
        self.engine = make_engine(self.dem, self.mat)
        self.engine.check_geometry(self.case["geometry"], self.label)
        # The LIGGGHTS launch (None under LAMMPS), for the intruder's extra LIGGGHTS stages.
        self.launcher = getattr(self.engine, "launcher", None)
        # A run whose fill is shared has the fill's seed: alone (no fill_from) it pours that very
        # packing itself, so it is the same run inside the workflow and out of it.
        fill = shared_fill_of(case_name, self.case, run_id)
        self.seed = fill_physics(config, case_name, fill)["seed"] if fill else derived_seed(config["seed"], case_name, run_id)
        #: Normal stress of the top wall (Pa): per run for the rheometer, per case otherwise.
        self.wall_pressure = run_state(run_id)[1] if case_name == "rheometer" else float(self.case["wall_pressure"])
        self.state_path = run_dir / "state.json"
        self.state: dict[str, Any] = {}

    # ------------------------------------------------------------------------------- variables
    def _base_variables(self) -> dict[str, object]:
        d = self.mat["d"]
        n_types = 4
        return {
            "Lx": self.case["cell_x"] * d,
            "Ly": self.case["cell_y"] * d,
            "skin": 0.1 * d,
            "youngs_modulus": self.design.youngs_modulus,
            "poisson_ratio": self.mat["poisson_ratio"],
            "restitution_matrix": [self.mat["restitution"]] * n_types**2,
            "friction_matrix": [self.mat["friction"]] * n_types**2,
            # The smallest flowing grain's radius (LAMMPS estimates the largest overlap with it).
            "smallest_radius": 0.5 * min(size_classes(d, self.mat["polydispersity"], self.mat["n_sizes"])),
            "restitution": self.mat["restitution"],
            "friction": self.mat["friction"],
            "dt": self.design.dt,
        }

    def _fill(self) -> None:
        d, rho = self.mat["d"], self.mat["rho_s"]
        area = self.case["cell_x"] * self.case["cell_y"] * d**2
        v_grain = mean_grain_volume(d, self.mat["polydispersity"], self.mat["n_sizes"])
        fraction = getattr(self.engine, "insertion_solid_fraction", INSERTION_SOLID_FRACTION)
        lz = self.case["n_grains"] * v_grain / (fraction * area) + 4.0 * d
        g_fill = self.case["gravity"] if self.case["gravity"] > 0 else 9.81
        m_grain = rho * v_grain
        fall_time = math.sqrt(2.0 * lz / g_fill)
        # Short chunks: the kinetic energy is tested after each, so settling stops soon after rest.
        # An eighth of the fall time: with half, every default run stopped at 1.5 fall times while the
        # logs show rest reached at 1.1-1.25 (the first test on the way down cannot pass: the grains
        # then carry about m g Lz / 64 each, far above the threshold).
        settle_chunk = int(math.ceil(fall_time / 8.0 / self.design.dt))
        sizes = size_classes(d, self.mat["polydispersity"], self.mat["n_sizes"])
        bottom = random_layer(self.case["cell_x"] * d, self.case["cell_y"] * d, sizes,
                              np.random.default_rng(derived_seed(self.seed, "bottom_wall")))
        z_bottom = 0.5 * max(sizes)
        (self.run_dir / "bottom_wall.in").write_text(layer_include(bottom, 2, z_bottom, rho, first_id=1))
        top = random_layer(self.case["cell_x"] * d, self.case["cell_y"] * d, sizes,
                           np.random.default_rng(derived_seed(self.seed, "top_wall")))
        # Bodies created before the pour (an intruder) take the ids after the bottom wall.
        n_bodies = self._write_fill_bodies(first_id=len(bottom) + 1, z_bottom=z_bottom)
        first_top_id = len(bottom) + n_bodies + self.case["n_grains"] + 1
        (self.run_dir / "top_wall.in").write_text(layer_include(top, 3, "${z_top_wall}", rho, first_id=first_top_id))
        adopted = self._adopted_packing(bottom, first_id=len(bottom) + n_bodies + 1)
        if adopted is not None:
            (self.run_dir / "grains.in").write_text(adopted["include"])
        else:
            seeds = [liggghts_seed(self.seed, "size", str(k)) for k in range(self.mat["n_sizes"])]
            (self.run_dir / "grains.in").write_text(
                self.engine.grains_include(
                    d, self.mat["polydispersity"], self.mat["n_sizes"], rho, seeds, liggghts_seed(self.seed, "pdd")
                )
            )
        variables = self._base_variables() | {
            "Lz_box": lz,
            "z_insert_low": z_bottom + max(sizes),
            "top_wall_clearance": max(sizes) + 0.01 * d,
            # Highest centre of a grain placed at random (LAMMPS; LIGGGHTS keeps whole grains inside by itself).
            "z_insert_high": lz - 0.5 * max(sizes) - 0.01 * d,
            "n_grains": self.case["n_grains"],
            "seed_insert": liggghts_seed(self.seed, "insert"),
            "g_fill": g_fill,
            "thermo_every": settle_chunk,
            "settle_chunk_steps": settle_chunk,
            "settle_max_chunks": 160,   # 20 fall times
            "fill_drag": m_grain / fall_time,
            "ke_settled": SETTLED_KE_PER_GRAIN * self.case["n_grains"] * m_grain * g_fill * d,
        }
        # The engine's templates (a shared fill's folder may hold only LIGGGHTS's: pipeline.dem.shared_fill).
        self.engine.copy_templates(self.case["geometry"], self.run_dir)
        if adopted is not None:
            template = self.run_dir / "fill.in"
            template.write_text(adopted_packing.without_pour(template.read_text(), self.engine.name, template))
        self.engine.render_stage(self.run_dir, "fill", "fill.in", variables)
        seconds = self.engine.launch(self.run_dir, "fill", self.label)
        ke = printed_value(self.run_dir / "logs" / "fill.log", "SETTLED_KE")
        if ke > variables["ke_settled"]:
            raise DEMRunError(
                f"{self.label}: the poured grains did not settle (kinetic energy {ke:.3g} J > {variables['ke_settled']:.3g} J "
                f"after {variables['settle_max_chunks']} chunks)"
            )
        settled = read_settled(self.run_dir / "settled.dump")
        flowing = settled[settled["type"] == 1]
        if len(flowing) != self.case["n_grains"]:
            raise DEMRunError(f"{self.label}: inserted {len(flowing)} grains, the config asks for {self.case['n_grains']}")
        # A grain may sit in a hole of the wall layer, but its centre cannot get below the layer's
        # underside (z = 0) without having passed through it.
        through = flowing["z"] < z_bottom - 0.5 * max(sizes) + 0.5 * min(sizes)
        if through.any():
            raise DEMRunError(f"{self.label}: {int(through.sum())} grains fell through the bottom wall layer")
        z_top = printed_value(self.run_dir / "logs" / "fill.log", "TOP_WALL_Z")
        if z_top - z_bottom < MIN_GAP_OVER_D * d:
            raise DEMRunError(
                f"{self.label}: only {self.case['n_grains']} grains, too few grains for a bed between the walls "
                f"({(z_top - z_bottom) / d:.1f} d deep, the minimum is {MIN_GAP_OVER_D:g} d)"
            )
        walls = settled[settled["type"] == 3]
        if len(walls) != len(top) or int(walls["id"].min()) != first_top_id:
            raise DEMRunError(f"{self.label}: the top wall has {len(walls)} grains (expected {len(top)} from id {first_top_id})")
        if z_top + max(sizes) > lz:
            raise DEMRunError(f"{self.label}: the settled bed reaches the top of the box ({z_top:.4g} m of {lz:.4g} m)")
        self.state["fill"] = {
            "wall_seconds": seconds,
            "n_bottom_wall_grains": len(bottom),
            "n_top_wall_grains": len(top),
            "wall_coverage": [layer.coverage(self.case["cell_x"] * d, self.case["cell_y"] * d) for layer in (bottom, top)],
            "settled_gap": z_top - z_bottom,
            "z_bottom_wall": z_bottom,
            "z_top_wall": z_top,
            "settled_ke": ke,
            "steps": settled_timestep(self.run_dir / "settled.dump"),
            "wall_mass": float(np.sum(rho * np.pi * top.diameter**3 / 6.0)),
            # A restart is its engine's own: a shared fill records which (lifecycle._adopt_fill checks).
            "engine": self.engine.name,
        }
        if adopted is not None:
            self.state["fill"]["packing_from"] = {"path": str(adopted["path"]), "sha256": adopted["sha256"]}
        self.state["wall_seconds"] += seconds
        self._save_state()

    # ------------------------------------------------------------------------------- shearing
    def wall_speed(self) -> float:
        """Top-wall speed (m/s): given, or from the target inertial number of a rheometer run."""
        if "wall_speed" in self.case:
            return float(self.case["wall_speed"])
        target = run_state(self.run_id)[0]
        shear_rate = target * math.sqrt(self.wall_pressure / self.mat["rho_s"]) / self.mat["d"]
        return shear_rate * self.state["fill"]["settled_gap"]

    def reference_speed(self) -> float:
        """Speed (m/s) that sets the chunk length and the kinetic-energy scale: the wall speed.

        Overridden by runs whose wall is at rest (an intruder's control run), which keep the
        chunk length of the sheared runs they are compared with.
        """
        return self.wall_speed()

    def _adopted_packing(self, bottom: WallLayer, first_id: int) -> dict[str, Any] | None:
        """``cases.<case>.packing_from``: the grains.in text placing another root's settled grains
        of this run (:mod:`pipeline.dem.adopted_packing`), its source and digest; None to pour."""
        root = self.case.get("packing_from")
        if not root:
            return None
        # The packing this run shears: its shared fill's (the rheometer's states of one replica),
        # whether poured here as that fill or by the run alone from the fill's seed; else its own.
        packing = shared_fill_of(self.case_name, self.case, self.run_id) or self.run_id
        if self.case["geometry"] != "planar_shear" or self.run_dir.name not in (packing, self.run_id):
            raise DEMRunError(f"{self.label}: cases.{self.case_name}.packing_from is for a planar case's fills "
                              f"(its own or its replica's shared fill), not for {self.run_dir.name}")
        path = adopted_packing.source_path(root, self.case_name, packing)
        if not path.is_file():
            raise DEMRunError(f"{self.label}: cases.{self.case_name}.packing_from: no settled packing {path}")
        settled = read_settled(path)
        adopted_packing.check_source(settled, path, self.case["n_grains"], bottom.x, bottom.y)
        return {"include": adopted_packing.packing_include(settled, first_id, self.mat["rho_s"]),
                "path": path, "sha256": adopted_packing.sha256(path)}

    def _write_fill_bodies(self, first_id: int, z_bottom: float) -> int:
        """Hook: write include files for bodies created before the pour; return their atom count.

        ``first_id`` is the id LIGGGHTS gives the first such atom; ``z_bottom`` (m) is the height of
        the bottom wall's centres. Planar shear has none.
        """
        return 0

    def _stage_variables(self, plan: dict[str, int]) -> dict[str, object]:
        """Template variables every shear and production chunk of planar shear reads: the walls'
        heights, motion, load and damping, gravity (the lifecycle adds the chunk's own files)."""
        n_wall = self.state["fill"]["n_top_wall_grains"]
        return self._base_variables() | {
            "z_bottom_wall": self.state["fill"]["z_bottom_wall"],
            "z_top_wall": self.state["fill"]["z_top_wall"],
            "wall_speed": self.wall_speed(),
            "gravity": self.case["gravity"],
            "load_per_grain": self.top_load() / n_wall,
            "wall_damping_per_grain": self._wall_damping() / n_wall,
        }

    def _chunk_variables(self, stage: str) -> dict[str, object]:
        """Hook: extra template variables of one shear or production chunk (none for planar shear)."""
        return {}

    def _wall_damping(self) -> float:
        """Total damping coefficient (N s/m) on the wall's vertical speed: 10 % of critical.

        The bed acts on the wall as a spring of stiffness ``K = E_bed A / h``, the bed modulus
        estimated from the linearised Hertz stiffness at the design overlap,
        ``E_bed ~ Z nu k / (pi d)``. Damping ratio 0.1 removes the wall's ringing within a few
        periods (~1 ms) without resisting the much slower dilation of the bed: at critical damping
        the drag of a dilating bed on the wall reached twice the load and overlaps 1 % of d.
        """
        d = self.mat["d"]
        e_star = self.design.effective_modulus
        k_n = 2.0 * e_star * math.sqrt(0.25 * d * self.mat["design_overlap"] * d)
        e_bed = 2.7 * k_n / (math.pi * d)
        area = self.case["cell_x"] * self.case["cell_y"] * d**2
        stiffness = e_bed * area / self.state["fill"]["settled_gap"]
        return 2.0 * WALL_DAMPING_RATIO * math.sqrt(stiffness * self.state["fill"]["wall_mass"])

    def _check_series(self, series: pd.DataFrame, stage: str) -> None:
        d = self.mat["d"]
        v = self.reference_speed()
        n_flow = self.case["n_grains"]
        m_grain = self.mat["rho_s"] * mean_grain_volume(d, self.mat["polydispersity"], self.mat["n_sizes"])
        scale = 0.5 * m_grain * v**2 + self.wall_pressure * d**3
        ke_ratio = float(series["ke"].max()) / n_flow / scale
        if ke_ratio > self.dem["max_ke_ratio"]:
            raise DEMRunError(
                f"{self.label} stage {stage}: kinetic energy blew up ({ke_ratio:.3g} x (m V^2/2 + P d^3) per grain, "
                f"limit dem.max_ke_ratio = {self.dem['max_ke_ratio']:g}): time step too large or walls too soft?"
            )
        max_overlap = float(series["max_overlap"].max()) / d
        if max_overlap > self.mat["max_overlap"]:
            raise DEMRunError(
                f"{self.label} stage {stage}: contact overlap reached {max_overlap:.3g} d, above the bound "
                f"material.max_overlap = {self.mat['max_overlap']:g} d (grains too soft for the pressure)"
            )

    def top_load(self) -> float:
        """The top wall's load (N, downwards): ``wall_pressure`` times the cell's area."""
        area = self.case["cell_x"] * self.case["cell_y"] * self.mat["d"] ** 2
        return self.wall_pressure * area

    def load_balance(self, series: pd.DataFrame) -> dict[str, float | bool]:
        """The top wall's vertical balance over a stretch of its wall series (recorded, not required).

        The grains' mean push on the wall equals its load plus the drag of its damping,
        ``c <v_z>``, with ``<v_z>`` the wall's mean rise over the stretch (m/s, the slope of its height;
        its momentum changes by a negligible amount). ``balanced``: the push equals the load within twice its block error
        (:func:`pipeline.dem.steady_state.balance_test` with no tolerance); ``damping_drag_over_load``:
        ``c <v_z>`` over the load, which accounts for the difference (docs/dem.md, "The top wall's
        vertical balance": the fast, low-pressure rheometer states' walls creep up under a drag of
        0.2-1.7 x their load).
        """
        balance = balance_test(series["ftop_z"].to_numpy(), self.top_load(), tol=0.0).as_dict()
        # The mean rise as the least-squares slope of h(t): the end points alone carry the wall's jiggle.
        rise = float(np.polyfit(series["time"].to_numpy(), series["h_top"].to_numpy(), 1)[0])
        return balance | {"wall_rise_speed": rise, "damping_drag_over_load": self._wall_damping() * rise / self.top_load()}

    def pair_force_sum(self, shear: float) -> dict[str, float] | None:
        """Mean sums of all contact forces over production (N): x (also relative to ``shear``, the
        mean top-wall shear force, N), y, and z (the atoms' z forces less the grains' weight and the
        top wall's load, also relative to their sum); None when a production chunk has no pair-sum
        file (the intruder's template)."""
        production = [c for c in self.state["chunks"] if c["kind"] == "production"]
        files = [self.run_dir / "series" / f"pairsum_{c['stage']}.txt" for c in production]
        if not production or not all(f.is_file() for f in files):
            return None
        sums = pd.concat([read_wall_series(f, PAIRSUM_COLUMNS) for f in files], ignore_index=True)
        mean_x = float(sums["fsum_x"].mean())
        settled = read_settled(self.run_dir / "settled.dump")
        external = self.top_load() + float(settled.loc[settled["type"] == 1, "mass"].sum()) * self.case["gravity"]
        mean_z = float(sums["fsum_z"].mean()) + external
        return {"mean_x": mean_x, "mean_y": float(sums["fsum_y"].mean()), "mean_z": mean_z,
                "over_top_shear_force": mean_x / abs(shear) if shear else float("nan"),
                "z_over_load_and_weight": mean_z / external}

    def _record(self, plan: dict[str, int]) -> dict[str, Any]:
        production = [c for c in self.state["chunks"] if c["kind"] == "production"]
        prod_series = self.series(("production",))
        depth = self.state["fill"]["settled_gap"]
        prod_force = drift_test(prod_series["time"], prod_series["ftop_x"], self.dem["steady_force_tol"], float(prod_series["ftop_x"].mean()))
        prod_height = drift_test(prod_series["time"], prod_series["h_top"], self.dem["steady_height_tol"], depth)
        sizes = size_classes(self.mat["d"], self.mat["polydispersity"], self.mat["n_sizes"])
        return {
            "format_version": RUN_FORMAT_VERSION,
            "case": self.case_name,
            "run": self.run_id,
            "geometry": self.case["geometry"],
            # The DEM engine (dem.engine) and its contact law (docs/dem.md, "Two engines").
            "engine": self.engine.name,
            "particle_count": self.case["n_grains"] + self.state["fill"]["n_bottom_wall_grains"] + self.state["fill"]["n_top_wall_grains"],
            "flowing_grains": self.case["n_grains"],
            "wall_grains": [self.state["fill"]["n_bottom_wall_grains"], self.state["fill"]["n_top_wall_grains"]],
            "wall_coverage": self.state["fill"]["wall_coverage"],
            "diameters": sizes,
            "d": self.mat["d"],
            "density": self.mat["rho_s"],
            "friction": self.mat["friction"],
            "restitution": self.mat["restitution"],
            "poisson_ratio": self.mat["poisson_ratio"],
            "youngs_modulus": self.design.youngs_modulus,
            "stiffness_rule": self.design.as_dict(),
            "time_step": self.design.dt,
            "wall_speed": self.wall_speed(),
            "wall_pressure": self.wall_pressure,
            "gravity": self.case["gravity"],
            "cell": [self.case["cell_x"] * self.mat["d"], self.case["cell_y"] * self.mat["d"]],
            "settled_gap": depth,
            "steps": int(sum(c["steps"] for c in self.state["chunks"])),
            "shear_chunks": sum(1 for c in self.state["chunks"] if c["kind"] == "shear"),
            "production_chunks": len(production),
            # Of them, the steady window's (dem.precision.steady_window_is_production): 0 or steady_window_chunks.
            "production_chunks_from_steady_window": sum(1 for c in production if c.get("from_steady_window")),
            "production_strain": len(production) * self.dem["chunk_strain"],
            "production_stop": self.state.get("production_stop"),
            "steps_by_stage": self.steps_by_stage(),
            # The shared fill this run started from (its steps and seconds, counted once there), or None.
            "shared_fill": self.state["fill"].get("shared"),
            # The run whose final packing the shear stage started from (continue_above), or None.
            "started_from": self.state.get("start"),
            "wall_seconds_by_stage": self.seconds_by_stage(),
            "chunk_steps": plan["chunk_steps"],
            "dump_every": plan["dump_every"],
            "wall_clock_seconds": self.state["wall_seconds"],
            "mpi_ranks": self.dem["mpi_ranks"],
            "mpi_launcher": self.dem["mpi_launcher"],
            "mpi_start": self.engine.start,
            "seed": self.seed,
            "steady_state_window": [self.state["steady"]["t_start"], production[-1]["t_end"]],
            "steady_state_test": self.state["steady"],
            "production_window": [production[0]["t_start"], production[-1]["t_end"]],
            "production_drift": {"force": prod_force.as_dict(), "height": prod_height.as_dict()},
            # The top wall's mean push over its load across the production, and its damping's drag.
            "production_load_balance": self.load_balance(prod_series),
            "pair_force_sum": self.pair_force_sum(float(prod_series["ftop_x"].mean())),
            # Action = reaction over all contacts, every sample at round-off (pipeline/dem/force_balance.py).
            "pair_force_check": force_balance.record(self.run_dir, [c["stage"] for c in production], float(prod_series["ftop_x"].mean())),
            "max_overlap_over_d": float(self.series()["max_overlap"].max() / self.mat["d"]),
            "particle_dumps": [c["dumps"][0] for c in production],
            "contact_dumps": [c["dumps"][1] for c in production],
            "contact_columns": list(CONTACT_COLUMNS),
            "provenance": provenance(self.config),
        }
