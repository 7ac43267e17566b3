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

import numpy as np
import pytest

np.seterr(all="raise")


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random test input is reproducible."""
    return np.random.default_rng(20261123)


REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def reduced_results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Output root of one run of the real workflow on config/ci.yaml, with the real LIGGGHTS.

    Runs once per test session (a few minutes on 2 cores); every test that needs DEM output,
    fields or the report reads from it.
    """
    if shutil.which("liggghts") is None:
        pytest.fail("LIGGGHTS is not installed: run scripts/install.sh (the workflow test needs the real binary)")
    out = tmp_path_factory.mktemp("reduced") / "results"
    cmd = [
        sys.executable, "-m", "snakemake", "--cores", str(os.cpu_count() or 1),
        "--configfile", "config/ci.yaml", "--config", f"output_root={out}",
        "--directory", str(REPO), "--snakefile", str(REPO / "Snakefile"),
    ]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        logs = "\n".join(f"--- {p}\n{p.read_text()[-3000:]}" for p in sorted(out.glob("logs/**/*.log")))
        pytest.fail(f"reduced workflow failed (exit {proc.returncode}):\n{proc.stderr[-5000:]}\n{logs}")
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
