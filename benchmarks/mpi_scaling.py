"""MPI speed-up of the DEM stage: the same shear chunk of a >= 10k-grain cell on 1 and on 2 ranks.

The cell is a sheared steady state of the pipeline itself, tiled: the last restart file of a reduced
rheometer run (config/ci.yaml, I = 0.2, made here with ``pipeline.dem_run`` unless ``--source``
names one) is read and ``replicate``-d NX x NY times in the periodic plane (one serial LIGGGHTS
call writing a new restart), so the grains, the rough walls, the contact law, the time step and
the chunk input are exactly the pipeline's (``liggghts_inputs/planar_shear/shear.in``). The same rendered input is then run with
``mpirun -n 1`` and ``mpirun -n 2``; the speed-up is the ratio of the LIGGGHTS loop times
(wall-clock times, start-up included, are printed too). Runs alternate between the rank counts so
a changing machine load hits both alike; the load average is printed before and after.

Usage: ``python benchmarks/mpi_scaling.py [--source RUN_DIR] [--replicate 6 5] [--steps 3000] [--repeat 1]``
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from pipeline.dem_run import _mpi_environment  # noqa: E402

RUN = "I0.2-P200-r1"
_LOOP = re.compile(r"Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def make_source(work: Path) -> Path:
    """A finished reduced rheometer run (2 shear + 2 production chunks) to take the state from."""
    config = yaml.safe_load((REPO / "config" / "ci.yaml").read_text())
    config["output_root"] = str(work / "results")
    config["cases"] = {name: config["cases"][name] for name in ("rheometer", "shear_gravity")}
    config["dem"].update(steady_window_chunks=2, max_shear_chunks=4, steady_force_tol=1.0, steady_height_tol=1.0,
                         production_strain=1.0, snapshots=4, series_samples_per_chunk=20)
    path = work / "source.yaml"
    path.write_text(yaml.safe_dump(config))
    out = work / "source"
    subprocess.run([sys.executable, "-m", "pipeline.dem_run", "--config", str(path), "--case", "rheometer",
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
    for name in ("common_settings.in", "materials.in", "shear.in"):
        shutil.copy(source / name, bench / name)
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
    subprocess.run(["liggghts", "-in", "in.tile", "-log", "log.tile"], cwd=bench, stdout=subprocess.DEVNULL,
                   env=_mpi_environment(), check=True)
    return bench


def run(bench: Path, ranks: int) -> dict[str, float]:
    """One run on ``ranks`` MPI ranks; wall-clock and LIGGGHTS loop time (s)."""
    log = f"log.{ranks}"
    start = time.perf_counter()
    with open(bench / f"screen.{ranks}", "w") as screen:
        subprocess.run(["mpirun", "-n", str(ranks), "liggghts", "-in", "in.bench", "-log", log], cwd=bench,
                       stdout=screen, stderr=subprocess.STDOUT, env=_mpi_environment(), check=True)
    wall = time.perf_counter() - start
    match = _LOOP.search((bench / log).read_text())
    assert match and int(match.group(2)) == ranks, f"no loop time for {ranks} ranks in {bench / log}"
    return {"wall": wall, "loop": float(match.group(1)), "steps": int(match.group(3)), "atoms": int(match.group(4))}


def load() -> str:
    return Path("/proc/loadavg").read_text().split(" ", 3)[:3].__str__()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--source", type=Path, help="a finished planar-shear run folder (default: make one)")
    parser.add_argument("--replicate", type=int, nargs=2, default=(6, 5), metavar=("NX", "NY"))
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--keep", type=Path, help="keep the work folder here")
    args = parser.parse_args()
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
                print(f"{ranks} rank(s): {r['atoms']} atoms, {r['steps']} steps: loop {r['loop']:.2f} s, "
                      f"wall {r['wall']:.2f} s, {r['atoms'] * r['steps'] / r['loop'] / ranks:.3g} atom-steps/s per core")
        print(f"load average after: {load()}")
        best = {k: min(v, key=lambda r: r["loop"]) for k, v in results.items()}
        speedup = best[1]["loop"] / best[2]["loop"]
        print(f"speed-up 2 ranks vs 1: {speedup:.2f} (loop time), "
              f"{best[1]['wall'] / best[2]['wall']:.2f} (wall clock); parallel efficiency {speedup / 2:.0%}")
    finally:
        if args.keep:
            shutil.copytree(work, args.keep, dirs_exist_ok=True)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
