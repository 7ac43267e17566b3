"""The MPI launch of a DEM run leaves the kernel free to place it (real Open MPI and LIGGGHTS).

Two of the workflow's one-rank DEM jobs run at once on a 2-core machine; Open MPI's default
binding pinned each launch to core 0, so both shared it. The launch environment of
:func:`pipeline.dem.planar_run.mpi_environment` must leave a rank the cores its parent has,
whether it starts through mpirun (several ranks) or as the bare binary (one rank, a singleton).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from pipeline.common.config import ConfigError, validate_config
from pipeline.dem.engines.liggghts import Launcher
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.planar_run import mpi_environment, run_liggghts

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
    with mpi_environment() as env:
        out = subprocess.run(["mpirun", "-n", "1", *probe], env=env, capture_output=True, text=True, check=True,
                             timeout=60)
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
    with mpi_environment(launcher.singleton) as env:
        subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, check=True, timeout=60)
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


@pytest.mark.liggghts
def test_each_launch_keeps_its_session_files_in_a_directory_of_its_own(tmp_path, monkeypatch) -> None:
    """Every isolated singleton is Open MPI job family 0: launches sharing a session base race on
    ``ompi.<host>.<uid>/jf.0`` (one creating it as another removes it fails MPI_Init). Each launch
    must name a base of its own, inside one the user names, hold its session files there while it
    runs (LIGGGHTS's ``shell`` lists them) and leave nothing behind."""
    shared = tmp_path / "scratch"
    shared.mkdir()
    monkeypatch.setenv("OMPI_MCA_orte_tmpdir_base", str(shared))
    launcher = Launcher("liggghts", "", 1)
    bases = []
    for name in ("a", "b"):
        run_dir = tmp_path / name
        run_dir.mkdir()
        (run_dir / "in.probe").write_text("variable base getenv OMPI_MCA_orte_tmpdir_base\n"
                                          "print \"base ${base}\"\n"
                                          "shell find ${base} -name jf.* > session.txt\n"
                                          # an empty run: the launch's check wants one finished
                                          "atom_modify sort 0 0.0\nregion box block 0 1 0 1 0 1\n"
                                          "create_box 1 box\nmass 1 1.0\nrun 0\n")
        run_liggghts(launcher, run_dir, "probe", f"probe {name}")
        base = Path(re.search(r"^base (\S+)$", (run_dir / "logs" / "probe.log").read_text(), re.M).group(1))
        found = (run_dir / "session.txt").read_text().split()
        assert base.parent == shared and found and all(Path(f).is_relative_to(base) for f in found), (base, found)
        assert not base.exists()
        bases.append(base)
    assert bases[0] != bases[1]


def test_a_session_base_that_is_not_a_directory_is_refused_naming_the_variable(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("OMPI_MCA_orte_tmpdir_base", str(tmp_path / "missing"))
    with pytest.raises(DEMRunError, match="OMPI_MCA_orte_tmpdir_base .*missing.* is not a directory"):
        with mpi_environment(True):
            pass
