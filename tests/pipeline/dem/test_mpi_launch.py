"""The MPI launch of a DEM run leaves the kernel free to place it (real Open MPI and LIGGGHTS).

Two of the workflow's one-rank DEM jobs run at once on a 2-core machine; Open MPI's default
binding pinned each launch to core 0, so both shared it. The launch environment of
:func:`pipeline.dem.planar_run._mpi_environment` must leave a rank the cores its parent has,
whether it starts through mpirun (several ranks) or as the bare binary (one rank, a singleton).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from pipeline.common.config import ConfigError, validate_config
from pipeline.dem.engines.liggghts import Launcher
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.planar_run import _mpi_environment

CI = Path(__file__).resolve().parents[3] / "config" / "ci.yaml"


def test_a_one_rank_launch_is_not_pinned_to_one_core() -> None:
    # Several ranks start through mpirun (dem.mpi_launcher): without it they cannot run at all.
    if shutil.which("mpirun") is None:
        pytest.fail("mpirun is not installed: run scripts/install.sh (the launcher of runs on several ranks)")
    parent = sorted(os.sched_getaffinity(0))
    if len(parent) < 2:
        # Binding cannot pin a one-core process anywhere else: the property has no content here.
        pytest.skip("the test process has one core: no second core to be pinned away from")
    probe = [sys.executable, "-c", "import os; print(sorted(os.sched_getaffinity(0)))"]
    out = subprocess.run(["mpirun", "-n", "1", *probe], env=_mpi_environment(), capture_output=True, text=True,
                         check=True, timeout=60)
    assert out.stdout.strip() == str(parent), out.stdout


@pytest.mark.liggghts
def test_a_one_rank_run_is_the_bare_binary_and_keeps_every_core(tmp_path) -> None:
    """One rank starts LIGGGHTS itself, whatever launcher the config names (an Open MPI
    singleton, no mpirun daemon), and the running engine is not pinned: a child it starts
    (LIGGGHTS's ``shell``) reads the affinity it inherits."""
    parent = os.sched_getaffinity(0)
    if len(parent) < 2:
        pytest.skip("the test process has one core: no second core to be pinned away from")
    launcher = Launcher("liggghts", "mpirun", 1)
    command = launcher.command("in.probe", "log.probe")
    assert launcher.singleton and command == [shutil.which("liggghts"), "-in", "in.probe", "-log", "log.probe"]
    (tmp_path / "in.probe").write_text("shell grep Cpus_allowed_list /proc/self/status > affinity.txt\n")
    subprocess.run(command, cwd=tmp_path, env=_mpi_environment(launcher.singleton), capture_output=True,
                   check=True, timeout=60)
    listed = (tmp_path / "affinity.txt").read_text().split()[-1]
    cores = set()
    for part in listed.split(","):
        low, _, high = part.partition("-")
        cores.update(range(int(low), int(high or low) + 1))
    assert cores == parent


def test_several_ranks_without_a_launcher_are_refused() -> None:
    """dem.mpi_ranks above 1 with no dem.mpi_launcher would run one rank: refused, naming both
    keys, by the config's validation and by the launcher itself (a command line's override)."""
    with pytest.raises(DEMRunError, match="dem.mpi_ranks is 2 but dem.mpi_launcher is empty"):
        Launcher("liggghts", "", 2).command("in.x", "log.x")
    config = yaml.safe_load(CI.read_text())
    config["dem"].update(mpi_ranks=2, mpi_launcher="")
    with pytest.raises(ConfigError, match=r"ci.yaml: dem.mpi_ranks is 2 but dem.mpi_launcher is empty"):
        validate_config(config, str(CI))
