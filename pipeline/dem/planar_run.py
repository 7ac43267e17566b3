"""Run one planar-shear DEM case with LIGGGHTS: fill and settle, shear until steady, produce.

Stages, each a separate LIGGGHTS call continued from the previous one's restart file:

1. ``fill``: pour and settle the grains under gravity; the pipeline then makes the lowest and the
   highest layer of grains into the rough walls.
2. ``shear_NNN``: chunks of ``chunk_strain`` wall displacement over depth each; after every chunk
   the wall shear force and wall height over the trailing ``steady_window_chunks`` chunks are
   tested for drift (:mod:`pipeline.dem.steady_state`). The first window that passes is the start of
   the steady state.
3. ``production_NNN``: chunks of the same length that also dump particles and contacts. With
   ``dem.precision.steady_window_is_production`` the steady window's chunks are the production's
   first ones (the shear chunks then dump too, and all but the trailing window's snapshots are
   deleted as the stage goes on).

Every chunk is committed (restart renamed from its temporary name, state.json rewritten) only
after its log and its wall series passed the failure checks, so a killed run resumes from the
last committed chunk and gives the same numbers. ``run.json`` is written last, under a temporary
name renamed at the end: its presence means the run finished.

Usage: ``python -m pipeline.dem --config config/config.yaml --case rheometer --run I0.02-r1``
"""
from __future__ import annotations

import functools
import json
import math
import os
import shlex
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.dem import liggghts_render as render
from pipeline.dem import precision
from pipeline.common.config import (case_production, derived_seed, fill_physics, liggghts_seed, mean_grain_volume, run_case, run_physics,
                                    run_state, shared_fill_of, size_classes)
from pipeline.dem.contact_scaling import ContactDesign, design_contacts
from pipeline.common.formats import RUN_FORMAT_VERSION
from pipeline.dem.liggghts_log import DEMRunError, check_run, printed_value
from pipeline.common.provenance import provenance
from pipeline.dem.rough_wall import layer_include, random_layer
from pipeline.dem.steady_state import balance_test, band_speeds, creep_settled, drift_test
from pipeline.dem.wall_series import PAIRSUM_COLUMNS, read_wall_series

#: Column of ``delta`` (overlap) among the pair/gran/local outputs ``pos id force contactPoint delta``
#: (LIGGGHTS orders them pos(6) id(3) force(3) delta(1) contactPoint(3); checked by a test on a real run).
CONTACT_COLUMNS = (
    "x1", "y1", "z1", "x2", "y2", "z2", "id1", "id2", "periodic",
    "fx", "fy", "fz", "delta", "cx", "cy", "cz",
)
DELTA_COLUMN = CONTACT_COLUMNS.index("delta") + 1
#: Solid fraction assumed when estimating the height of the initial loose insertion region.
INSERTION_SOLID_FRACTION = 0.25
#: Smallest wall-to-wall gap (in d) a run accepts: the bulk is sampled 3 d from each wall.
MIN_GAP_OVER_D = 6.0
#: Damping ratio of the top wall's vertical motion on the bed (see PlanarShearRun._wall_damping).
WALL_DAMPING_RATIO = 0.1
#: Depth bands (edges in d below the top wall's grain centres) in which the steady-state test
#: compares the creep of consecutive windows (``dem.steady_creep_bands_over_d`` overrides).
STEADY_CREEP_BANDS = (3.0, 6.0, 9.0, 12.0, 15.0, 18.0)
#: Kinetic energy per grain, in units of m g d, below which the poured packing counts as settled.
SETTLED_KE_PER_GRAIN = 1e-3
#: A shared fill's record, in its folder (pipeline.dem.shared_fill).
FILL_RECORD = "fill.json"
#: What a run takes from a shared fill: the restart it shears from, the settled snapshot and the
#: include files and log that made it (kept so the run folder shows its whole history).
FILL_FILES = ("fill.restart", "settled.dump", "bottom_wall.in", "top_wall.in", "grains.in", "in.fill", "logs/fill.log")
#: The restart a run continued from another's final packing starts its shear stage from.
START_RESTART = "start.restart"
#: Made by the fill of some geometries only (the intruder's rod).
OPTIONAL_FILL_FILES = ("intruder.in",)


def contact_design(config: dict[str, Any]) -> ContactDesign:
    """The one contact design shared by all cases, so the calibration transfers between them.

    It depends on the material section only (``design_pressure`` sets the stiffness), never on
    the other cases of the config: a DEM run reads a config that holds its own case alone.
    """
    mat = config["material"]
    return design_contacts(
        p_max=mat["design_pressure"],
        d=mat["d"],
        polydispersity=mat["polydispersity"],
        rho_s=mat["rho_s"],
        poisson_ratio=mat["poisson_ratio"],
        design_overlap=mat["design_overlap"],
        max_overlap=mat["max_overlap"],
        dt_over_contact_time=mat["dt_over_contact_time"],
    )


@dataclass
class Launcher:
    """How LIGGGHTS is started: ``[mpi_launcher -n ranks] liggghts``."""

    liggghts: str
    mpi_launcher: str = ""
    ranks: int = 1

    def command(self, input_name: str, log_name: str) -> list[str]:
        binary = shutil.which(self.liggghts)
        if binary is None:
            raise DEMRunError(f"LIGGGHTS executable {self.liggghts!r} not found on PATH (install the Debian package 'liggghts')")
        # Screen output is kept (sent to a file by the caller): LIGGGHTS 3.8 crashes in some
        # fixes (wall/gran primitive) when started with '-screen none'.
        cmd = [binary, "-in", input_name, "-log", log_name]
        if self.mpi_launcher and self.mpi_launcher != "none":
            launcher = shlex.split(self.mpi_launcher)
            if shutil.which(launcher[0]) is None:
                raise DEMRunError(f"MPI launcher {launcher[0]!r} not found on PATH")
            cmd = [*launcher, "-n", str(self.ranks), *cmd]
        return cmd


def _mpi_environment() -> dict[str, str]:
    env = dict(os.environ)
    # Open MPI refuses to start as root unless told; CI and containers run as root.
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    env.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
    # Open MPI binds a run's ranks to cores counted from core 0, each launch on its own: two
    # concurrent runs of one rank (the workflow's jobs on 2 cores) were both pinned to core 0,
    # sharing it while the other core idled (measured: 48 % idle, both at 50 %). Unbound, the
    # kernel spreads them. (Under SLURM, srun places the ranks and this is not read.)
    env.setdefault("OMPI_MCA_hwloc_base_binding_policy", "none")
    return env


def run_liggghts(launcher: Launcher, run_dir: Path, stage: str, label: str) -> float:
    """Run ``in.<stage>`` in ``run_dir``; return wall-clock seconds. Raises :class:`DEMRunError`."""
    log = Path("logs") / f"{stage}.log"
    (run_dir / "logs").mkdir(exist_ok=True)
    screen = run_dir / "logs" / f"{stage}.screen"
    start = time.perf_counter()
    with screen.open("w") as out:
        proc = subprocess.run(
            launcher.command(f"in.{stage}", str(log)),
            cwd=run_dir,
            stdout=out,
            stderr=subprocess.STDOUT,
            env=_mpi_environment(),
            check=False,
        )
    seconds = time.perf_counter() - start
    check_run(f"{label} stage {stage}", run_dir / log, proc.returncode, screen.read_text(errors="replace"))
    return seconds


def settled_timestep(path: Path) -> int:
    """The time step of ``settled.dump``'s snapshot: the steps the fill took."""
    with path.open() as f:
        for line in f:
            if line.startswith("ITEM: TIMESTEP"):
                return int(next(f).split()[0])
    raise DEMRunError(f"{path}: no 'ITEM: TIMESTEP' line")


def read_settled(path: Path) -> pd.DataFrame:
    """The single snapshot of ``settled.dump`` (columns id type x y z radius mass)."""
    lines = path.read_text().splitlines()
    try:
        header_at = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    except StopIteration:
        raise DEMRunError(f"{path}: no 'ITEM: ATOMS' section") from None
    columns = lines[header_at].split()[2:]
    n_atoms = int(lines[lines.index("ITEM: NUMBER OF ATOMS") + 1])
    body = lines[header_at + 1 :]
    if len(body) != n_atoms:
        raise DEMRunError(f"{path}: expected {n_atoms} atom lines, found {len(body)} (truncated?)")
    data = np.array([line.split() for line in body], dtype=float)
    return pd.DataFrame(data, columns=columns)


class PlanarShearRun:
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
        self.launcher = Launcher(self.dem["liggghts"], self.dem["mpi_launcher"], self.dem["mpi_ranks"])
        # A run whose fill is shared has the fill's seed: alone (no fill_from) it pours that very
        # packing itself, so it is the same run inside the workflow and out of it.
        fill = shared_fill_of(case_name, self.case, run_id)
        self.seed = fill_physics(config, case_name, fill)["seed"] if fill else derived_seed(config["seed"], case_name, run_id)
        #: Normal stress of the top wall (Pa): per run for the rheometer, per case otherwise.
        self.wall_pressure = run_state(run_id)[1] if case_name == "rheometer" else float(self.case["wall_pressure"])
        self.state_path = run_dir / "state.json"
        self.state: dict[str, Any] = {}

    # ----------------------------------------------------------------------------------- state
    def _load_state(self) -> None:
        # Only what changes the physics: the output folder, MPI layout, other runs and non-DEM
        # sections may differ on resume.
        fingerprint = {"config": run_physics(self.config, self.case_name, self.run_id), "case": self.case_name,
                       "run": self.run_id}
        if self.start_from is not None:
            # Chunks continued from another run's packing belong to that run's history too.
            fingerprint["start_from"] = self._start_source["fingerprint"]
        if self.state_path.exists():
            state = json.loads(self.state_path.read_text())
            if state.get("fingerprint") == fingerprint:
                self.state = state
                return
            # Chunks made with another config cannot be continued: start this run afresh.
            for item in ("restart", "logs", "dumps", "series"):
                shutil.rmtree(self.run_dir / item, ignore_errors=True)
        self.state = {"fingerprint": fingerprint, "chunks": [], "steady": None, "wall_seconds": 0.0}

    def _save_state(self) -> None:
        tmp = self.state_path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(self.state, indent=1))
        tmp.replace(self.state_path)

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
            "dt": self.design.dt,
        }

    def _fill(self) -> None:
        d, rho = self.mat["d"], self.mat["rho_s"]
        area = self.case["cell_x"] * self.case["cell_y"] * d**2
        v_grain = mean_grain_volume(d, self.mat["polydispersity"], self.mat["n_sizes"])
        lz = self.case["n_grains"] * v_grain / (INSERTION_SOLID_FRACTION * area) + 4.0 * d
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
        seeds = [liggghts_seed(self.seed, "size", str(k)) for k in range(self.mat["n_sizes"])]
        (self.run_dir / "grains.in").write_text(
            render.grains_include(
                d, self.mat["polydispersity"], self.mat["n_sizes"], rho, seeds, liggghts_seed(self.seed, "pdd")
            )
        )
        variables = self._base_variables() | {
            "Lz_box": lz,
            "z_insert_low": z_bottom + max(sizes),
            "top_wall_clearance": max(sizes) + 0.01 * d,
            "n_grains": self.case["n_grains"],
            "seed_insert": liggghts_seed(self.seed, "insert"),
            "g_fill": g_fill,
            "thermo_every": settle_chunk,
            "settle_chunk_steps": settle_chunk,
            "settle_max_chunks": 160,   # 20 fall times
            "fill_drag": m_grain / fall_time,
            "ke_settled": SETTLED_KE_PER_GRAIN * self.case["n_grains"] * m_grain * g_fill * d,
        }
        render.render_stage(self.run_dir, "fill", "fill.in", variables)
        seconds = run_liggghts(self.launcher, self.run_dir, "fill", self.label)
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
        }
        self.state["wall_seconds"] += seconds
        self._save_state()

    def _adopt_fill(self, source: Path) -> None:
        """Start from a shared fill: copy its settled packing, walls and restart into this run.

        The fill's record must carry the physics this run's config gives it (material, cell, grains,
        seed): a fill made for another config is refused, never silently used. The run's own fill
        stage then costs nothing; the fill's steps and seconds are counted once, in ``fill.json``.
        """
        record_path = source / FILL_RECORD
        if not record_path.is_file():
            raise DEMRunError(f"{self.label}: --fill-from {source}: no {FILL_RECORD} there (the shared fill has not run)")
        record = json.loads(record_path.read_text())
        own_fill = shared_fill_of(self.case_name, self.case, self.run_id)
        if own_fill != record.get("run") or record.get("physics") != fill_physics(self.config, self.case_name, own_fill):
            raise DEMRunError(f"{self.label}: {record_path} is fill {record.get('run')!r} made with other settings "
                              f"than this run's config gives its shared fill {own_fill!r} "
                              "(material, cell, grains or seed differ): rerun the fill")
        for name in FILL_FILES + tuple(n for n in OPTIONAL_FILL_FILES if (source / n).is_file()):
            target = self.run_dir / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source / name, target)
        if record.get("bodies"):
            self.state["intruder"] = record["bodies"]
        self.state["fill"] = record["fill"] | {
            "steps": 0, "wall_seconds": 0.0,
            "shared": {"run": record["run"], "steps": record["fill"]["steps"], "wall_seconds": record["fill"]["wall_seconds"]}}
        self._save_state()

    @functools.cached_property
    def _start_source(self) -> dict[str, Any]:
        """The finished run ``start_from`` names: its id, state fingerprint, seed and final restart
        (read once: the fingerprint and the start both need it)."""
        source = self.start_from
        state_path, record_path = source / "state.json", source / "run.json"
        if not record_path.is_file() or not state_path.is_file():
            raise DEMRunError(f"{self.label}: --start-from {source}: not a finished DEM run (no run.json and state.json there)")
        state = json.loads(state_path.read_text())
        return {"run": state["fingerprint"]["run"], "fingerprint": state["fingerprint"],
                "seed": json.loads(record_path.read_text()).get("seed"), "restart": source / state["chunks"][-1]["restart"],
                "chunks": len(state["chunks"])}

    def _adopt_start(self) -> None:
        """Copy the final restart of ``start_from`` into this run as the shear stage's start.

        Only a run of the same case grown from the same shared fill qualifies: the walls, grains
        and ids must be this run's own. Its velocities are replaced by this run's Couette ramp at
        the first chunk, as after a fill; the steady-state test then decides, as always, when the
        packing has become this run's.
        """
        source = self._start_source
        # The lineage is the shared fill's seed, whether a run copied that fill or poured it itself.
        own_fill = shared_fill_of(self.case_name, self.case, self.run_id)
        if source["fingerprint"]["case"] != self.case_name or own_fill is None or source["seed"] != self.seed:
            raise DEMRunError(f"{self.label}: --start-from {self.start_from}: run {source['fingerprint']['case']}/{source['run']} "
                              f"did not grow from this run's shared fill {own_fill!r} (its seed {source['seed']}, the fill's {self.seed})")
        shutil.copy2(source["restart"], self.run_dir / START_RESTART)
        self.state["start"] = {"run": source["run"], "restart": str(source["restart"].relative_to(self.start_from)),
                               "after_chunks": source["chunks"]}
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

    def _write_fill_bodies(self, first_id: int, z_bottom: float) -> int:
        """Hook: write include files for bodies created before the pour; return their atom count.

        ``first_id`` is the id LIGGGHTS gives the first such atom; ``z_bottom`` (m) is the height of
        the bottom wall's centres. Planar shear has none.
        """
        return 0

    def _chunk_variables(self, stage: str) -> dict[str, object]:
        """Hook: extra template variables of one shear or production chunk (none for planar shear)."""
        return {}

    def _chunk_plan(self) -> dict[str, int]:
        v = self.reference_speed()
        samples = self.dem["series_samples_per_chunk"]
        duration = self.dem["chunk_strain"] * self.state["fill"]["settled_gap"] / v
        nevery = max(1, int(round(duration / self.design.dt / samples / 10)))
        series_every = 10 * nevery
        chunk_steps = series_every * samples
        def chunks(strain: float) -> int:
            return max(1, int(math.ceil(strain / self.dem["chunk_strain"])))

        n_prod = chunks(self.dem["production_strain"])
        # dem.snapshots per dem.production_strain, whatever this case's cap.
        per_chunk = max(1, int(math.ceil(self.dem["snapshots"] / chunks(self.dem["snapshot_strain"]))))
        dump_every = max(1, chunk_steps // per_chunk)
        while chunk_steps % dump_every:
            dump_every -= 1
        return {
            "chunk_steps": chunk_steps,
            "series_nevery": nevery,
            "series_nrepeat": 10,
            "series_every": series_every,
            "production_chunks": n_prod,
            "dump_every": dump_every,
        }

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

    def _run_chunk(self, kind: str, index: int, plan: dict[str, int]) -> dict[str, Any]:
        stage = f"{kind}_{index:03d}"
        chunks = self.state["chunks"]
        first = START_RESTART if "start" in self.state else "fill.restart"
        restart_in = first if not chunks else chunks[-1]["restart"]
        restart_out = f"restart/{stage}.restart"
        (self.run_dir / "restart").mkdir(exist_ok=True)
        (self.run_dir / "series").mkdir(exist_ok=True)
        n_wall = self.state["fill"]["n_top_wall_grains"]
        production = kind == "production"
        # A shear chunk may end up in the steady window that becomes the production's start, so
        # it writes its snapshots too (under its own name; adopted ones are renamed).
        dumped = production or self._window_is_production()
        if dumped:
            (self.run_dir / "dumps").mkdir(exist_ok=True)
        prefix = "" if production else "s"
        variables = self._base_variables() | {
            "restart_in": restart_in,
            "restart_out": restart_out + ".tmp",
            "first_chunk": int(not chunks),
            "z_bottom_wall": self.state["fill"]["z_bottom_wall"],
            "z_top_wall": self.state["fill"]["z_top_wall"],
            "wall_speed": self.wall_speed(),
            "gravity": self.case["gravity"],
            "load_per_grain": self.top_load() / n_wall,
            "wall_damping_per_grain": self._wall_damping() / n_wall,
            "delta_column": DELTA_COLUMN,
            "series_nevery": plan["series_nevery"],
            "series_nrepeat": plan["series_nrepeat"],
            "series_every": plan["series_every"],
            "series_file": f"series/{stage}.txt",
            "pairsum_file": f"series/pairsum_{stage}.txt",
            "thermo_every": plan["chunk_steps"] // 4,
            "chunk_steps": plan["chunk_steps"],
            "dump_every": plan["dump_every"] if dumped else 0,
            "particle_dump": f"dumps/particles_{prefix}{index:03d}.dump",
            "contact_dump": f"dumps/contacts_{prefix}{index:03d}.dump",
            "contact_columns": [f"c_pgl[{k}]" for k in range(1, len(CONTACT_COLUMNS) + 1)],
        } | self._chunk_variables(stage)
        render.render_stage(self.run_dir, stage, "shear.in", variables)
        seconds = run_liggghts(self.launcher, self.run_dir, stage, self.label)
        series = read_wall_series(self.run_dir / variables["series_file"])
        self._check_series(series, stage)
        (self.run_dir / (restart_out + ".tmp")).replace(self.run_dir / restart_out)
        record = {"stage": stage, "kind": kind, "restart": restart_out, "wall_seconds": seconds,
                  "steps": plan["chunk_steps"], "series": variables["series_file"],
                  "t_start": float(series["time"].iloc[0]), "t_end": float(series["time"].iloc[-1])}
        if dumped:
            record["dumps"] = [variables["particle_dump"], variables["contact_dump"]]
        chunks.append(record)
        self.state["wall_seconds"] += seconds
        self._save_state()
        return record

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

    def series(self, kinds: tuple[str, ...] = ("shear", "production")) -> pd.DataFrame:
        """The wall series of all committed chunks of the given kinds, in time order."""
        frames = [read_wall_series(self.run_dir / c["series"]) for c in self.state["chunks"] if c["kind"] in kinds]
        return pd.concat(frames, ignore_index=True)

    def _steady_test(self, window_chunks: list[dict[str, Any]]) -> dict[str, Any]:
        frames = [read_wall_series(self.run_dir / c["series"]) for c in window_chunks]
        data = pd.concat(frames, ignore_index=True)
        depth = self.state["fill"]["settled_gap"]
        force = drift_test(data["time"], data["ftop_x"], self.dem["steady_force_tol"], float(data["ftop_x"].mean()))
        height = drift_test(data["time"], data["h_top"], self.dem["steady_height_tol"], depth)
        test = {"force": force.as_dict(), "height": height.as_dict(), "load": self.load_balance(data),
                "stationary": force.stationary and height.stationary,
                "t_start": window_chunks[0]["t_start"], "t_end": window_chunks[-1]["t_end"]}
        if self._tests_creep():
            creep = self._creep_test(window_chunks)
            test |= {"creep": creep, "stationary": bool(test["stationary"] and creep["stationary"])}
        return test

    def min_shear_strain(self) -> float:
        """Strain of shear before the steady window may start: the case's ``min_shear_strain``,
        else ``dem.min_shear_strain`` (0 when neither is set; :func:`case_production` merges them)."""
        return float(self.dem.get("min_shear_strain", 0.0))

    def _tests_creep(self) -> bool:
        """Whether the steady-state test also holds the creep (``dem.steady_creep_tol``): planar
        shear with gravity whose shear chunks keep their snapshots (the window becomes production)."""
        return (self.case["geometry"] == "planar_shear" and self.case["gravity"] > 0
                and self.dem.get("steady_creep_tol") is not None and self._window_is_production())

    def _creep_test(self, window_chunks: list[dict[str, Any]]) -> dict[str, Any]:
        """The window's creep against the window of as many shear chunks before it, band by band
        (:func:`pipeline.dem.steady_state.creep_settled`); not stationary until there is one."""
        shear = [c for c in self.state["chunks"] if c["kind"] == "shear"]
        first = next(k for k, c in enumerate(shear) if c["stage"] == window_chunks[0]["stage"])
        n = len(window_chunks)
        if first < n:
            return {"stationary": False, "reason": "no earlier window yet", "tested": 0}
        earlier = shear[first - n:first]
        d = self.mat["d"]
        means = precision.chunk_means([self.run_dir / c["dumps"][0] for c in [*earlier, *window_chunks]], d,
                                      self.design.dt, self.reference_speed(), precision.BULK_MARGIN_OVER_D * d)
        bands, edges = band_speeds(means.u_disp_over_v, means.depth, d, tuple(self.dem.get("steady_creep_bands_over_d", STEADY_CREEP_BANDS)))
        return creep_settled(bands[:n], bands[n:], edges, float(self.dem["steady_creep_tol"]))

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

    def _steady_summary(self, test: dict[str, Any]) -> str:
        """One clause for the log: each drift as a fraction of what the test allows."""
        out = (f"force drift {abs(test['force']['drift']) / test['force']['allowed']:.2f}, height drift "
               f"{abs(test['height']['drift']) / test['height']['allowed']:.2f} of allowed; top-wall push / load "
               f"{test['load']['ratio']:.3f}")
        creep = test.get("creep")
        if creep is None:
            return out
        if "bands" not in creep:
            return out + f"; creep: {creep['reason']}"
        parts = [f"{r['depth_over_d'][0]:g}-{r['depth_over_d'][1]:g} d {r['log10_change']:+.2f} "
                 f"({abs(r['log10_change']) / r['allowed']:.2f} of allowed)" for r in creep["bands"] if "settled" in r]
        return out + "; creep change in decades against the window before: " + (", ".join(parts) or "no band resolved")

    # ------------------------------------------------------------------------------------ run
    def run(self) -> dict[str, Any]:
        """Run (or resume) all stages; return the run.json record."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        geometry = self.case["geometry"]
        render.copy_templates(geometry, self.run_dir)
        self._load_state()
        if "fill" not in self.state:
            if self.fill_from is not None:
                self._adopt_fill(self.fill_from)
            else:
                self._fill()
            print(f"{self.label}: fill and settle done, {self.state['fill']['settled_gap'] / self.mat['d']:.1f} d "
                  f"between the walls, {self.state['wall_seconds']:.1f} s", flush=True)
        # Committed before any chunk, so a resumed run never shears from the fill instead.
        if self.start_from is not None and "start" not in self.state:
            if self.state["chunks"]:
                raise DEMRunError(f"{self.label}: chunks committed without the start from {self.start_from} (state.json)")
            self._adopt_start()
        plan = self._chunk_plan()
        window = self.dem["steady_window_chunks"]
        # The window may start only after dem.min_shear_strain of shear (or the case's own): a state
        # sheared from its fill dilates over its first strain unit (nu 0.0006 +- 0.0003 above the
        # rest of the production on the rigid-limit benchmark's reference states), which the wall's
        # force and height tests do not see; the deep creep of a bed with gravity relaxes for 2-3
        # strain units, which the creep test's band errors do not resolve (docs/dem.md).
        settle = int(math.ceil(self.min_shear_strain() / self.dem["chunk_strain"] - 1e-9))
        while self.state["steady"] is None:
            shear = [c for c in self.state["chunks"] if c["kind"] == "shear"]
            if len(shear) >= window + settle:
                test = self._steady_test(shear[-window:])
                self.state["last_steady_test"] = test
                print(f"{self.label}: steady-state test over shear chunks {len(shear) - window + 1}-{len(shear)}: "
                      f"{self._steady_summary(test)}: {'steady' if test['stationary'] else 'not yet steady'}", flush=True)
                if test["stationary"]:
                    self.state["steady"] = test
                    if self._window_is_production():
                        self._adopt_window(shear[-window:])
                    self._save_state()
                    break
            if len(shear) >= self.dem["max_shear_chunks"]:
                test = self.state.get("last_steady_test", {})
                raise DEMRunError(
                    f"{self.label}: no steady state after {len(shear)} shear chunks (dem.max_shear_chunks); "
                    f"last drift test: force {test.get('force')}, height {test.get('height')}"
                )
            if self._window_is_production():
                # The creep test compares the window with the one before it: keep both.
                kept = 2 * window - 1 if self._tests_creep() else window - 1
                self._drop_stale_dumps(shear[max(0, len(shear) - kept):])
            self._progress(self._run_chunk("shear", len(shear), plan), plan)
        while True:
            produced = [c for c in self.state["chunks"] if c["kind"] == "production"]
            stop = self._production_stop(produced, plan)
            if stop is not None:
                self.state["production_stop"] = stop
                self._save_state()
                break
            self._progress(self._run_chunk("production", len(produced), plan), plan)
        return self._record(plan)

    #: False for runs that never look for a steady window to keep (the yield probe's staircase).
    KEEPS_STEADY_WINDOW = True

    def _window_is_production(self) -> bool:
        """Whether the steady-state test's window becomes the production's first chunks
        (``dem.precision.steady_window_is_production``).

        The window passed the test, so its chunks are as steady as any that follow; producing
        after it, as the fixed design does, throws away ``steady_window_chunks`` chunks of steady
        flow per run (1 strain in the default, half of a run's 2-strain cap).
        """
        precision_cfg = self.dem.get("precision") or {}
        return self.KEEPS_STEADY_WINDOW and bool(precision_cfg.get("steady_window_is_production", False))

    def _drop_stale_dumps(self, keep: list[dict[str, Any]]) -> None:
        """Delete the snapshots of shear chunks that can no longer fall in a steady window (all but
        ``keep``, the trailing chunks the next window will hold), so the shear stage keeps at most a
        window of them on disk."""
        kept = {c["stage"] for c in keep}
        stale = [c for c in self.state["chunks"] if c["kind"] == "shear" and "dumps" in c and c["stage"] not in kept]
        for chunk in stale:
            for name in chunk.pop("dumps"):
                (self.run_dir / name).unlink(missing_ok=True)
        if stale:
            self._save_state()

    def _adopt_window(self, window_chunks: list[dict[str, Any]]) -> None:
        """Make the steady window's chunks the first production chunks: kind ``production``, their
        snapshots renamed to the production's numbering (``dumps/particles_000.dump`` on). Safe to
        repeat after an interruption: a snapshot already renamed is found under its new name."""
        self._drop_stale_dumps(window_chunks)
        for index, chunk in enumerate(window_chunks):
            renamed = []
            for name in chunk["dumps"]:
                target = f"dumps/{Path(name).name.split('_')[0]}_{index:03d}.dump"
                source, dest = self.run_dir / name, self.run_dir / target
                if source.is_file():
                    source.replace(dest)
                elif not dest.is_file():
                    raise DEMRunError(f"{self.label}: snapshot {name} of steady chunk {chunk['stage']} is missing")
                renamed.append(target)
            chunk.update(kind="production", dumps=renamed, from_steady_window=True)

    def _min_production_chunks(self, plan: dict[str, int]) -> int:
        precision_cfg = self.dem.get("precision")
        if precision_cfg is None:
            return plan["production_chunks"]
        wanted = int(math.ceil(precision_cfg["min_production_strain"] / self.dem["chunk_strain"] - 1e-9))
        return min(plan["production_chunks"], max(precision.MIN_BLOCKS, wanted))

    def _production_stop(self, produced: list[dict[str, Any]], plan: dict[str, int]) -> dict[str, Any] | None:
        """Why production stops after the committed chunks ``produced``, or None to go on.

        Without ``dem.precision`` production has the fixed length ``production_strain``; with it,
        it goes on from ``min_production_strain`` until every target of the run's geometry is met
        (:mod:`pipeline.dem.precision`) or ``production_strain`` (the cap) is reached.
        """
        strain = len(produced) * self.dem["chunk_strain"]
        precision_cfg = self.dem.get("precision")
        if precision_cfg is None:
            if len(produced) < plan["production_chunks"]:
                return None
            return {"design": "fixed length", "reason": "fixed production length reached", "strain": strain,
                    "chunks": len(produced)}
        if len(produced) < self._min_production_chunks(plan):
            return None
        measured = self.production_precision(produced, precision_cfg)
        # JSON has no infinity: an unresolved error is recorded as null.
        for key in ("reached", "bound"):
            measured[key] = {k: (v if math.isfinite(v) else None) for k, v in measured[key].items()}
        self.state.setdefault("precision_history", {})[str(len(produced))] = measured
        stop = {"design": "precision target", "targets": self.precision_targets(precision_cfg), "strain": strain,
                "chunks": len(produced), "cap_strain": plan["production_chunks"] * self.dem["chunk_strain"]} | measured
        if measured["all_met"]:
            return stop | {"reason": "every precision target met"}
        if len(produced) >= plan["production_chunks"]:
            unmet = sorted(name for name, ok in measured["met"].items() if not ok)
            return stop | {"reason": f"strain cap production_strain reached with {', '.join(unmet) or 'no target'} unmet"}
        print(f"{self.label}: precision after {len(produced)} production chunks: "
              + ", ".join(f"{k} {'unresolved' if v is None else format(v, '.3g')} (bound "
                          f"{'unresolved' if measured['bound'][k] is None else format(measured['bound'][k], '.3g')}, "
                          f"target {stop['targets'][k]:g})" for k, v in measured["reached"].items())
              + ": going on", flush=True)
        return None

    def precision_targets(self, precision_cfg: dict[str, Any]) -> dict[str, float]:
        """The targets that apply to this run: the planar fields, the wall friction, and with
        gravity the creep."""
        names = ("u_x_over_v", "nu", "mu") + (("log_speed", "log_speed_depth_over_d") if self.case["gravity"] > 0 else ())
        return {k: float(precision_cfg[k]) for k in names if k in precision_cfg}

    def production_precision(self, produced: list[dict[str, Any]], precision_cfg: dict[str, Any]) -> dict[str, Any]:
        """Errors reached by the committed production chunks (:func:`pipeline.dem.precision.measure`)."""
        d = self.mat["d"]
        means = precision.chunk_means([self.run_dir / c["dumps"][0] for c in produced], d, self.design.dt,
                                      self.reference_speed(), precision.BULK_MARGIN_OVER_D * d)
        ratios = []
        for c in produced:
            wall = read_wall_series(self.run_dir / c["series"])
            ratios.append(abs(float(wall["ftop_x"].mean())) / float(wall["ftop_z"].mean()))
        return precision.measure(means, d, np.array(ratios), self.precision_targets(precision_cfg), self.case["gravity"] > 0)

    def _progress(self, chunk: dict[str, Any], plan: dict[str, int]) -> None:
        """One line per chunk on stdout (the rule's log): where the run stands and what is left.

        The shear stage ends when the steady-state test passes, so its length is not known in
        advance: the estimate counts the chunks still needed at the least (the test's window and
        the production) and says so.
        """
        chunks = self.state["chunks"]
        shear = [c for c in chunks if c["kind"] == "shear"]
        produced = [c for c in chunks if c["kind"] == "production"]
        window = self.dem["steady_window_chunks"]
        strain = self.dem["chunk_strain"]
        rate = chunk["steps"] * self.case["n_grains"] / max(chunk["wall_seconds"], 1e-9)
        if chunk["kind"] == "shear":
            margin = f"steady-state test from chunk {window} on"
            # An adopted steady window is the production's first chunks: that many fewer to come.
            adopted = window if self._window_is_production() else 0
            left = max(window - len(shear), 0) + max(plan["production_chunks"] - adopted, 0)
            where = f"shear {len(shear)} (strain {len(shear) * strain:g}, at most {self.dem['max_shear_chunks'] * strain:g})"
            bound = "at least "
        else:
            margin = "steady"
            left = plan["production_chunks"] - len(produced)
            where = (f"production {len(produced)}/{plan['production_chunks']} (strain {len(produced) * strain:g} "
                     f"of {plan['production_chunks'] * strain:g})")
            bound = ""
        mean_seconds = sum(c["wall_seconds"] for c in chunks) / max(len(chunks), 1)
        print(f"{self.label}: {where}; {margin}; {chunk['wall_seconds']:.1f} s, {rate / 1e6:.2f} M particle-steps/s; "
              f"left: {bound}{left} chunks, ~{left * mean_seconds:.0f} s", flush=True)

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

    def steps_by_stage(self) -> dict[str, int]:
        """Time steps spent in each stage: fill (pour and settle), shear to the steady state, production."""
        return {"fill": int(self.state["fill"].get("steps", 0))} | {kind: int(sum(c["steps"] for c in self.state["chunks"] if c["kind"] == kind)) for kind in ("shear", "production")}

    def seconds_by_stage(self) -> dict[str, float]:
        """Wall-clock seconds of LIGGGHTS in each stage (fill, shear, production)."""
        out = {"fill": float(self.state["fill"]["wall_seconds"])}
        for kind in ("shear", "production"):
            out[kind] = float(sum(c["wall_seconds"] for c in self.state["chunks"] if c["kind"] == kind))
        return out

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
            "seed": self.seed,
            "steady_state_window": [self.state["steady"]["t_start"], production[-1]["t_end"]],
            "steady_state_test": self.state["steady"],
            "production_window": [production[0]["t_start"], production[-1]["t_end"]],
            "production_drift": {"force": prod_force.as_dict(), "height": prod_height.as_dict()},
            # The top wall's mean push over its load across the production, and its damping's drag.
            "production_load_balance": self.load_balance(prod_series),
            "pair_force_sum": self.pair_force_sum(float(prod_series["ftop_x"].mean())),
            "max_overlap_over_d": float(self.series()["max_overlap"].max() / self.mat["d"]),
            "particle_dumps": [c["dumps"][0] for c in production],
            "contact_dumps": [c["dumps"][1] for c in production],
            "contact_columns": list(CONTACT_COLUMNS),
            "provenance": provenance(self.config),
        }
