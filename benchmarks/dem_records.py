"""What a finished output root's DEM did and cost, read from its records and logs.

The run records (``dem/<case>/<run>/run.json`` and ``state.json``; the shared fills'
``dem/<case>/fill-r<k>/fill.json``, counted once): particle-steps (grains x time steps) and
core-seconds (the engine's wall time x ranks) by stage. The engine logs (``dem/<case>/<run>/logs``,
one per stage; a shared fill's log, copied into each run that adopted it, counted in the fill's
folder only): the particle-steps and core-seconds inside the engines' own ``run`` loops (their
``Loop time`` lines), the engine's own rate without its start-ups and the pipeline's work between
chunks. Read by ``benchmarks/workflow_cost.py`` (the bills of two designs) and
``benchmarks/workflow_timeline.py`` (a run's use of its slots, issue 57 item 4).
"""
from __future__ import annotations

import functools
import json
import sys
from pathlib import Path

import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.planar_run import settled_timestep  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from engine_speed import LOOP  # noqa: E402  (a LIGGGHTS or LAMMPS log's timing of one run command)


def fill_steps(run_dir: Path, state: dict) -> int:
    """Steps of the fill: recorded since issue 19, else the settled snapshot's time step."""
    if "steps" in state.get("fill", {}):
        return int(state["fill"]["steps"])
    return settled_timestep(run_dir / "settled.dump")


def stage_of(case: str, run: str) -> str:
    """Row label: the size study's runs (L<cell>-r<k>) apart from the case's replicas."""
    return f"{case} size study" if run.startswith("L") else case


def run_costs(root: Path) -> pd.DataFrame:
    """One row per finished DEM run under ``root``: work by stage and wall time."""
    rows = []
    for record_path in sorted((root / "dem").glob("*/*/run.json")):
        run_dir = record_path.parent
        record = json.loads(record_path.read_text())
        state = json.loads((run_dir / "state.json").read_text())
        n = record["particle_count"]
        chunks = state["chunks"]
        steps = {"fill": fill_steps(run_dir, state)}
        for kind in ("shear", "production"):
            steps[kind] = sum(c["steps"] for c in chunks if c["kind"] == kind)
        ranks = record.get("mpi_ranks", 1)
        seconds = {"fill": state["fill"]["wall_seconds"]} | {
            kind: sum(c["wall_seconds"] for c in chunks if c["kind"] == kind) for kind in ("shear", "production")}
        strain = {kind: sum(1 for c in chunks if c["kind"] == kind) * state["fingerprint"]["config"]["dem"]["chunk_strain"]
                  for kind in ("shear", "production")}
        rows.append({"case": stage_of(record["case"], record["run"]), "run": record["run"],
                     "particle_steps": n * sum(steps.values()),
                     **{f"particle_steps_{k}": n * v for k, v in steps.items()},
                     "core_seconds": ranks * sum(seconds.values()),
                     **{f"core_seconds_{k}": ranks * v for k, v in seconds.items()},
                     "shear_strain": strain["shear"], "production_strain": strain["production"],
                     # Production chunks that were the steady-state test's window (none before 2026-12-02).
                     "window_chunks": sum(1 for c in chunks if c.get("from_steady_window")),
                     "stop": (record.get("production_stop") or {}).get("reason", "fixed length")})
    # Fills shared by several runs (their runs record a fill of 0 steps), and the intruder's sheared
    # beds (cases.<case>.shared_bed: a fill and its shear to steady state): counted once.
    for record_path in sorted((root / "dem").glob("*/fill-*/fill.json")):
        record = json.loads(record_path.read_text())
        n, ranks = record["particle_count"], record.get("mpi_ranks", 1)
        steps, seconds = record["steps_by_stage"], record["wall_seconds_by_stage"]
        bed = record.get("bed")
        rows.append({"case": record["case"], "run": record["run"], "particle_steps": n * sum(steps.values()),
                     "particle_steps_fill": n * steps["fill"], "particle_steps_shear": n * steps.get("shear", 0),
                     "particle_steps_production": 0,
                     "core_seconds": ranks * sum(seconds.values()), "core_seconds_fill": ranks * seconds["fill"],
                     "core_seconds_shear": ranks * seconds.get("shear", 0.0), "core_seconds_production": 0.0,
                     "shear_strain": bed["strain"] if bed else float("nan"), "production_strain": float("nan"),
                     "window_chunks": 0, "stop": "sheared bed" if bed else "shared fill"})
    if not rows:
        raise SystemExit(f"{root}: no finished DEM runs (dem/*/*/run.json)")
    return pd.DataFrame(rows)


def run_logs(run_dir: Path) -> list[Path]:
    """The engine logs a DEM folder's own job wrote, one per stage: a shared fill's log, copied into
    each run that adopted it, is counted in the fill's folder only."""
    state = run_dir / "state.json"
    shared = state.exists() and json.loads(state.read_text()).get("fill", {}).get("shared")
    return [log for log in sorted((run_dir / "logs").glob("*.log")) if not (shared and log.name == "fill.log")]


@functools.lru_cache(maxsize=None)
def log_loops(log: Path) -> tuple[tuple[str, ...], ...]:
    """Every ``run`` loop's timing in an engine log (seconds, processes, steps, atoms), read once
    for both the loops' totals and the launches."""
    return tuple(LOOP.findall(log.read_text(errors="replace")))


def engine_loops_by_case(root: Path) -> pd.DataFrame:
    """Particle-steps (``loop_steps``) and core-seconds (``loop_seconds``: wall time x processes)
    inside the engines' own ``run`` loops, per case (index), from every DEM log of ``root`` (runs
    and shared fills, each log once: :func:`run_logs`)."""
    rows = [(run_dir.parent.name, float(n_steps) * float(atoms), float(t) * float(procs))
            for run_dir in sorted((root / "dem").glob("*/*/")) for log in run_logs(run_dir)
            for t, procs, n_steps, atoms in log_loops(log)]
    return pd.DataFrame(rows, columns=["case", "loop_steps", "loop_seconds"]).groupby("case").sum()


def engine_loops(root: Path) -> tuple[float, float]:
    """Particle-steps and core-seconds inside the engines' own ``run`` loops, every case together."""
    by_case = engine_loops_by_case(root)
    return float(by_case["loop_steps"].sum()), float(by_case["loop_seconds"].sum())


def dem_records(root: Path) -> list[dict]:
    """The run and shared-fill records of ``root``'s finished DEM (``run.json``, ``fill.json``)."""
    return [json.loads(p.read_text()) for pattern in ("*/*/run.json", "*/fill-*/fill.json")
            for p in sorted((root / "dem").glob(pattern))]
