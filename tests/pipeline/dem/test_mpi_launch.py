"""The MPI launch of a DEM run leaves the kernel free to place it (real Open MPI, no LIGGGHTS).

Two of the workflow's one-rank DEM jobs run at once on a 2-core machine; Open MPI's default
binding pinned each launch to core 0, so both shared it. The launch environment of
:func:`pipeline.dem.planar_run._mpi_environment` must leave a rank the cores its parent has.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from pipeline.dem.planar_run import _mpi_environment


def test_a_one_rank_launch_is_not_pinned_to_one_core() -> None:
    # The default config launches LIGGGHTS through mpirun: without it the DEM cannot run at all.
    if shutil.which("mpirun") is None:
        pytest.fail("mpirun is not installed: run scripts/install.sh (the default DEM launcher is mpirun)")
    parent = sorted(os.sched_getaffinity(0))
    if len(parent) < 2:
        # Binding cannot pin a one-core process anywhere else: the property has no content here.
        pytest.skip("the test process has one core: no second core to be pinned away from")
    probe = [sys.executable, "-c", "import os; print(sorted(os.sched_getaffinity(0)))"]
    out = subprocess.run(["mpirun", "-n", "1", *probe], env=_mpi_environment(), capture_output=True, text=True,
                         check=True, timeout=60)
    assert out.stdout.strip() == str(parent), out.stdout
