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


@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun (scripts/install.sh installs Open MPI)")
def test_a_one_rank_launch_is_not_pinned_to_one_core() -> None:
    parent = sorted(os.sched_getaffinity(0))
    if len(parent) < 2:
        pytest.skip("one core: nothing to pin away from")
    probe = [sys.executable, "-c", "import os; print(sorted(os.sched_getaffinity(0)))"]
    out = subprocess.run(["mpirun", "-n", "1", *probe], env=_mpi_environment(), capture_output=True, text=True,
                         check=True, timeout=60)
    assert out.stdout.strip() == str(parent), out.stdout
