"""The engine-agnostic life of a chunked DEM run: fill, shear until steady, produce, record.

Stages, each a separate engine call continued from the previous one's restart file:

1. ``fill``: pour and settle the grains under gravity; the pipeline then makes the lowest and the
   highest layer of grains into the rough walls (the geometry's :meth:`ChunkedRun._fill`).
2. ``shear_NNN``: chunks of ``chunk_strain`` wall displacement over depth each; after every chunk
   the wall shear force and wall height over the trailing ``steady_window_chunks`` chunks are
   tested for drift (:mod:`pipeline.dem.steady_state`). The first window that passes is the start of
   the steady state.
3. ``production_NNN``: chunks of the same length that also dump particles and contacts. With
   ``dem.precision.steady_window_is_production`` the steady window's chunks are the production's
   first ones (the shear chunks then dump too, and all but the trailing window's snapshots are
   deleted as the stage goes on).

Every chunk is committed (restart renamed from its temporary name, state.json rewritten) only
after its log, its dumps (brought to the store's format by the engine) and its wall series passed
the failure checks, so a killed run resumes from the last committed chunk and gives the same
numbers. ``run.json`` is written last, under a temporary name renamed at the end (by the caller):
its presence means the run finished.

What an engine does (templates, launch, logs, dump format) is behind :mod:`pipeline.dem.engines`;
what a geometry does (its fill, its walls, its chunk variables, its record) is in the subclass
(:class:`pipeline.dem.planar_run.PlanarShearRun`, :class:`pipeline.dem.intruder_run.IntruderRun`).
"""
from __future__ import annotations

import functools
import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pipeline.common.config import run_physics, shared_fill_of, fill_physics
from pipeline.dem import force_balance, precision
from pipeline.dem.engines import DEFAULT_ENGINE, Engine, engine_name
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.steady_state import band_speeds, creep_settled, drift_test
from pipeline.dem.wall_series import read_wall_series

#: Depth bands (edges in d below the top wall's grain centres) in which the steady-state test
#: compares the creep of consecutive windows (``dem.steady_creep_bands_over_d`` overrides).
STEADY_CREEP_BANDS = (3.0, 6.0, 9.0, 12.0, 15.0, 18.0)
#: A shared fill's record, in its folder (pipeline.dem.shared_fill).
FILL_RECORD = "fill.json"
#: What a run takes from a shared fill: the restart it shears from, the settled snapshot and the
#: include files and log that made it (kept so the run folder shows its whole history).
FILL_FILES = ("fill.restart", "settled.dump", "bottom_wall.in", "top_wall.in", "grains.in", "in.fill", "logs/fill.log")
#: The restart a run continued from another's final packing starts its shear stage from.
START_RESTART = "start.restart"
#: Made by the fill of some geometries only (the intruder's rod).
OPTIONAL_FILL_FILES = ("intruder.in",)


def settled_timestep(path: Path) -> int:
    """The time step of ``settled.dump``'s snapshot: the steps the fill took."""
    with path.open() as f:
        for line in f:
            if line.startswith("ITEM: TIMESTEP"):
                return int(next(f).split()[0])
    raise DEMRunError(f"{path}: no 'ITEM: TIMESTEP' line")


def read_settled(path: Path) -> pd.DataFrame:
    """The single snapshot of ``settled.dump`` (columns id type x y z radius mass)."""
    lines = path.read_text().splitlines()
    try:
        header_at = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    except StopIteration:
        raise DEMRunError(f"{path}: no 'ITEM: ATOMS' section") from None
    columns = lines[header_at].split()[2:]
    n_atoms = int(lines[lines.index("ITEM: NUMBER OF ATOMS") + 1])
    body = lines[header_at + 1 :]
    if len(body) != n_atoms:
        raise DEMRunError(f"{path}: expected {n_atoms} atom lines, found {len(body)} (truncated?)")
    data = np.array([line.split() for line in body], dtype=float)
    return pd.DataFrame(data, columns=columns)


class ChunkedRun:
    """A DEM run made of a fill and restart-chained chunks, whatever the engine and geometry.

    A subclass sets, in its ``__init__``: ``config``, ``case_name``, ``run_id``, ``case``, ``mat``,
    ``dem`` (the case's production settings), ``run_dir``, ``label``, ``design`` (the contact
    design), ``engine`` (:func:`pipeline.dem.engines.make_engine`), ``seed``, ``fill_from``,
    ``start_from``, ``state_path`` and ``state``; and it provides the geometry's hooks ``_fill``,
    ``_stage_variables``, ``_check_series``, ``reference_speed``, ``load_balance`` and ``_record``.
    """

    engine: Engine

    # ----------------------------------------------------------------------------------- state
    def _load_state(self) -> None:
        # Only what changes the physics: the output folder, MPI layout, other runs and non-DEM
        # sections may differ on resume.
        fingerprint = {"config": run_physics(self.config, self.case_name, self.run_id), "case": self.case_name,
                       "run": self.run_id}
        if self.start_from is not None:
            # Chunks continued from another run's packing belong to that run's history too.
            fingerprint["start_from"] = self._start_source["fingerprint"]
        if self.state_path.exists():
            state = json.loads(self.state_path.read_text())
            if state.get("fingerprint") == fingerprint:
                self.state = state
                return
            # Chunks made with another config cannot be continued: start this run afresh.
            for item in ("restart", "logs", "dumps", "series"):
                shutil.rmtree(self.run_dir / item, ignore_errors=True)
        self.state = {"fingerprint": fingerprint, "chunks": [], "steady": None, "wall_seconds": 0.0}

    def _save_state(self) -> None:
        tmp = self.state_path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(self.state, indent=1))
        tmp.replace(self.state_path)

    def _adopt_fill(self, source: Path) -> None:
        """Start from a shared fill: copy its settled packing, walls and restart into this run.

        The fill's record must carry the physics this run's config gives it (material, cell, grains,
        seed): a fill made for another config is refused, never silently used. The run's own fill
        stage then costs nothing; the fill's steps and seconds are counted once, in ``fill.json``.
        """
        record_path = source / FILL_RECORD
        if not record_path.is_file():
            raise DEMRunError(f"{self.label}: --fill-from {source}: no {FILL_RECORD} there (the shared fill has not run)")
        record = json.loads(record_path.read_text())
        # A fill's restart is its engine's own format: another engine cannot continue it. The
        # engine is in the fill's own record (PlanarShearRun._fill); older fills are LIGGGHTS's.
        poured_by = record.get("fill", {}).get("engine", DEFAULT_ENGINE)
        if poured_by != self.engine.name:
            raise DEMRunError(f"{self.label}: {record_path} was poured by {poured_by}, "
                              f"this run's dem.engine is {self.engine.name}: rerun the fill")
        own_fill = shared_fill_of(self.case_name, self.case, self.run_id)
        if own_fill != record.get("run") or record.get("physics") != fill_physics(self.config, self.case_name, own_fill):
            raise DEMRunError(f"{self.label}: {record_path} is fill {record.get('run')!r} made with other settings "
                              f"than this run's config gives its shared fill {own_fill!r} "
                              "(material, cell, grains or seed differ): rerun the fill")
        for name in FILL_FILES + tuple(n for n in OPTIONAL_FILL_FILES if (source / n).is_file()):
            target = self.run_dir / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source / name, target)
        if record.get("bodies"):
            self.state["intruder"] = record["bodies"]
        self.state["fill"] = record["fill"] | {
            "steps": 0, "wall_seconds": 0.0,
            "shared": {"run": record["run"], "steps": record["fill"]["steps"], "wall_seconds": record["fill"]["wall_seconds"]}}
        self._save_state()

    @functools.cached_property
    def _start_source(self) -> dict[str, Any]:
        """The finished run ``start_from`` names: its id, state fingerprint, seed and final restart
        (read once: the fingerprint and the start both need it)."""
        source = self.start_from
        state_path, record_path = source / "state.json", source / "run.json"
        if not record_path.is_file() or not state_path.is_file():
            raise DEMRunError(f"{self.label}: --start-from {source}: not a finished DEM run (no run.json and state.json there)")
        state = json.loads(state_path.read_text())
        return {"run": state["fingerprint"]["run"], "fingerprint": state["fingerprint"],
                "seed": json.loads(record_path.read_text()).get("seed"), "restart": source / state["chunks"][-1]["restart"],
                "chunks": len(state["chunks"])}

    def _adopt_start(self) -> None:
        """Copy the final restart of ``start_from`` into this run as the shear stage's start.

        Only a run of the same case grown from the same shared fill qualifies: the walls, grains
        and ids must be this run's own. Its velocities are replaced by this run's Couette ramp at
        the first chunk, as after a fill; the steady-state test then decides, as always, when the
        packing has become this run's.
        """
        source = self._start_source
        # The lineage is the shared fill's seed, whether a run copied that fill or poured it itself.
        own_fill = shared_fill_of(self.case_name, self.case, self.run_id)
        if source["fingerprint"]["case"] != self.case_name or own_fill is None or source["seed"] != self.seed:
            raise DEMRunError(f"{self.label}: --start-from {self.start_from}: run {source['fingerprint']['case']}/{source['run']} "
                              f"did not grow from this run's shared fill {own_fill!r} (its seed {source['seed']}, the fill's {self.seed})")
        source_engine = engine_name(source["fingerprint"].get("config", {}).get("dem", {}))
        if source_engine != self.engine.name:
            raise DEMRunError(f"{self.label}: --start-from {self.start_from}: a {source_engine} run; this run's "
                              f"dem.engine is {self.engine.name} (restart files are the engine's own)")
        shutil.copy2(source["restart"], self.run_dir / START_RESTART)
        self.state["start"] = {"run": source["run"], "restart": str(source["restart"].relative_to(self.start_from)),
                               "after_chunks": source["chunks"]}
        self._save_state()

    def _chunk_plan(self) -> dict[str, int]:
        v = self.reference_speed()
        samples = self.dem["series_samples_per_chunk"]
        duration = self.dem["chunk_strain"] * self.state["fill"]["settled_gap"] / v
        nevery = max(1, int(round(duration / self.design.dt / samples / 10)))
        series_every = 10 * nevery
        chunk_steps = series_every * samples
        def chunks(strain: float) -> int:
            return max(1, int(math.ceil(strain / self.dem["chunk_strain"])))

        n_prod = chunks(self.dem["production_strain"])
        # dem.snapshots per dem.production_strain, whatever this case's cap.
        per_chunk = max(1, int(math.ceil(self.dem["snapshots"] / chunks(self.dem["snapshot_strain"]))))
        dump_every = max(1, chunk_steps // per_chunk)
        while chunk_steps % dump_every:
            dump_every -= 1
        return {
            "chunk_steps": chunk_steps,
            "series_nevery": nevery,
            "series_nrepeat": 10,
            "series_every": series_every,
            "production_chunks": n_prod,
            "dump_every": dump_every,
        }

    def _run_chunk(self, kind: str, index: int, plan: dict[str, int]) -> dict[str, Any]:
        stage = f"{kind}_{index:03d}"
        chunks = self.state["chunks"]
        first = START_RESTART if "start" in self.state else "fill.restart"
        restart_in = first if not chunks else chunks[-1]["restart"]
        restart_out = f"restart/{stage}.restart"
        (self.run_dir / "restart").mkdir(exist_ok=True)
        (self.run_dir / "series").mkdir(exist_ok=True)
        production = kind == "production"
        # A shear chunk may end up in the steady window that becomes the production's start, so
        # it writes its snapshots too (under its own name; adopted ones are renamed).
        dumped = production or self._window_is_production()
        if dumped:
            (self.run_dir / "dumps").mkdir(exist_ok=True)
        prefix = "" if production else "s"
        variables = self._stage_variables(plan) | {
            "restart_in": restart_in,
            "restart_out": restart_out + ".tmp",
            "first_chunk": int(not chunks),
            "series_nevery": plan["series_nevery"],
            "series_nrepeat": plan["series_nrepeat"],
            "series_every": plan["series_every"],
            "series_file": f"series/{stage}.txt",
            "pairsum_file": f"series/pairsum_{stage}.txt",
            "pairforce_file": force_balance.pair_force_file(stage),
            "thermo_every": plan["chunk_steps"] // 4,
            "chunk_steps": plan["chunk_steps"],
            "dump_every": plan["dump_every"] if dumped else 0,
            "particle_dump": f"dumps/particles_{prefix}{index:03d}.dump",
            "contact_dump": f"dumps/contacts_{prefix}{index:03d}.dump",
        } | self._chunk_variables(stage)
        variables |= self.engine.chunk_variables(self.run_dir, variables)
        self.engine.render_stage(self.run_dir, stage, "shear.in", variables)
        seconds = self.engine.launch(self.run_dir, stage, self.label)
        if dumped:
            self.engine.finish_chunk(self.run_dir, variables)
        series = read_wall_series(self.run_dir / variables["series_file"])
        self._check_series(series, stage)
        (self.run_dir / (restart_out + ".tmp")).replace(self.run_dir / restart_out)
        record = {"stage": stage, "kind": kind, "restart": restart_out, "wall_seconds": seconds,
                  "steps": plan["chunk_steps"], "series": variables["series_file"],
                  "t_start": float(series["time"].iloc[0]), "t_end": float(series["time"].iloc[-1])}
        if dumped:
            record["dumps"] = [variables["particle_dump"], variables["contact_dump"]]
        chunks.append(record)
        self.state["wall_seconds"] += seconds
        self._save_state()
        return record

    def series(self, kinds: tuple[str, ...] = ("shear", "production")) -> pd.DataFrame:
        """The wall series of all committed chunks of the given kinds, in time order."""
        frames = [read_wall_series(self.run_dir / c["series"]) for c in self.state["chunks"] if c["kind"] in kinds]
        return pd.concat(frames, ignore_index=True)

    def _steady_test(self, window_chunks: list[dict[str, Any]]) -> dict[str, Any]:
        frames = [read_wall_series(self.run_dir / c["series"]) for c in window_chunks]
        data = pd.concat(frames, ignore_index=True)
        depth = self.state["fill"]["settled_gap"]
        force = drift_test(data["time"], data["ftop_x"], self.dem["steady_force_tol"], float(data["ftop_x"].mean()))
        height = drift_test(data["time"], data["h_top"], self.dem["steady_height_tol"], depth)
        test = {"force": force.as_dict(), "height": height.as_dict(), "load": self.load_balance(data),
                "stationary": force.stationary and height.stationary,
                "t_start": window_chunks[0]["t_start"], "t_end": window_chunks[-1]["t_end"]}
        if self._tests_creep():
            creep = self._creep_test(window_chunks)
            test |= {"creep": creep, "stationary": bool(test["stationary"] and creep["stationary"])}
        return test

    def min_shear_strain(self) -> float:
        """Strain of shear before the steady window may start: the case's ``min_shear_strain``,
        else ``dem.min_shear_strain`` (0 when neither is set; :func:`case_production` merges them)."""
        return float(self.dem.get("min_shear_strain", 0.0))

    def _tests_creep(self) -> bool:
        """Whether the steady-state test also holds the creep (``dem.steady_creep_tol``): planar
        shear with gravity whose shear chunks keep their snapshots (the window becomes production)."""
        return (self.case["geometry"] == "planar_shear" and self.case["gravity"] > 0
                and self.dem.get("steady_creep_tol") is not None and self._window_is_production())

    def _creep_test(self, window_chunks: list[dict[str, Any]]) -> dict[str, Any]:
        """The window's creep against the window of as many shear chunks before it, band by band
        (:func:`pipeline.dem.steady_state.creep_settled`); not stationary until there is one."""
        shear = [c for c in self.state["chunks"] if c["kind"] == "shear"]
        first = next(k for k, c in enumerate(shear) if c["stage"] == window_chunks[0]["stage"])
        n = len(window_chunks)
        if first < n:
            return {"stationary": False, "reason": "no earlier window yet", "tested": 0}
        earlier = shear[first - n:first]
        d = self.mat["d"]
        means = precision.chunk_means([self.run_dir / c["dumps"][0] for c in [*earlier, *window_chunks]], d,
                                      self.design.dt, self.reference_speed(), precision.BULK_MARGIN_OVER_D * d)
        bands, edges = band_speeds(means.u_disp_over_v, means.depth, d, tuple(self.dem.get("steady_creep_bands_over_d", STEADY_CREEP_BANDS)))
        return creep_settled(bands[:n], bands[n:], edges, float(self.dem["steady_creep_tol"]))

    def _steady_summary(self, test: dict[str, Any]) -> str:
        """One clause for the log: each drift as a fraction of what the test allows."""
        out = (f"force drift {abs(test['force']['drift']) / test['force']['allowed']:.2f}, height drift "
               f"{abs(test['height']['drift']) / test['height']['allowed']:.2f} of allowed; top-wall push / load "
               f"{test['load']['ratio']:.3f}")
        creep = test.get("creep")
        if creep is None:
            return out
        if "bands" not in creep:
            return out + f"; creep: {creep['reason']}"
        parts = [f"{r['depth_over_d'][0]:g}-{r['depth_over_d'][1]:g} d {r['log10_change']:+.2f} "
                 f"({abs(r['log10_change']) / r['allowed']:.2f} of allowed)" for r in creep["bands"] if "settled" in r]
        return out + "; creep change in decades against the window before: " + (", ".join(parts) or "no band resolved")

    # ------------------------------------------------------------------------------------ run
    def run(self) -> dict[str, Any]:
        """Run (or resume) all stages; return the run.json record."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.engine.copy_templates(self.case["geometry"], self.run_dir)
        self._load_state()
        if "fill" not in self.state:
            if self.fill_from is not None:
                self._adopt_fill(self.fill_from)
            else:
                self._fill()
            print(f"{self.label}: fill and settle done, {self.state['fill']['settled_gap'] / self.mat['d']:.1f} d "
                  f"between the walls, {self.state['wall_seconds']:.1f} s", flush=True)
        # Committed before any chunk, so a resumed run never shears from the fill instead.
        if self.start_from is not None and "start" not in self.state:
            if self.state["chunks"]:
                raise DEMRunError(f"{self.label}: chunks committed without the start from {self.start_from} (state.json)")
            self._adopt_start()
        plan = self._chunk_plan()
        window = self.dem["steady_window_chunks"]
        # The window may start only after dem.min_shear_strain of shear (or the case's own): a state
        # sheared from its fill dilates over its first strain unit (nu 0.0006 +- 0.0003 above the
        # rest of the production on the rigid-limit benchmark's reference states), which the wall's
        # force and height tests do not see; the deep creep of a bed with gravity relaxes for 2-3
        # strain units, which the creep test's band errors do not resolve (docs/dem.md).
        settle = int(math.ceil(self.min_shear_strain() / self.dem["chunk_strain"] - 1e-9))
        while self.state["steady"] is None:
            shear = [c for c in self.state["chunks"] if c["kind"] == "shear"]
            if len(shear) >= window + settle:
                test = self._steady_test(shear[-window:])
                self.state["last_steady_test"] = test
                print(f"{self.label}: steady-state test over shear chunks {len(shear) - window + 1}-{len(shear)}: "
                      f"{self._steady_summary(test)}: {'steady' if test['stationary'] else 'not yet steady'}", flush=True)
                if test["stationary"]:
                    self.state["steady"] = test
                    if self._window_is_production():
                        self._adopt_window(shear[-window:])
                    self._save_state()
                    break
            if len(shear) >= self.dem["max_shear_chunks"]:
                test = self.state.get("last_steady_test", {})
                raise DEMRunError(
                    f"{self.label}: no steady state after {len(shear)} shear chunks (dem.max_shear_chunks); "
                    f"last drift test: force {test.get('force')}, height {test.get('height')}"
                )
            if self._window_is_production():
                # The creep test compares the window with the one before it: keep both.
                kept = 2 * window - 1 if self._tests_creep() else window - 1
                self._drop_stale_dumps(shear[max(0, len(shear) - kept):])
            self._progress(self._run_chunk("shear", len(shear), plan), plan)
        while True:
            produced = [c for c in self.state["chunks"] if c["kind"] == "production"]
            stop = self._production_stop(produced, plan)
            if stop is not None:
                self.state["production_stop"] = stop
                self._save_state()
                break
            self._progress(self._run_chunk("production", len(produced), plan), plan)
        return self._record(plan)

    #: False for runs that never look for a steady window to keep (the yield probe's staircase).
    KEEPS_STEADY_WINDOW = True

    def _window_is_production(self) -> bool:
        """Whether the steady-state test's window becomes the production's first chunks
        (``dem.precision.steady_window_is_production``).

        The window passed the test, so its chunks are as steady as any that follow; producing
        after it, as the fixed design does, throws away ``steady_window_chunks`` chunks of steady
        flow per run (1 strain in the default, half of a run's 2-strain cap).
        """
        precision_cfg = self.dem.get("precision") or {}
        return self.KEEPS_STEADY_WINDOW and bool(precision_cfg.get("steady_window_is_production", False))

    def _drop_stale_dumps(self, keep: list[dict[str, Any]]) -> None:
        """Delete the snapshots of shear chunks that can no longer fall in a steady window (all but
        ``keep``, the trailing chunks the next window will hold), so the shear stage keeps at most a
        window of them on disk."""
        kept = {c["stage"] for c in keep}
        stale = [c for c in self.state["chunks"] if c["kind"] == "shear" and "dumps" in c and c["stage"] not in kept]
        for chunk in stale:
            for name in chunk.pop("dumps"):
                (self.run_dir / name).unlink(missing_ok=True)
        if stale:
            self._save_state()

    def _adopt_window(self, window_chunks: list[dict[str, Any]]) -> None:
        """Make the steady window's chunks the first production chunks: kind ``production``, their
        snapshots renamed to the production's numbering (``dumps/particles_000.dump`` on). Safe to
        repeat after an interruption: a snapshot already renamed is found under its new name."""
        self._drop_stale_dumps(window_chunks)
        for index, chunk in enumerate(window_chunks):
            renamed = []
            for name in chunk["dumps"]:
                target = f"dumps/{Path(name).name.split('_')[0]}_{index:03d}.dump"
                source, dest = self.run_dir / name, self.run_dir / target
                if source.is_file():
                    source.replace(dest)
                elif not dest.is_file():
                    raise DEMRunError(f"{self.label}: snapshot {name} of steady chunk {chunk['stage']} is missing")
                renamed.append(target)
            chunk.update(kind="production", dumps=renamed, from_steady_window=True)

    def _min_production_chunks(self, plan: dict[str, int]) -> int:
        precision_cfg = self.dem.get("precision")
        if precision_cfg is None:
            return plan["production_chunks"]
        wanted = int(math.ceil(precision_cfg["min_production_strain"] / self.dem["chunk_strain"] - 1e-9))
        return min(plan["production_chunks"], max(precision.MIN_BLOCKS, wanted))

    def _production_stop(self, produced: list[dict[str, Any]], plan: dict[str, int]) -> dict[str, Any] | None:
        """Why production stops after the committed chunks ``produced``, or None to go on.

        Without ``dem.precision`` production has the fixed length ``production_strain``; with it,
        it goes on from ``min_production_strain`` until every target of the run's geometry is met
        (:mod:`pipeline.dem.precision`) or ``production_strain`` (the cap) is reached.
        """
        strain = len(produced) * self.dem["chunk_strain"]
        precision_cfg = self.dem.get("precision")
        if precision_cfg is None:
            if len(produced) < plan["production_chunks"]:
                return None
            return {"design": "fixed length", "reason": "fixed production length reached", "strain": strain,
                    "chunks": len(produced)}
        if len(produced) < self._min_production_chunks(plan):
            return None
        measured = self.production_precision(produced, precision_cfg)
        # JSON has no infinity: an unresolved error is recorded as null.
        for key in ("reached", "bound"):
            measured[key] = {k: (v if math.isfinite(v) else None) for k, v in measured[key].items()}
        self.state.setdefault("precision_history", {})[str(len(produced))] = measured
        stop = {"design": "precision target", "targets": self.precision_targets(precision_cfg), "strain": strain,
                "chunks": len(produced), "cap_strain": plan["production_chunks"] * self.dem["chunk_strain"]} | measured
        if measured["all_met"]:
            return stop | {"reason": "every precision target met"}
        if len(produced) >= plan["production_chunks"]:
            unmet = sorted(name for name, ok in measured["met"].items() if not ok)
            return stop | {"reason": f"strain cap production_strain reached with {', '.join(unmet) or 'no target'} unmet"}
        print(f"{self.label}: precision after {len(produced)} production chunks: "
              + ", ".join(f"{k} {'unresolved' if v is None else format(v, '.3g')} (bound "
                          f"{'unresolved' if measured['bound'][k] is None else format(measured['bound'][k], '.3g')}, "
                          f"target {stop['targets'][k]:g})" for k, v in measured["reached"].items())
              + ": going on", flush=True)
        return None

    def precision_targets(self, precision_cfg: dict[str, Any]) -> dict[str, float]:
        """The targets that apply to this run: the planar fields, the wall friction, and with
        gravity the creep."""
        names = ("u_x_over_v", "nu", "mu") + (("log_speed", "log_speed_depth_over_d") if self.case["gravity"] > 0 else ())
        return {k: float(precision_cfg[k]) for k in names if k in precision_cfg}

    def production_precision(self, produced: list[dict[str, Any]], precision_cfg: dict[str, Any]) -> dict[str, Any]:
        """Errors reached by the committed production chunks (:func:`pipeline.dem.precision.measure`)."""
        d = self.mat["d"]
        means = precision.chunk_means([self.run_dir / c["dumps"][0] for c in produced], d, self.design.dt,
                                      self.reference_speed(), precision.BULK_MARGIN_OVER_D * d)
        ratios = []
        for c in produced:
            wall = read_wall_series(self.run_dir / c["series"])
            ratios.append(abs(float(wall["ftop_x"].mean())) / float(wall["ftop_z"].mean()))
        return precision.measure(means, d, np.array(ratios), self.precision_targets(precision_cfg), self.case["gravity"] > 0)

    def _progress(self, chunk: dict[str, Any], plan: dict[str, int]) -> None:
        """One line per chunk on stdout (the rule's log): where the run stands and what is left.

        The shear stage ends when the steady-state test passes, so its length is not known in
        advance: the estimate counts the chunks still needed at the least (the test's window and
        the production) and says so.
        """
        chunks = self.state["chunks"]
        shear = [c for c in chunks if c["kind"] == "shear"]
        produced = [c for c in chunks if c["kind"] == "production"]
        window = self.dem["steady_window_chunks"]
        strain = self.dem["chunk_strain"]
        rate = chunk["steps"] * self.case["n_grains"] / max(chunk["wall_seconds"], 1e-9)
        if chunk["kind"] == "shear":
            margin = f"steady-state test from chunk {window} on"
            # An adopted steady window is the production's first chunks: that many fewer to come.
            adopted = window if self._window_is_production() else 0
            left = max(window - len(shear), 0) + max(plan["production_chunks"] - adopted, 0)
            where = f"shear {len(shear)} (strain {len(shear) * strain:g}, at most {self.dem['max_shear_chunks'] * strain:g})"
            bound = "at least "
        else:
            margin = "steady"
            left = plan["production_chunks"] - len(produced)
            where = (f"production {len(produced)}/{plan['production_chunks']} (strain {len(produced) * strain:g} "
                     f"of {plan['production_chunks'] * strain:g})")
            bound = ""
        mean_seconds = sum(c["wall_seconds"] for c in chunks) / max(len(chunks), 1)
        print(f"{self.label}: {where}; {margin}; {chunk['wall_seconds']:.1f} s, {rate / 1e6:.2f} M particle-steps/s; "
              f"left: {bound}{left} chunks, ~{left * mean_seconds:.0f} s", flush=True)

    def steps_by_stage(self) -> dict[str, int]:
        """Time steps spent in each stage: fill (pour and settle), shear to the steady state, production."""
        return {"fill": int(self.state["fill"].get("steps", 0))} | {kind: int(sum(c["steps"] for c in self.state["chunks"] if c["kind"] == kind)) for kind in ("shear", "production")}

    def seconds_by_stage(self) -> dict[str, float]:
        """Wall-clock seconds of LIGGGHTS in each stage (fill, shear, production)."""
        out = {"fill": float(self.state["fill"]["wall_seconds"])}
        for kind in ("shear", "production"):
            out[kind] = float(sum(c["wall_seconds"] for c in self.state["chunks"] if c["kind"] == kind))
        return out

