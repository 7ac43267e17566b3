"""The LIGGGHTS adapter: templates in ``liggghts_inputs/``, the ``liggghts`` binary (Debian's 3.8,
Open MPI), its logs read by :mod:`pipeline.dem.liggghts_log`, its dumps already in the store's format."""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.dem import liggghts_render as render
from pipeline.dem.engines import CONTACT_COLUMNS, DELTA_COLUMN
from pipeline.dem.liggghts_log import DEMRunError, check_run


@dataclass
class Launcher:
    """How LIGGGHTS is started: ``mpi_launcher -n ranks liggghts``, and one rank as the bare binary.

    One rank is started without a launcher, as an MPI singleton (:func:`mpi_environment`): the
    same single process and the same numbers (the SLURM test compares them byte for byte), without
    mpirun's daemon or the interconnect probing a lone process has no use for. A start took a
    median 0.42 s through ``mpirun -n 1`` and 0.37 s bare with Open MPI's defaults, against 0.065 s
    as an isolated singleton on shared memory (``benchmarks/engine_start.py``, docs/dem_cost.md
    30): a run restarts the engine at every chunk (about 1800 launches in the default)."""

    liggghts: str
    mpi_launcher: str = ""
    ranks: int = 1

    @property
    def singleton(self) -> bool:
        """Whether the run is one rank started as the bare binary."""
        return self.ranks == 1

    @property
    def start(self) -> str:
        """How :meth:`command` starts the engine, for the run's record."""
        return "bare binary (one rank)" if self.singleton else f"{self.mpi_launcher} -n {self.ranks}"

    def command(self, input_name: str, log_name: str) -> list[str]:
        if not self.singleton and self.mpi_launcher.strip() in ("", "none"):
            # (the config's validation refuses this first; a command line's --mpi-launcher may not)
            raise DEMRunError(f"dem.mpi_ranks is {self.ranks} but dem.mpi_launcher is empty: without a launcher "
                              "(mpirun, srun) LIGGGHTS would run one rank")
        binary = shutil.which(self.liggghts)
        if binary is None:
            raise DEMRunError(f"LIGGGHTS executable {self.liggghts!r} not found on PATH (install the Debian package 'liggghts')")
        # Screen output is kept (sent to a file by the caller): LIGGGHTS 3.8 crashes in some
        # fixes (wall/gran primitive) when started with '-screen none'.
        cmd = [binary, "-in", input_name, "-log", log_name]
        if self.singleton:
            return cmd
        launcher = shlex.split(self.mpi_launcher)
        if shutil.which(launcher[0]) is None:
            raise DEMRunError(f"MPI launcher {launcher[0]!r} not found on PATH")
        return [*launcher, "-n", str(self.ranks), *cmd]


#: Open MPI settings of a one-rank run (a singleton): no ``orted`` daemon forked to serve it, and
#: the point-to-point layer that needs no network (``ob1`` over ``self`` and shared memory), so the
#: start does not probe Omni-Path's ``psm2``, whose library sleeps in a loop while it looks for
#: adapters. Set as defaults only: a user's own environment wins.
SINGLETON_MCA = {"OMPI_MCA_ess_singleton_isolated": "1", "OMPI_MCA_pml": "ob1", "OMPI_MCA_btl": "self,vader"}


def _mpi_environment(singleton: bool, session_base: Path) -> dict[str, str]:
    """The environment a LIGGGHTS launch runs in; ``singleton``: a one-rank run started bare
    (:data:`SINGLETON_MCA`); ``session_base``: the directory Open MPI keeps its session files in
    (:func:`mpi_environment` gives each launch its own)."""
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
    if singleton:
        for key, value in SINGLETON_MCA.items():
            env.setdefault(key, value)
    # Not a default the user's environment may override: a shared base is what races.
    env["OMPI_MCA_orte_tmpdir_base"] = str(session_base)
    return env


@contextmanager
def mpi_environment(singleton: bool = False) -> Iterator[dict[str, str]]:
    """:func:`_mpi_environment` with a session directory of the launch's own, removed afterwards.

    Every isolated singleton is job family 0, so concurrent one-rank launches share Open MPI's
    session directory ``<tmp>/ompi.<host>.<uid>/jf.0``: one creating it while another, finishing,
    removes it fails ``MPI_Init`` ("A call to mkdir was unable to create the desired directory ...
    File exists"). Measured with 4 concurrent loops of a LIGGGHTS start
    (``benchmarks/singleton_race.py``, docs/dem_cost.md 35): 23 failures in 4000 launches with the
    shared base, 0 in 4000 with a base each. A base the user names (``OMPI_MCA_orte_tmpdir_base``,
    say a node's scratch disk) holds the launches' own bases."""
    named = os.environ.get("OMPI_MCA_orte_tmpdir_base") or None
    if named is not None and not Path(named).is_dir():
        raise DEMRunError(f"the environment's OMPI_MCA_orte_tmpdir_base {named!r} is not a directory "
                          "(Open MPI's session files go there): create it or unset the variable")
    base = Path(tempfile.mkdtemp(prefix="ompi-", dir=named))
    try:
        yield _mpi_environment(singleton, base)
    finally:
        # Open MPI removes its own session files; the base is ours, and empty unless a rank crashed.
        shutil.rmtree(base, ignore_errors=True)


def run_liggghts(launcher: Launcher, run_dir: Path, stage: str, label: str) -> float:
    """Run ``in.<stage>`` in ``run_dir``; return wall-clock seconds. Raises :class:`DEMRunError`."""
    log = Path("logs") / f"{stage}.log"
    (run_dir / "logs").mkdir(exist_ok=True)
    screen = run_dir / "logs" / f"{stage}.screen"
    start = time.perf_counter()
    with screen.open("w") as out, mpi_environment(launcher.singleton) as env:
        proc = subprocess.run(
            launcher.command(f"in.{stage}", str(log)),
            cwd=run_dir,
            stdout=out,
            stderr=subprocess.STDOUT,
            env=env,
            check=False,
        )
    seconds = time.perf_counter() - start
    check_run(f"{label} stage {stage}", run_dir / log, proc.returncode, screen.read_text(errors="replace"))
    return seconds


class LiggghtsEngine:
    """LIGGGHTS 3.8: ``pair_style gran model hertz tangential history``, ``newton off``."""

    name = "liggghts"
    #: Solid fraction of the loose insertion region (insert/pack places the grains by itself).
    insertion_solid_fraction = 0.25

    def __init__(self, liggghts: str, mpi_launcher: str = "", ranks: int = 1, tangential_damping: bool = True) -> None:
        self.launcher = Launcher(liggghts, mpi_launcher, ranks)
        #: material.tangential_damping (pipeline/dem/contact_law.py): the templates' law when true.
        self.tangential_damping = tangential_damping

    @property
    def start(self) -> str:
        return self.launcher.start

    def check_geometry(self, geometry: str, label: str) -> None:
        try:
            render.template_files(geometry)
        except render.TemplateError as exc:
            raise DEMRunError(f"{label}: {exc}") from None

    def copy_templates(self, geometry: str, run_dir: Path) -> None:
        render.copy_templates(geometry, run_dir, self.tangential_damping)

    def render_stage(self, run_dir: Path, stage: str, template: str, variables: dict[str, object]) -> Path:
        return render.render_stage(run_dir, stage, template, variables)

    def grains_include(self, d: float, polydispersity: float, n_sizes: int, rho_s: float,
                       seeds: list[int], distribution_seed: int) -> str:
        return render.grains_include(d, polydispersity, n_sizes, rho_s, seeds, distribution_seed)

    def launch(self, run_dir: Path, stage: str, label: str) -> float:
        return run_liggghts(self.launcher, run_dir, stage, label)

    def chunk_variables(self, run_dir: Path, variables: dict[str, Any]) -> dict[str, object]:
        # pair/gran/local writes CONTACT_COLUMNS in order; the overlap is its DELTA_COLUMN-th output.
        return {"delta_column": DELTA_COLUMN,
                "contact_columns": [f"c_pgl[{k}]" for k in range(1, len(CONTACT_COLUMNS) + 1)]}

    def finish_chunk(self, run_dir: Path, variables: dict[str, Any]) -> None:
        """LIGGGHTS's dumps are already in the store's format."""
