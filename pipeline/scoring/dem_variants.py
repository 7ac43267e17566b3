"""What a variant of an output root keeps of its DEM, and what that DEM cost (issue 57, item 2).

A variant (:class:`Variant`) is a prefix of every run's production (its first 1/8, 1/4, 1/2 of the
snapshots: :func:`prefix_count`, :func:`prefix_of`, :func:`prefix_record`; a rod's speed over the same
prefix of its position series: :func:`prefix_rod`) or a subset of a case's replicas
(:func:`replica_subsets`), no new DEM. :mod:`pipeline.scoring.claims_cost` scores and judges each.

DEM cost (:func:`run_cost`, :func:`variant_cost`): per case, the LIGGGHTS wall seconds of its
scored runs times their MPI ranks (``run.json`` ``wall_seconds_by_stage``), the fill and the shear
to steady state paid in full, the production scaled by the fraction of it kept (its snapshots kept
over its snapshots), plus the shared fills and sheared beds the kept runs started from (``fill.json``,
counted once), in core-hours. ``dem_core_hours_with_window``: the same where the production cannot
be shorter than the steady-state test's window it begins with
(``production_chunks_from_steady_window`` of ``production_chunks``): what such a run would cost today.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import pandas as pd

#: Fractions of the production kept by default (issue 57).
FRACTIONS = (0.125, 0.25, 0.5)
#: Fewest snapshots a prefix keeps (an average and a block error need two).
MIN_SNAPSHOTS = 2


# -------------------------------------------------------------------------------- snapshots
def prefix_count(n: int, fraction: float, minimum: int = MIN_SNAPSHOTS) -> int:
    """How many of a production's ``n`` snapshots its first ``fraction`` keeps: ``ceil(fraction n)``
    (at least the fraction), never fewer than ``minimum`` nor more than ``n``."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction {fraction}: expected 0 < fraction <= 1")
    if n < minimum:
        raise ValueError(f"{n} snapshots: a prefix needs at least {minimum}")
    return int(min(n, max(minimum, math.ceil(fraction * n - 1e-9))))


def production_indices(timesteps: np.ndarray, run: dict[str, Any]) -> np.ndarray:
    """Indices of the snapshots inside the run's steady-state window, the fields' window (the rule
    of :func:`pipeline.coarse_graining.fields.steady_snapshots`, half a time step of slack)."""
    t0, t1 = run["steady_state_window"]
    dt = float(run["time_step"])
    times = np.asarray(timesteps, dtype=float) * dt
    return np.nonzero((times >= t0 - 0.5 * dt) & (times <= t1 + 0.5 * dt))[0]


@dataclass(frozen=True)
class Prefix:
    """A prefix of one run's production: its window (s), the snapshots kept and the production's."""

    window: tuple[float, float]
    kept: int
    total: int

    @property
    def kept_fraction(self) -> float:
        return self.kept / self.total


def prefix_of(timesteps: np.ndarray, run: dict[str, Any], fraction: float) -> Prefix:
    """The window of the first ``fraction`` of a run's production snapshots (:func:`prefix_count`):
    from the window's start to the last kept snapshot's time."""
    chosen = production_indices(timesteps, run)
    if chosen.size < MIN_SNAPSHOTS:
        raise ValueError(f"{run.get('case')}/{run.get('run')}: {chosen.size} snapshots in the steady window")
    keep = prefix_count(int(chosen.size), fraction)
    t0, t1 = (float(t) for t in run["steady_state_window"])
    # Every snapshot kept: the run's own window (its wall series run past the last snapshot).
    t_end = t1 if keep == chosen.size else float(timesteps[chosen[keep - 1]]) * float(run["time_step"])
    return Prefix((t0, t_end), keep, int(chosen.size))


def prefix_record(run: dict[str, Any], prefix: Prefix, fraction: float) -> dict[str, Any]:
    """``run.json`` of a run cut to ``prefix``: its steady-state and production windows end at the
    last kept snapshot (the fields and the wall's series are read over it), ``claims_cost`` says so."""
    out = json.loads(json.dumps(run))
    out["steady_state_window"] = [prefix.window[0], prefix.window[1]]
    production = run.get("production_window", run["steady_state_window"])
    out["production_window"] = [float(production[0]), prefix.window[1] if prefix.kept < prefix.total else float(production[1])]
    out["claims_cost"] = {"fraction": fraction, "snapshots_kept": prefix.kept, "snapshots_production": prefix.total,
                          "window_full": run["steady_state_window"], "note": "prefix of the production: "
                          "pipeline.scoring.claims_cost, not a DEM run of its own"}
    return out


def store_timesteps(run_dir: Path, run: dict[str, Any]) -> np.ndarray:
    """The particle snapshots' time steps, from ``dumps.nc`` alone where it exists."""
    from pipeline.dumps.store import STORE_NAME

    store = Path(run_dir) / STORE_NAME
    if store.is_file():
        import netCDF4

        with netCDF4.Dataset(store, "r") as ds:
            return np.asarray(ds["particle_timestep"][:], dtype=np.int64)
    from pipeline.coarse_graining.fields import load_tables

    return load_tables(Path(run_dir), run)[0].timesteps


# ------------------------------------------------------------------------------------- cost
@dataclass(frozen=True)
class RunCost:
    """What one DEM run cost (core-seconds: LIGGGHTS wall seconds x MPI ranks; particle-steps)."""

    case: str
    run: str
    replica: int
    fixed_core_seconds: float  # fill and shear to steady state: paid whatever the production
    production_core_seconds: float
    fixed_particle_steps: float
    production_particle_steps: float
    window_share: float  # of the production, the steady-state test's window it begins with
    shared: str | None = None  # the shared fill or sheared bed it started from (dem/<case>/<shared>/fill.json)


def replica_of(run: str) -> int:
    """The replica index k of a run id ending in ``r<k>``."""
    match = re.search(r"(?:^|-)r(\d+)$", run)
    if not match:
        raise ValueError(f"run {run!r}: no replica suffix r<k>")
    return int(match.group(1))


def run_cost(record: dict[str, Any]) -> RunCost:
    """A run's cost from its ``run.json`` (``wall_seconds_by_stage``, ``steps_by_stage``, ``mpi_ranks``)."""
    ranks = float(record.get("mpi_ranks", 1))
    seconds = record.get("wall_seconds_by_stage") or {}
    steps = record.get("steps_by_stage") or {}
    n = float(record["particle_count"])
    chunks = int(record.get("production_chunks", 0) or 0)
    window = int(record.get("production_chunks_from_steady_window", 0) or 0)
    shared = (record.get("shared_fill") or {}).get("run")
    return RunCost(str(record["case"]), str(record["run"]), replica_of(str(record["run"])),
                   ranks * sum(float(v) for k, v in seconds.items() if k != "production"),
                   ranks * float(seconds.get("production", 0.0)),
                   n * sum(float(v) for k, v in steps.items() if k != "production"),
                   n * float(steps.get("production", 0)),
                   window / chunks if chunks else 0.0, shared)


def shared_cost(fill: dict[str, Any]) -> tuple[float, float]:
    """(core-seconds, particle-steps) of a shared fill or sheared bed (its ``fill.json``)."""
    ranks = float(fill.get("mpi_ranks", 1))
    seconds = sum(float(v) for v in (fill.get("wall_seconds_by_stage") or {}).values())
    steps = sum(float(v) for v in (fill.get("steps_by_stage") or {}).values())
    return ranks * seconds, float(fill.get("particle_count", 0)) * steps


@dataclass(frozen=True)
class Cost:
    core_hours: float
    core_hours_with_window: float
    particle_steps: float


def variant_cost(costs: Iterable[RunCost], kept: dict[str, float], shared: dict[str, tuple[float, float]]) -> Cost:
    """The DEM of the runs in ``kept`` (run -> fraction of its production kept): fill and shear in
    full, the production scaled; each shared fill or bed the kept runs started from once (``shared``:
    name -> (core-seconds, particle-steps), from :func:`shared_cost`)."""
    seconds = seconds_window = steps = 0.0
    fills = set()
    for c in costs:
        if c.run not in kept:
            continue
        f = float(kept[c.run])
        seconds += c.fixed_core_seconds + f * c.production_core_seconds
        seconds_window += c.fixed_core_seconds + max(f, c.window_share) * c.production_core_seconds
        steps += c.fixed_particle_steps + f * c.production_particle_steps
        if c.shared:
            fills.add(c.shared)
    for name in fills:
        s, p = shared.get(name, (0.0, 0.0))
        seconds += s
        seconds_window += s
        steps += p
    return Cost(seconds / 3600.0, seconds_window / 3600.0, steps)


# ----------------------------------------------------------------------------------- variants
@dataclass(frozen=True)
class Variant:
    """Less DEM: the first ``fraction`` of every production, and the replicas ``replicas`` (None: all)."""

    fraction: float = 1.0
    replicas: tuple[int, ...] | None = None

    @property
    def name(self) -> str:
        parts = []
        if self.fraction < 1.0:
            parts.append(f"prefix {fraction_label(self.fraction)}")
        if self.replicas is not None:
            parts.append("replicas " + "+".join(f"r{k}" for k in self.replicas))
        return ", ".join(parts) or "full"

    @property
    def tag(self) -> str:
        return f"f{self.fraction:g}"

    def kept(self, replicas: list[int]) -> list[int] | None:
        """The case's replicas this variant keeps (None where it is no variant of the case: it keeps
        them all at the whole production, or none)."""
        keep = [k for k in replicas if self.replicas is None or k in self.replicas]
        if not keep:
            return None
        if self.replicas is not None and len(keep) == len(replicas) and self.fraction >= 1.0:
            return None
        return keep


def fraction_label(fraction: float) -> str:
    f = Fraction(fraction).limit_denominator(64)
    return f"{f.numerator}/{f.denominator}" if f.denominator > 1 else f"{f.numerator}"


def replica_subsets(n: int, min_replicas: int = 1) -> list[tuple[int, ...]]:
    """Replica subsets of a case of ``n``: each one left out in turn, then the first m for m from
    n - 2 down to ``min_replicas``."""
    if n < 2:
        return []
    every = list(range(1, n + 1))
    subsets = [tuple(k for k in every if k != out) for out in every] if n - 1 >= min_replicas else []
    subsets += [tuple(range(1, m + 1)) for m in range(n - 2, max(min_replicas, 1) - 1, -1)]
    return subsets


def variants(fractions: Iterable[float], max_replicas: int, min_replicas: int = 1, combine: bool = False) -> list[Variant]:
    """``full``, the prefixes, the replica subsets and with ``combine`` every prefix of every subset."""
    fractions = [float(f) for f in fractions if float(f) < 1.0]
    subsets = replica_subsets(max_replicas, min_replicas)
    out = [Variant()] + [Variant(f) for f in sorted(fractions)] + [Variant(1.0, s) for s in subsets]
    if combine:
        out += [Variant(f, s) for f in sorted(fractions) for s in subsets]
    return out


# --------------------------------------------------------------------------------- the rods
def rod_series(run_dir: Path) -> pd.DataFrame:
    """A rod's position series over every committed chunk (``series/intruder_<stage>.txt``), x unwrapped."""
    from pipeline.dem.intruder_run import read_intruder_series, unwrap

    # As IntruderRun.intruder_series reads it (chunks in their order, no sample dropped), so the
    # whole production gives run.json's speed again.
    state = json.loads((run_dir / "state.json").read_text())
    record = json.loads((run_dir / "run.json").read_text())
    paths = [run_dir / "series" / f"intruder_{c['stage']}.txt" for c in state["chunks"]]
    frames = [read_intruder_series(path) for path in paths if path.exists()]
    data = pd.concat(frames, ignore_index=True)
    data["x"] = unwrap(data["x"].to_numpy(), float(record["cell"][0]))
    return data


def prefix_rod(record: dict[str, Any], series: pd.DataFrame, fraction: float, rest_speed: float) -> tuple[dict[str, Any], str]:
    """The run's record with the rod's ``speed``, ``speed_err`` and ``arrested`` over the first
    ``fraction`` of its production window, and a note: where the prefix holds fewer than 3 samples
    per block of the usual :data:`~pipeline.dem.rod_speed.SPEED_BLOCKS`, fewer blocks (at least 2);
    with fewer than 6 samples the record unchanged and a note ending "left out" (the caller drops
    the run)."""
    from pipeline.dem.rod_speed import SPEED_BLOCKS, creep_speed

    t0, t1 = record["production_window"]
    t_end = t0 + fraction * (t1 - t0)
    part = series[(series["time"] >= t0) & (series["time"] <= t_end)]
    n = len(part)
    blocks = min(SPEED_BLOCKS, n // 3)
    out = json.loads(json.dumps(record))
    if blocks < 2:
        return out, f"{record['run']}: {n} rod samples in the prefix, too few: left out"
    t, x = part["time"].to_numpy(), part["x"].to_numpy()
    creep = creep_speed(t, x, blocks, rest_speed)
    rod = out["intruder"]
    if rod.get("speed_over_wall_speed") is not None and rod.get("speed"):
        rod["speed_over_wall_speed"] = float(rod["speed_over_wall_speed"]) * creep.speed / float(rod["speed"])
    rod.update({"speed": creep.speed, "speed_err": creep.speed_err, "arrested": bool(creep.arrested),
                "displacement": creep.displacement, "window": [t0, t_end], "speed_blocks": blocks})
    if "halves" in rod or "steadiness" in rod:
        # As IntruderRun._record: the prefix's halves, the rod's travel over it and whether it is
        # steady (issue 55: the depth sweep's score takes the steady rods only).
        from pipeline.dem.rod_speed import production_halves
        from pipeline.scoring.rod_steadiness import classify, split_durations

        halves = production_halves(t, x, rest_speed)
        if halves is not None:
            halves["first_duration"], halves["second_duration"] = split_durations(t)
        rod["halves"] = halves
        steadiness = classify(out)
        rod.update({k: steadiness[k] for k in ("travel_over_d", "travel_first_half_over_d", "travel_second_half_over_d",
                                               "travel_source") if k in steadiness})
        rod["steadiness"] = {k: steadiness.get(k) for k in ("steady", "rod_class", "reason", "halves_z_normal")}
    note = f"{record['run']}: {blocks} blocks of {n} samples" if blocks < SPEED_BLOCKS else ""
    return out, note
