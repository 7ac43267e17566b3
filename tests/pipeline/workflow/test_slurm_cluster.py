"""The reduced workflow on a real SLURM cluster (tests/slurm_cluster.py: Debian's slurm-wlm 22.05
and munge, one node, started here as root and stopped by pid), through the executor plugin and
profiles/slurm.

What it shows:
- jobs reach SLURM: every rule's job is in slurmctld's log and ran as a SLURM job;
- the DEM jobs ran as the local reduced run does (config/ci.yaml: one rank), one SLURM task each
  with no MPI launcher (the plugin refuses an MPI job of one task; a one-rank run starts the bare
  binary anyway, locally too), and run.json and LIGGGHTS's log ("1 by 1 by 1 MPI processor grid") say so;
- the scores equal the local reduced run's (``reduced_results``, same config, seeds and domain
  split) to 1e-12 relative, and a DEM run's dumps are byte-identical: LIGGGHTS is deterministic
  for a given domain split;
- a DEM job killed by SLURM (``scancel`` while it runs a chunk) fails loudly, keeps its
  committed chunks, and the workflow's retry (profile ``retries``) completes it from there: its
  fill and early chunks are not run again;
- the profile's MPI path: a DEM run started in a batch allocation of 2 tasks with
  ``--mpi-launcher srun --mpi-ranks 2``, as the profile's ``dem`` rule starts it, runs LIGGGHTS on
  the 2 ranks (its log: "2 by 1 by 1 MPI processor grid"), keeps every grain, and its wall
  friction agrees with the local one-rank run within the noise (:func:`test_an_mpi_dem_run_starts_its_ranks_by_srun`).
LIGGGHTS runs through SLURM for three DEM runs (:data:`THROUGH_SLURM`), and their dump stores and
fields; the other runs' folders, dump stores and fields are the local reduced run's, copied in
before the start (a dry run checks that exactly the three are left to do), so the suite does not
pay the reduced DEM and its coarse-graining twice. Every rule runs through SLURM at least once, and
every rule after the fields (calibration, models, scores) for every case, for two of the five models
(:data:`SLURM_MODELS`, by ``--config models=...``, which no DEM run's config holds): the other three
run the same rules (``model``, ``intruder_model``, its draws, grid study and merge), and their 2D
intruder solves were 460 of the 640 slot-seconds of this run with all five (2026-12-05).
Where SLURM cannot be started here (not root, packages unavailable) the test fails with the
reason; it never skips.
"""
from __future__ import annotations

import json
import math
import re
import shlex
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from tests.pipeline.dem.test_planar_run import (assert_grains_kept_and_friction_agrees, fastest_rheometer_run,
                                                production_stages, rerun_command)
from tests.slurm_cluster import Cluster, local_cluster
from tests.workflow_outputs import dem_outputs

pytestmark = [pytest.mark.liggghts, pytest.mark.slurm]

REPO = Path(__file__).resolve().parents[3]
PROFILE = REPO / "profiles" / "slurm"
#: The local reduced run's ranks per DEM run (config/ci.yaml), which the workflow's DEM jobs keep.
RANKS = 1
#: Ranks of the MPI run started by srun in a batch allocation (the profile's path for a DEM job).
MPI_RANKS = 2
#: The DEM run the test cancels: the longest of the reduced set, so it is caught inside a chunk.
CANCELLED = ("shear_gravity", "r1")
#: The DEM runs LIGGGHTS computes through SLURM: the cancelled one (resumed, its dumps are compared
#: byte for byte), an intruder run (the other LIGGGHTS input) and a rheometer state (the one that
#: continues from a slower state's packing, copied in). Every other run's folder, dump store and
#: fields are the local reduced run's, copied before the workflow starts.
THROUGH_SLURM = (CANCELLED, ("intruder", "D4-r1"), ("rheometer", "I0.3-P50-r1"))
#: The models solved through SLURM: a 1D-and-2D fluidity model and a 2D yield-stress one (the two
#: intruder solver families), the cheapest of each.
SLURM_MODELS = ("local_mu_i", "ngf")


def slurm_command(out: Path) -> list[str]:
    """The reduced workflow through the profile, adapted to this one-node cluster as a user would
    adapt it to theirs: partition, ranks per DEM job, memory, logs under the output root, and job
    status from squeue (no accounting database here)."""
    return [
        sys.executable, "-m", "snakemake", "--profile", str(PROFILE), "--configfile", "config/ci.yaml",
        "--config", f"output_root={out}", f"models={{names: [{', '.join(SLURM_MODELS)}]}}", "--jobs", "4",
        "--default-resources", "slurm_partition=test", "mem_mb=1000", "runtime=30", "cpus_per_task=1", "tasks=1",
        # --set-resources replaces the profile's whole set. One task, as the local run's one rank,
        # with no MPI launcher: the plugin (2.8) refuses an MPI job of one task ("'tasks' must be
        # greater than 1"), and an empty ``mpi`` makes the job a plain one, the rule's command then
        # starting the bare binary (as every one-rank run does, docs/scaling.md).
        "--set-resources", *[f"{rule}:{item}" for rule in ("dem", "dem_fill")
                             for item in ("mpi=''", f"tasks={RANKS}", "cpus_per_task=1", "mem_mb=1000", "runtime=30")],
        "dump_store:mem_mb=2000", "fields:mem_mb=2000", "calibrate:mem_mb=2000", "report:mem_mb=2000",
        "failure_catalogue:runtime=30",
        "--slurm-status-command", "squeue", "--slurm-logdir", str(out / "logs" / "slurm"),
        # A one-node test cluster answers squeue at once: poll soon (a site keeps the defaults). The
        # plugin (2.8) waits this long after a check that saw a job finish, and 10 s more after each
        # check that saw none (--seconds-between-status-checks is overridden by that back-off): at 5 s
        # a job of a few seconds was seen done 10-15 s late, and the rerun's slots stood empty for
        # 126 of its 251 s (2026-12-06, slurmctld's log: submissions on a 10 s beat).
        "--slurm-init-seconds-before-status-checks", "1", "--seconds-between-status-checks", "2",
        "--slurm-no-account",
        "--latency-wait", "10", "--retries", "1",
        # Up to the scores: the report and the stability study (which runs its own small DEM
        # cases) add jobs but nothing this test compares.
        str(out / "scores.csv"),
    ]


def planned_jobs(out: Path, env: dict) -> dict[str, set[tuple[str, str]]]:
    """The per-run jobs a dry run of the SLURM command plans: ``dem`` (case, run) pairs, and the
    runs whose dump store or fields are to be made (it also writes the per-run configs into
    ``out``, as the real run will, unchanged)."""
    proc = subprocess.run([*slurm_command(out), "--dry-run", "--printshellcmds"], cwd=REPO, env=env,
                          capture_output=True, text=True, check=False, timeout=600)
    if proc.returncode != 0:
        pytest.fail(f"dry run of the SLURM workflow failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    text = proc.stdout + proc.stderr
    run_dirs = re.findall(r"python -m pipeline\.dumps \S*/dem/([^/\s]+)/([^/\s]+) ", text)
    run_dirs += re.findall(r"python -m pipeline\.coarse_graining \S+ .*?--run-dir \S*/dem/([^/\s]+)/([^/\s]+) ", text)
    return {"dem": set(re.findall(r"python -m pipeline\.dem --config \S+ --case (\S+) --run (\S+)", text)),
            "per_run": set(run_dirs)}


def seed_local_runs(local: Path, out: Path, env: dict) -> None:
    """Copy the local reduced run's results of every DEM run but :data:`THROUGH_SLURM` into ``out``:
    the DEM folder with its dump store, and its fields, newer than the per-run configs the workflow
    writes and each newer than what it is made from, so Snakemake takes them as done. Check that
    exactly those runs are left to do, by a dry run through the profile."""
    planned = planned_jobs(out, env)["dem"]
    copied = sorted(planned - set(THROUGH_SLURM))
    for case, run in copied:
        shutil.copytree(local / "dem" / case / run, out / "dem" / case / run)
        for folder in ("fields", "fields_xz"):
            for path in sorted((local / folder / case).glob(f"{run}.*")):
                (out / folder / case).mkdir(parents=True, exist_ok=True)
                shutil.copy2(path, out / folder / case / path.name)
    # In the order the workflow makes them: shared fills, runs, dump stores, fields.
    stages = [lambda c, r: [out / "dem" / c / r / "fill.json"], lambda c, r: [out / "dem" / c / r / "run.json"],
              lambda c, r: [out / "dem" / c / r / "dumps.nc"],
              lambda c, r: sorted((out / "fields" / c).glob(f"{r}.*")) + sorted((out / "fields_xz" / c).glob(f"{r}.*"))]
    for stage in stages:
        for case, run in copied:
            for path in stage(case, run):
                if path.exists():
                    path.touch()
    left = planned_jobs(out, env)
    assert left["dem"] == set(THROUGH_SLURM), f"planned before seeding {sorted(planned)}, after {sorted(left['dem'])}"
    assert left["per_run"] == set(THROUGH_SLURM), f"dump stores and fields still planned for {sorted(left['per_run'])}"


def cancel_mid_chunk(cluster: Cluster, run_dir: Path, seen: dict, timeout: float = 900.0) -> None:
    """Watch for the DEM job of ``run_dir`` and ``scancel`` it once it has committed its fill and a
    chunk and is inside the next one; record what was on disk then."""
    end = time.monotonic() + timeout
    state = run_dir / "state.json"
    while time.monotonic() < end:
        chunks = json.loads(state.read_text()).get("chunks", []) if state.exists() else []
        if len(chunks) >= 1:
            queue = cluster.run("squeue", "-h", "-t", "RUNNING", "-o", "%i %k", check=False).stdout
            # The plugin puts the rule and the wildcards' values in the job's comment.
            for line in queue.splitlines():
                job, _, comment = line.partition(" ")
                if comment.strip() == f"rule_dem_wildcards_{CANCELLED[0]}_{CANCELLED[1]}":
                    seen["chunks_at_cancel"] = [c["stage"] for c in chunks]
                    seen["fill_log_mtime"] = (run_dir / "logs" / "fill.log").stat().st_mtime_ns
                    seen["job"] = job
                    seen["scancel"] = cluster.run("scancel", job, check=False).returncode
                    return
        time.sleep(0.5)
    seen["error"] = "the job to cancel was not seen running with a committed chunk"


def mpi_run_in_allocation(cluster: Cluster, local: Path, folder: Path) -> dict:
    """The local reduced run's fastest rheometer state again, as a batch job of :data:`MPI_RANKS`
    tasks whose command starts LIGGGHTS by ``srun -n 2``, as the profile's ``dem`` rule does
    (``--mpi-launcher srun``); waited for (``sbatch --wait``)."""
    record = fastest_rheometer_run(local)
    folder.mkdir(parents=True)
    command = shlex.join(rerun_command(record, local, folder / "run", "srun", MPI_RANKS))
    proc = subprocess.run(["sbatch", "--wait", "--parsable", "-p", cluster.partition, f"--ntasks={MPI_RANKS}", "--cpus-per-task=1",
                           "--mem-per-cpu=1000", "--time=30", f"--chdir={REPO}", f"--output={folder / 'job.log'}",
                           f"--wrap={command}"], env=cluster.env, capture_output=True, text=True, check=False, timeout=900)
    log = folder / "job.log"
    return {"record": record, "dir": folder / "run", "returncode": proc.returncode, "job": proc.stdout.strip().split(";")[0],
            "output": proc.stdout + proc.stderr + (log.read_text()[-3000:] if log.exists() else "")}


def wait_for_local_dem(local: Path, runs: set[tuple[str, str]], workflow: subprocess.Popen | None,
                       timeout: float = 3000.0) -> None:
    """Wait until the local reduced run has made every DEM folder, dump store and fields file of
    ``runs`` (its DEM and coarse-graining come first: ``tests/conftest.py`` prioritises them), or
    stop if it ended without them."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        missing = [p for p in dem_outputs(local, runs) or [local / "config.effective.json"] if not p.exists()]
        if not missing:
            return
        if _EARLY.get("stopping"):
            raise RuntimeError("the test session ended before the local DEM did")
        if workflow is not None and workflow.poll() is not None:
            raise RuntimeError(f"the local reduced workflow ended (exit {workflow.returncode}) without {missing[0]}")
        time.sleep(2.0)
    raise RuntimeError(f"the local reduced workflow did not make {missing[0]} within {timeout:g} s")


def slurm_rerun(base: Path, local: Path, workflow: subprocess.Popen | None) -> dict:
    """Start the cluster, wait for the local run's DEM and fields, copy them in, run the workflow
    through the profile (cancelling one DEM job mid-chunk), then the MPI run in an allocation."""
    out = base / "results"
    with local_cluster(base / "cluster") as cluster:
        wait_for_local_dem(local, planned_jobs(out, cluster.env)["dem"], workflow)
        seed_local_runs(local, out, cluster.env)
        seen: dict = {}
        watcher = threading.Thread(target=cancel_mid_chunk, args=(cluster, out / "dem" / CANCELLED[0] / CANCELLED[1], seen),
                                   daemon=True)
        watcher.start()
        start = time.monotonic()
        proc = subprocess.Popen(slurm_command(out), cwd=REPO, env=cluster.env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        _EARLY["proc"] = proc  # (stop_at_unconfigure ends it if the session ends first)
        stdout, stderr = proc.communicate(timeout=1800)
        seconds = time.monotonic() - start
        watcher.join(timeout=5)
        mpi = mpi_run_in_allocation(cluster, local, base / "mpi") if proc.returncode == 0 and not _EARLY.get("stopping") else {}
        ctld_log = cluster.log("slurmctld")
        jobs = cluster.run("squeue", "-h", "-t", "all", "-o", "%i|%T|%k|%D|%C", check=False).stdout
    return {"out": out, "seen": seen, "ctld_log": ctld_log, "jobs": jobs, "seconds": seconds, "stderr": stderr,
            "stdout": stdout, "returncode": proc.returncode, "mpi": mpi}


#: The rerun started at collection (:func:`start_at_collection`): its thread, and its result or error.
_EARLY: dict[str, Any] = {}


def start_at_collection(tmp_path_factory: pytest.TempPathFactory, started: dict[str, dict[str, Any]]) -> None:
    """Called by ``tests/conftest.py`` once the background workflows are started: run the SLURM
    rerun in a thread from now on. It waits for the local run's DEM and fields, then runs beside
    the local run's models and the other tests: its jobs spend most of their wall time in the
    plugin's status checks (busy 0.38 of 2 slots, 2026-12-07), which the local models fill."""
    local = started.get("reduced_results")
    if local is None:
        return
    base = tmp_path_factory.mktemp("slurm")

    def work() -> None:
        try:
            _EARLY["result"] = slurm_rerun(base, local["out"], local["proc"])
        except BaseException as exc:  # noqa: BLE001 (handed to the fixture, which fails with it)
            _EARLY["error"] = exc

    _EARLY["thread"] = threading.Thread(target=work, daemon=True)
    _EARLY["thread"].start()


def stop_at_unconfigure() -> None:
    """Called by ``tests/conftest.py`` at the session's end: a session that ends before the rerun
    (an interrupt, -x) stops its workflow, and its thread then stops the cluster's daemons."""
    _EARLY["stopping"] = True
    proc = _EARLY.get("proc")
    if proc is not None and proc.poll() is None:
        proc.terminate()
    thread = _EARLY.get("thread")
    if thread is not None:
        thread.join(timeout=300)


@pytest.fixture(scope="module")
def slurm_run(tmp_path_factory: pytest.TempPathFactory, reduced_results: Path) -> dict:
    if "thread" in _EARLY:
        _EARLY["thread"].join()
        if "error" in _EARLY:
            raise _EARLY["error"]
        run = _EARLY["result"]
    else:  # not started at collection (a test selected on its own by a dynamic fixture request)
        run = slurm_rerun(tmp_path_factory.mktemp("slurm"), reduced_results, None)
    if run["returncode"] != 0:
        pytest.fail(f"workflow through SLURM failed (exit {run['returncode']}):\n{run['stdout'][-4000:]}\n{run['stderr'][-6000:]}")
    print(f"\nSLURM workflow: {run['seconds']:.0f} s wall; jobs:\n{run['jobs']}")
    return run


def test_jobs_ran_as_slurm_jobs(slurm_run: dict) -> None:
    rows = [line.split("|") for line in slurm_run["jobs"].splitlines() if line.strip()]
    # The MPI run's batch job (test_an_mpi_dem_run_starts_its_ranks_by_srun) is no workflow job.
    mpi_job = slurm_run["mpi"].get("job")
    assert mpi_job and sum(r[0] == mpi_job for r in rows) == 1, (mpi_job, slurm_run["jobs"])
    submitted = len(rows)
    rows = [r for r in rows if r[0] != mpi_job]
    states = pd.Series([r[1] for r in rows]).value_counts()
    steps = re.findall(r"(\d+) of (\d+) steps \(100%\) done", slurm_run["stderr"])
    print(f"job states in squeue: {states.to_dict()}; Snakemake: {steps[-1][0] if steps else '?'} jobs done")
    assert steps and steps[-1][0] == steps[-1][1]
    # No rule is local: every Snakemake job was a SLURM job that completed, and the cancelled DEM
    # job is there once more, cancelled, before its retry.
    assert states.get("COMPLETED", 0) == int(steps[-1][0])
    assert states.get("CANCELLED", 0) == 1
    assert set(states.index) <= {"COMPLETED", "CANCELLED"}
    assert slurm_run["ctld_log"].count("_slurm_rpc_submit_batch_job") == submitted


def test_dem_ran_on_the_ranks_the_local_run_used(slurm_run: dict) -> None:
    records = [slurm_run["out"] / "dem" / case / run / "run.json" for case, run in THROUGH_SLURM]
    for path in records:
        run = json.loads(path.read_text())
        # One task, no launcher: the job's command started the bare binary.
        assert run["mpi_ranks"] == RANKS and run["mpi_launcher"] == "" and run["mpi_start"] == "bare binary (one rank)", path
        stage = next(c["stage"] for c in json.loads((path.parent / "state.json").read_text())["chunks"] if c["kind"] == "production")
        log = (path.parent / "logs" / f"{stage}.log").read_text()
        grids = [math.prod(int(n) for n in g) for g in re.findall(r"(\d+) by (\d+) by (\d+) MPI processor grid", log)]
        assert grids and all(g == RANKS for g in grids), (path, grids)


def test_scores_equal_the_local_run(slurm_run: dict, reduced_results: Path) -> None:
    """Same config, seeds and domain split (one rank: the bare binary, locally and here in a
    one-task job): the DEM is bitwise the same, so every score is equal. (Across rank counts it would not
    be: LIGGGHTS is deterministic for a given decomposition only, and a chaotic flow turns the
    different summation order into an independent realisation, whose scores differ by their whole
    realisation scatter, calibration included: 1 rank against 2 moved fluidity_micro_log_rmse by
    27 times its DEM noise in one measurement.)"""
    local = pd.read_csv(reduced_results / "scores.csv")
    remote = pd.read_csv(slurm_run["out"] / "scores.csv")
    assert set(remote["model"]) == set(SLURM_MODELS)
    local = local[local["model"].isin(SLURM_MODELS)]
    both = local.merge(remote, on=["case", "model", "metric"], suffixes=("_local", "_slurm"))
    assert len(both) == len(local) == len(remote) > 0
    for name in ("value", "dem_noise"):
        a, b = both[f"{name}_local"].to_numpy(float), both[f"{name}_slurm"].to_numpy(float)
        np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b))
        np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-12, atol=0, err_msg=name)
    # And the DEM itself: every particle dump is byte-identical, of the run SLURM cancelled and
    # resumed too (every chunk, the cancelled one again, starts from a committed restart file).
    run = CANCELLED
    for dump in sorted((reduced_results / "dem" / run[0] / run[1] / "dumps").glob("particles_*.dump")):
        assert dump.read_bytes() == (slurm_run["out"] / "dem" / run[0] / run[1] / "dumps" / dump.name).read_bytes(), dump.name


def test_an_mpi_dem_run_starts_its_ranks_by_srun(slurm_run: dict) -> None:
    """The profile's MPI path: a batch job of 2 tasks whose DEM command starts LIGGGHTS by
    ``srun -n 2`` ran on 2 ranks splitting the periodic plane, kept every grain, and its wall
    friction agrees with the local one-rank run within the noise (another realisation)."""
    mpi = slurm_run["mpi"]
    assert mpi and mpi["returncode"] == 0, mpi.get("output", "the workflow through SLURM failed first")
    run = json.loads((mpi["dir"] / "run.json").read_text()) | {"_dir": mpi["dir"]}
    assert run["mpi_ranks"] == MPI_RANKS and run["mpi_launcher"] == "srun" and run["mpi_start"] == f"srun -n {MPI_RANKS}"
    for stage in production_stages(run):
        log = (mpi["dir"] / "logs" / f"{stage}.log").read_text()
        assert f"{MPI_RANKS} by 1 by 1 MPI processor grid" in log and f"{MPI_RANKS} procs" in log, stage
    assert_grains_kept_and_friction_agrees(run, mpi["record"])


def test_cancelled_dem_job_resumed_from_its_committed_chunks(slurm_run: dict) -> None:
    seen = slurm_run["seen"]
    assert "error" not in seen, seen.get("error")
    assert seen["scancel"] == 0
    run_dir = slurm_run["out"] / "dem" / CANCELLED[0] / CANCELLED[1]
    state = json.loads((run_dir / "state.json").read_text())
    stages = [c["stage"] for c in state["chunks"]]
    # The chunks committed before the cancel are the first ones of the finished run, not redone:
    # the fill's log is the one written before the cancel.
    assert stages[: len(seen["chunks_at_cancel"])] == seen["chunks_at_cancel"]
    assert (run_dir / "logs" / "fill.log").stat().st_mtime_ns == seen["fill_log_mtime"]
    assert (run_dir / "run.json").exists()
