"""Shared test fixtures.

Floating-point errors raise (as in py-pde's test suite) so that a NaN or an overflow inside a
solver or a coarse-graining kernel fails the test where it happens instead of propagating.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

np.seterr(all="raise")


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random test input is reproducible."""
    return np.random.default_rng(20261123)


REPO = Path(__file__).resolve().parent.parent


def _reduced_command(out: Path) -> list[str]:
    """The reduced workflow (config/ci.yaml) into ``out`` on every core."""
    return [
        sys.executable, "-m", "snakemake", "--cores", str(os.cpu_count() or 1),
        "--configfile", "config/ci.yaml", "--config", f"output_root={out}",
        "--directory", str(REPO), "--snakefile", str(REPO / "Snakefile"),
    ]


#: The reduced workflow started in the background at collection (``pytest_collection_modifyitems``):
#: ``out`` (its output root), ``log`` (its stdout and stderr) and ``proc``.
_REDUCED: dict[str, Any] = {}


def _needs_reduced(item: pytest.Item) -> bool:
    return "reduced_results" in getattr(item, "fixturenames", ())


@pytest.hookimpl(trylast=True)  # after -k / -m deselection: only the tests that will run count
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    """Start the reduced workflow as soon as the collected tests are known to need it, and run the
    tests that do not need it first, while it computes (issue 57: the suite's wall time). The
    workflow keeps about 1.2 of the 2 cores busy on average (its DEM runs one after another), so the
    single-core unit tests fill the rest. Whole test files move, so that no module-scoped fixture is
    set up twice; the order within each group is pytest's."""
    if config.option.collectonly or shutil.which("liggghts") is None:
        return  # without LIGGGHTS the fixture fails the tests that need it, with the reason
    modules_needing = {item.nodeid.split("::")[0] for item in items if _needs_reduced(item)}
    if not modules_needing:
        return
    items[:] = ([i for i in items if i.nodeid.split("::")[0] not in modules_needing]
                + [i for i in items if i.nodeid.split("::")[0] in modules_needing])
    out = config._tmp_path_factory.mktemp("reduced") / "results"  # the fixture's folder, as before
    log = out.parent / "workflow.log"
    with open(log, "w") as stream:
        proc = subprocess.Popen(_reduced_command(out), cwd=REPO, stdout=stream, stderr=subprocess.STDOUT, text=True)
    _REDUCED.update(out=out, log=log, proc=proc)


def pytest_unconfigure(config: pytest.Config) -> None:
    """A session that ends before the reduced workflow does (an interrupt, -x) stops it."""
    proc = _REDUCED.get("proc")
    if proc is not None and proc.poll() is None:
        proc.terminate()
        proc.wait()


@pytest.fixture(scope="session")
def reduced_results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Output root of one run of the real workflow on config/ci.yaml, with the real LIGGGHTS.

    Runs once per test session (a few minutes on 2 cores), started in the background at collection
    (``pytest_collection_modifyitems``) and waited for here; every test that needs DEM output,
    fields or the report reads from it.
    """
    if shutil.which("liggghts") is None:
        pytest.fail("LIGGGHTS is not installed: run scripts/install.sh (the workflow test needs the real binary)")
    if "proc" in _REDUCED:
        out, returncode = _REDUCED["out"], _REDUCED["proc"].wait()
        output = Path(_REDUCED["log"]).read_text()
    else:  # collected without the hook's start (e.g. the fixture requested dynamically)
        out = tmp_path_factory.mktemp("reduced") / "results"
        proc = subprocess.run(_reduced_command(out), cwd=REPO, capture_output=True, text=True, check=False)
        returncode, output = proc.returncode, proc.stderr
    if returncode != 0:
        logs = "\n".join(f"--- {p}\n{p.read_text()[-3000:]}" for p in sorted(out.glob("logs/**/*.log")))
        pytest.fail(f"reduced workflow failed (exit {returncode}):\n{output[-5000:]}\n{logs}")
    return out


@pytest.fixture(scope="session")
def shear_gravity_run(reduced_results: Path) -> Path:
    """Folder of the first reduced shear_gravity DEM run (real LIGGGHTS output)."""
    return reduced_results / "dem" / "shear_gravity" / "r1"


@pytest.fixture(scope="session")
def rheometer_run(reduced_results: Path) -> Path:
    """Folder of the first reduced rheometer DEM run (real LIGGGHTS output)."""
    runs = sorted((reduced_results / "dem" / "rheometer").glob("*/run.json"))
    assert runs, f"no rheometer run under {reduced_results}"
    return runs[0].parent
