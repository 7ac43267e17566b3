"""The SLURM profile (profiles/slurm): it parses, names only rules that exist, and a dry run of the
reduced workflow through it resolves the DEM jobs' MPI resources into their command lines."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import yaml

from pipeline.common.config import dem_fills, dem_runs, load_config

REPO = Path(__file__).resolve().parents[3]
PROFILE = REPO / "profiles" / "slurm"


def test_profile_resources_name_existing_rules() -> None:
    profile = yaml.safe_load((PROFILE / "config.yaml").read_text())
    assert profile["executor"] == "slurm"
    sources = [REPO / "Snakefile", *sorted((REPO / "rules").glob("*.smk"))]
    rules = {name for f in sources for name in re.findall(r"^rule (\w+):", f.read_text(), re.M)}
    # A typo in a rule name would be silently ignored by Snakemake.
    assert set(profile["set-resources"]) <= rules, set(profile["set-resources"]) - rules
    for rule in ("dem", "dem_fill"):
        dem = profile["set-resources"][rule]
        # The SLURM plugin refuses MPI jobs without tasks > 1; a DEM job also needs a runtime and memory.
        assert dem["mpi"] == "srun" and dem["tasks"] > 1 and dem["runtime"] > 0 and dem["mem_mb_per_cpu"] > 0, rule
    assert {"mem_mb", "runtime"} <= set(profile["default-resources"])


def test_dry_run_through_the_profile_gives_the_dem_jobs_their_ranks(tmp_path: Path) -> None:
    cmd = [sys.executable, "-m", "snakemake", "-n", "--profile", str(PROFILE), "--configfile", "config/ci.yaml",
           "--config", f"output_root={tmp_path}"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, check=False, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = proc.stdout + proc.stderr
    dem_commands = [line for line in out.splitlines() if "-m pipeline.dem " in line]
    config = load_config(REPO / "config" / "ci.yaml")
    # Every DEM run, and every fill several runs start from.
    assert len(dem_commands) == len(dem_runs(config)) + len(dem_fills(config)) > len(dem_runs(config))
    tasks = yaml.safe_load((PROFILE / "config.yaml").read_text())["set-resources"]["dem"]["tasks"]
    for line in dem_commands:
        assert f"--mpi-launcher 'srun' --mpi-ranks {tasks}" in line, line
    # Other rules are not MPI jobs.
    assert not [line for line in out.splitlines() if "pipeline.coarse_graining run" in line and "srun" in line]
