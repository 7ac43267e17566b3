"""DEM engines: one adapter per engine, named by ``dem.engine`` (``liggghts``, the default, or ``lammps``).

The run's lifecycle (:mod:`pipeline.dem.lifecycle`: fill, shear to steady state, production chunks,
restarts, records, precision stops) knows no engine. An adapter holds what does: its stage templates
(``liggghts_inputs/``, ``lammps_inputs/``), how its binary is started, how its log is checked, and
how its dumps are brought to the one format the dump store reads (:mod:`pipeline.dumps.reader`:
particle dumps ``id type x y z vx vy vz omegax omegay omegaz radius mass fx fy fz``, contact dumps
with the columns :data:`CONTACT_COLUMNS`). The wall series files have the same columns in both
(:mod:`pipeline.dem.wall_series`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

#: Columns of a contact dump in the dump store, both engines: positions of the two grains (the
#: second as the image nearest the first), ids, whether the contact crosses a periodic face, the
#: force on grain 1 (N), the overlap (m) and the contact point (m). LIGGGHTS writes them in this
#: order (``compute pair/gran/local pos id force contactPoint delta``; checked by a test on a real
#: run); LAMMPS's are converted to it (:mod:`pipeline.dem.engines.lammps`).
CONTACT_COLUMNS = (
    "x1", "y1", "z1", "x2", "y2", "z2", "id1", "id2", "periodic",
    "fx", "fy", "fz", "delta", "cx", "cy", "cz",
)
#: 1-based column of ``delta`` among :data:`CONTACT_COLUMNS` (a LIGGGHTS template reads it).
DELTA_COLUMN = CONTACT_COLUMNS.index("delta") + 1
#: The engines ``dem.engine`` may name.
ENGINE_NAMES = ("liggghts", "lammps")
#: The engine of a config without ``dem.engine`` (every config before the key existed).
DEFAULT_ENGINE = "liggghts"


class Engine(Protocol):
    """What the run lifecycle asks of a DEM engine."""

    name: str
    #: Solid fraction of the loose grains before the pour (sets the fill box's height).
    insertion_solid_fraction: float
    #: How the engine's processes are started, for the run's record (``run.json``'s ``mpi_start``).
    start: str

    def check_geometry(self, geometry: str, label: str) -> None:
        """Raise :class:`pipeline.dem.liggghts_log.DEMRunError` if the engine has no templates for ``geometry``."""

    def copy_templates(self, geometry: str, run_dir: Path) -> None:
        """Copy the geometry's stage templates into ``run_dir``, with the engine's contact law
        (``material.tangential_damping``: the templates byte for byte when true)."""

    def render_stage(self, run_dir: Path, stage: str, template: str, variables: dict[str, object]) -> Path:
        """Write ``run_dir/in.<stage>``: the variables, then the template."""

    def grains_include(self, d: float, polydispersity: float, n_sizes: int, rho_s: float,
                       seeds: list[int], distribution_seed: int) -> str:
        """Engine text that pours the flowing grains (written to ``grains.in`` by the fill)."""

    def launch(self, run_dir: Path, stage: str, label: str) -> float:
        """Run ``in.<stage>`` in ``run_dir``; return wall-clock seconds. Raises ``DEMRunError``."""

    def chunk_variables(self, run_dir: Path, variables: dict[str, Any]) -> dict[str, object]:
        """Engine-specific template variables of one shear or production chunk."""

    def finish_chunk(self, run_dir: Path, variables: dict[str, Any]) -> None:
        """Bring the chunk's dumps to the store's format (after a successful run, before commit)."""


def engine_name(dem: dict[str, Any]) -> str:
    """``dem.engine``, or the default when the config predates the key."""
    return str(dem.get("engine", DEFAULT_ENGINE))


def make_engine(dem: dict[str, Any], material: dict[str, Any] | None = None) -> Engine:
    """The adapter of the config's ``dem`` section (its ``engine``, executable and MPI layout), with
    the contact law of its ``material`` section (``tangential_damping``: :mod:`pipeline.dem.contact_law`;
    absent, or no material given, the law with tangential damping)."""
    from pipeline.dem.contact_law import tangential_damping
    name = engine_name(dem)
    damping = tangential_damping(material)
    if name == "liggghts":
        from pipeline.dem.engines.liggghts import LiggghtsEngine
        return LiggghtsEngine(dem["liggghts"], dem["mpi_launcher"], dem["mpi_ranks"], damping)
    if name == "lammps":
        from pipeline.dem.engines.lammps import LammpsEngine
        return LammpsEngine(dem["mpi_launcher"], dem["mpi_ranks"], damping)
    raise ValueError(f"dem.engine: {name!r} is not an engine (choose from {', '.join(ENGINE_NAMES)})")
