"""MPI speed-up of the DEM stage: the same shear chunk of a >= 10k-grain cell on 1 and on 2 ranks.

The cell is a sheared steady state of the pipeline itself, tiled: the last restart file of a reduced
rheometer run (config/ci.yaml, I = 0.2, made here with ``pipeline.dem.planar_run`` unless ``--source``
names one) is read and ``replicate``-d NX x NY times in the periodic plane (one serial LIGGGHTS
call writing a new restart), so the grains, the rough walls, the contact law, the time step and
the chunk input are exactly the pipeline's (``liggghts_inputs/planar_shear/shear.in``). The same rendered input is then run with
``mpirun -n 1`` and ``mpirun -n 2``; the speed-up is the ratio of the LIGGGHTS loop times
(wall-clock times, start-up included, are printed too). Runs alternate between the rank counts so
a changing machine load hits both alike; the load average is printed before and after, and the
CPU seconds of all ranks (a busy-waiting rank counts its waiting too).

Usage: ``python benchmarks/mpi_scaling.py [--source RUN_DIR] [--replicate 6 5] [--steps 3000] [--repeat 1]``
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem.planar_run import mpi_environment  # noqa: E402

RUN = "I0.2-P200-r1"
_LOOP = re.compile(r"Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def make_source(work: Path) -> Path:
    """A finished reduced rheometer run (2 shear chunks, its steady window and so its production's start, and the production after them) to take the state from."""
    config = yaml.safe_load((REPO / "config" / "ci.yaml").read_text())
    config["output_root"] = str(work / "results")
    config["cases"] = {name: config["cases"][name] for name in ("rheometer", "shear_gravity")}
    config["dem"].update(steady_window_chunks=2, max_shear_chunks=4, steady_force_tol=1.0, steady_height_tol=1.0,
                         production_strain=1.0, snapshots=4, series_samples_per_chunk=20)
    path = work / "source.yaml"
    path.write_text(yaml.safe_dump(config))
    out = work / "source"
    subprocess.run([sys.executable, "-m", "pipeline.dem", "--config", str(path), "--case", "rheometer",
                    "--run", RUN, "--out", str(out), "--mpi-launcher", "none"], cwd=REPO, check=True)
    return out


def prepare(source: Path, work: Path, nx: int, ny: int, steps: int) -> Path:
    """Render the benchmark input: the source's last chunk input continued from its last restart,
    tiled nx x ny times (once, serially: LIGGGHTS' ``replicate`` copies only local atoms), then
    ``steps`` steps without dumps."""
    state = json.loads((source / "state.json").read_text())
    last = state["chunks"][-1]
    bench = work / "bench"
    bench.mkdir()
    for name in ("materials.in", "shear.in"):
        shutil.copy(source / name, bench / name)
    # The repository's shared settings (the MPI domain layout among them), not the source run's copy.
    shutil.copy(REPO / "liggghts_inputs" / "common_settings.in", bench / "common_settings.in")
    shutil.copy(source / last["restart"], bench / "start.restart")
    text = (source / f"in.{last['stage']}").read_text()
    overrides = {"restart_in": "tiled.restart", "restart_out": "end.restart", "first_chunk": "0",
                 "chunk_steps": str(steps), "thermo_every": str(max(1, steps // 4)), "dump_every": "0",
                 "series_file": "series.txt"}
    for key, value in overrides.items():
        text, n = re.subn(rf'^variable {key} string ".*"$', f'variable {key} string "{value}"', text, flags=re.M)
        assert n == 1, key
    (bench / "in.bench").write_text(text)
    # LIGGGHTS 3.8 syntax: replicate nx ny nz offset dx dy dz shift sx sy sz.
    (bench / "in.tile").write_text(text.replace("include shear.in", "\n".join([
        # 'run 0' first: the contact-history fix must take its restart data before atoms are copied
        # (LIGGGHTS crashes otherwise); the copies' histories name partners of the first tile, so
        # their contacts restart without tangential history, which is immaterial for timing.
        "include common_settings.in", "read_restart start.restart", "include materials.in", "run 0",
        f"replicate {nx} {ny} 1 offset ${{Lx}} ${{Ly}} 0.0 shift 0.0 0.0 0.0", "write_restart tiled.restart", ""])))
    with mpi_environment() as env:
        subprocess.run(["liggghts", "-in", "in.tile", "-log", "log.tile"], cwd=bench, stdout=subprocess.DEVNULL,
                       env=env, check=True)
    return bench


def run(bench: Path, ranks: int) -> dict[str, float]:
    """One run on ``ranks`` MPI ranks; wall-clock and LIGGGHTS loop time (s)."""
    log = f"log.{ranks}"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    with open(bench / f"screen.{ranks}", "w") as screen, mpi_environment() as env:
        subprocess.run(["mpirun", "-n", str(ranks), "liggghts", "-in", "in.bench", "-log", log], cwd=bench,
                       stdout=screen, stderr=subprocess.STDOUT, env=env, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    # CPU seconds of all ranks (mpirun waits for them, so they count as our children's children).
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    match = _LOOP.search((bench / log).read_text())
    assert match and int(match.group(2)) == ranks, f"no loop time for {ranks} ranks in {bench / log}"
    grid = re.search(r"(\d+ by \d+ by \d+) MPI processor grid", (bench / log).read_text())
    return {"wall": wall, "loop": float(match.group(1)), "steps": int(match.group(3)), "atoms": int(match.group(4)),
            "cpu": cpu, "grid": grid.group(1) if grid else "?"}


# ------------------------------------------------------------------------------- projection
#: The largest study projected (docs/scaling.md): (case, grains per cell, runs per replica, replicas).
#: Rheometer: the 7 states of config/config.yaml; intruder: 3 depths plus the control run.
STUDY = (("rheometer", 20_000, 7, 5), ("shear_gravity", 100_000, 1, 5), ("intruder", 50_000, 4, 5))
RHEOMETER_STATES = ((0.002, 200.0), (0.006, 200.0), (0.02, 200.0), (0.06, 200.0), (0.2, 200.0),
                    (0.02, 600.0), (0.06, 600.0))
D, RHO_S, NU, G = 0.002, 2500.0, 0.6, 9.81
CHUNKS = 12  # shear chunks to steady state (4-8 seen with config.yaml) plus 4 production chunks
CHUNK_STRAIN = 0.5
FILL_OVERHEAD = 0.1  # pouring and settling, as a fraction of the shearing steps (reduced runs: < 10 %)


def projection(throughput: float, efficiency: float, ranks: int = 8) -> list[dict[str, float]]:
    """Core-hours of the STUDY from a measured throughput (atom-steps per core-second) and parallel
    efficiency, taken to hold at ``ranks`` ranks per run (profiles/slurm: 8, i.e. 2500 to 12500
    grains per rank; an assumption: only 2 ranks were measured).

    Steps per chunk: rheometer ``chunk_strain d / (I sqrt(P / rho_s) dt)`` (independent of the cell
    size); sheared beds ``chunk_strain H / (V dt)`` with H the bed depth at solid fraction NU. The
    time step follows the contact design: dt ~ p_max^(-1/2) (stiffness ~ the largest pressure at a
    fixed design overlap), scaled from dt = 2.26e-6 s at p_max = 820 Pa (config/config.yaml).
    """
    v_grain = 0.54 * D**3  # mean grain volume of the +-20 % size distribution
    depth = {"shear_gravity": 100_000 * v_grain / (NU * (40 * D) ** 2),
             "intruder": 50_000 * v_grain / (NU * (40 * D) * (20 * D))}
    p_max = 200.0 + RHO_S * NU * G * max(depth.values())
    dt = 2.26e-6 * (820.0 / p_max) ** 0.5
    rows = []
    for case, grains, runs, replicas in STUDY:
        if case == "rheometer":
            steps = sum(CHUNKS * CHUNK_STRAIN * D / (i * (p / RHO_S) ** 0.5 * dt) for i, p in RHEOMETER_STATES)
            longest = CHUNKS * CHUNK_STRAIN * D / (min(i for i, _ in RHEOMETER_STATES) * (200.0 / RHO_S) ** 0.5 * dt)
        else:
            steps = runs * CHUNKS * CHUNK_STRAIN * depth[case] / (0.1 * dt)
            longest = steps / runs
        atom_steps = grains * steps * replicas * (1.0 + FILL_OVERHEAD)
        core_hours = atom_steps / (throughput * efficiency) / 3600.0
        hours = grains * longest * (1.0 + FILL_OVERHEAD) / (throughput * efficiency * ranks) / 3600.0
        rows.append({"case": case, "grains": grains, "runs": runs * replicas, "steps_per_replica": steps,
                     "core_hours": core_hours, "ranks_per_run": ranks, "longest_run_hours": hours})
    return rows


def print_projection(throughput: float, efficiency: float) -> None:
    rows = projection(throughput, efficiency)
    print(f"projection at {throughput:.3g} atom-steps/s per core, parallel efficiency {efficiency:.2f}:")
    for r in rows:
        print(f"  {r['case']:>13}: {r['grains']:>7} grains, {r['runs']:>3} runs, {r['steps_per_replica']:.3g} steps "
              f"per replica, {r['core_hours']:.0f} core-h; {r['ranks_per_run']} ranks per run, longest run "
              f"{r['longest_run_hours']:.1f} h")
    print(f"  total: {sum(r['runs'] for r in rows)} runs, {sum(r['core_hours'] for r in rows):.0f} core-hours")


def load() -> str:
    return Path("/proc/loadavg").read_text().split(" ", 3)[:3].__str__()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--source", type=Path, help="a finished planar-shear run folder (default: make one)")
    parser.add_argument("--replicate", type=int, nargs=2, default=(6, 5), metavar=("NX", "NY"))
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--keep", type=Path, help="keep the work folder here")
    parser.add_argument("--project", type=float, nargs=2, metavar=("THROUGHPUT", "EFFICIENCY"),
                        help="only print the projection for these measured values")
    args = parser.parse_args()
    if args.project:
        print_projection(*args.project)
        return
    work = Path(tempfile.mkdtemp(prefix="mpi_scaling_"))
    try:
        source = args.source or make_source(work)
        bench = prepare(source, work, *args.replicate, args.steps)
        print(f"load average before: {load()}  (cores: {os.cpu_count()})")
        results: dict[int, list[dict[str, float]]] = {1: [], 2: []}
        for _ in range(args.repeat):
            for ranks in (1, 2):
                results[ranks].append(run(bench, ranks))
                r = results[ranks][-1]
                print(f"{ranks} rank(s) ({r['grid']}): {r['atoms']} atoms, {r['steps']} steps: loop {r['loop']:.2f} s, "
                      f"wall {r['wall']:.2f} s, CPU {r['cpu']:.2f} s, "
                      f"{r['atoms'] * r['steps'] / r['loop'] / ranks:.3g} atom-steps/s per core")
        print(f"load average after: {load()}")
        best = {k: min(v, key=lambda r: r["loop"]) for k, v in results.items()}
        speedup = best[1]["loop"] / best[2]["loop"]
        print(f"speed-up 2 ranks vs 1: {speedup:.2f} (loop time), "
              f"{best[1]['wall'] / best[2]['wall']:.2f} (wall clock); parallel efficiency {speedup / 2:.0%}")
        r1 = best[1]
        print_projection(r1["atoms"] * r1["steps"] / r1["loop"], speedup / 2)
    finally:
        if args.keep:
            shutil.copytree(work, args.keep, dirs_exist_ok=True)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
