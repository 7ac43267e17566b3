"""The verdict against the DEM it had: each claim of ``model_differences.csv`` with less DEM (issue 57, item 2).

Which of the report's claims would stand with a shorter production or fewer replicas, and what that
DEM costs. For each *variant* of a finished output root the held-out cases are scored again and
judged again (:func:`pipeline.scoring.scores.score_case`, :func:`pipeline.scoring.verdict.judge`,
:func:`pipeline.scoring.intruder_scores.score_intruder`, :func:`pipeline.scoring.force_sweep.score_force_sweep`,
the workflow's own functions, with the root's config, seed and confidence):

- ``prefix 1/8``, ``1/4``, ``1/2``: every run of the case re-coarse-grained from the first fraction
  of its production's snapshots (:func:`prefix_count`: never fewer than 2), from the dumps the run
  already wrote (no new DEM). A scratch run folder ``ROOT/claims_cost/dem/<tag>/<case>/<run>/`` holds
  the run's ``run.json`` with its steady-state and production windows cut at the last kept snapshot
  (links to its ``dumps.nc`` and ``series/``), so :func:`pipeline.coarse_graining.fields.run_fields`
  picks those snapshots by its own rule and the wall's series over the same prefix. The variant is
  coarse-grained on the root's fields' z grid (the models' nodes) and written to
  ``ROOT/claims_cost/fields/<tag>/<case>/<run>.nc``; the root's own fields are never touched. The
  intruder's rods: each rod's speed, its error and ``arrested`` recomputed from its position series
  over the same prefix of its production window (:func:`pipeline.dem.rod_speed.creep_speed`, with
  fewer blocks where the prefix holds fewer than 3 samples per block);
- ``replicas r1+r2`` ...: the root's fields of a subset of the case's replicas (each one left out in
  turn, then the first m, down to ``--min-replicas``). A subset without the first replica is placed
  on the first one's z by its top contact plane, as the scoring aligns every replica;
- ``full``: the root's own fields and rods through today's scoring code: the control (it confirms
  every claim unless the scoring code changed since the root was scored).

**Models fixed at the full calibration**: the models' nominal solutions (``models/``) and parameter
draws (``model_draws/``) stay those of the full root; only the DEM references change. (The
calibration's own DEM, the rheometer and ``calibration.nonlocal_case``, is not cut, and not counted.)

Claims and their comparison: :mod:`pipeline.scoring.claims` (**confirmed**, **lost**,
**contradicted**, **new**, ``still_cannot_tell_apart``). The variants, their prefixes and their DEM
cost: :mod:`pipeline.scoring.dem_variants`.

Outputs: ``--out`` (one row per case and variant, :data:`COLUMNS`), ``--pairs-out`` (default
``<out>_pairs.csv``: every compared pair with both claims and its status) and ``--figure`` (claims
held against DEM core-hours, per case: :func:`claims_figure`).

Usage: ``python -m pipeline.scoring claims-cost --root ROOT --out ROOT/validation/claims_cost.csv
--figure ROOT/figures/claims_cost.png [--fractions 0.125 0.25 0.5] [--min-replicas 1] [--combine]``
"""
from __future__ import annotations

import argparse
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import pandas as pd
import xarray as xr

from pipeline.common import atomic, layout
from pipeline.common.cli import positive_int
from pipeline.common.config import dem_runs, size_study_cell
from pipeline.scoring import verdict
from pipeline.scoring.claims import Key, claims, compare_claims, count_claims
from pipeline.scoring.dem_variants import (FRACTIONS, Prefix, RunCost, Variant, prefix_of, prefix_record, prefix_rod,
                                           replica_of, rod_series, run_cost, shared_cost, store_timesteps, variant_cost,
                                           variants)
from pipeline.scoring.metrics import MetricError
from pipeline.scoring.replicas import top_plane

#: What the variants keep fixed, in every row's notes.
MODELS_FIXED = "models fixed at the full calibration"
COLUMNS = ["case", "variant", "fraction", "replicas", "dem_core_hours", "confirmed", "lost", "contradicted", "new",
           "claims_full", "still_cannot_tell_apart", "unscored", "pairs", "dem_core_hours_full",
           "dem_core_hours_with_window", "particle_steps", "runs", "notes"]
PAIR_COLUMNS = ["case", "variant", "metric", "model_a", "model_b", "claim_full", "claim_variant", "status"]
#: The fields attributes that are heights in the DEM frame (moved with a replica put on another's z).
Z_ATTRS = ("z_bottom_wall", "z_top_wall", "z_bottom_contact_plane", "z_top_contact_plane")
#: Attributes a variant's fields file carries, so that a later call can reuse it.
FRACTION_ATTR = "claims_cost_fraction"


# ------------------------------------------------------------------------------ the root read
@dataclass
class Root:
    """What the variants read of a finished output root."""

    path: Path
    config: dict[str, Any]
    params: dict[str, Any]
    held_out: list[str]
    full: dict[Key, str]
    records: dict[tuple[str, str], dict[str, Any]] = field(default_factory=dict)

    @classmethod
    def read(cls, path: Path) -> Root:
        path = Path(path)
        config_path = path / "config.effective.json"
        differences_path = path / "validation" / "model_differences.csv"
        for need in (config_path, differences_path, path / "calibration" / "params.json"):
            if not need.is_file():
                raise FileNotFoundError(f"{need}: not there (is {path} a finished output root?)")
        config = json.loads(config_path.read_text())
        params = json.loads((path / "calibration" / "params.json").read_text())
        differences = pd.read_csv(differences_path)
        verdict_path = path / "validation" / "verdict.csv"
        verdicts = pd.read_csv(verdict_path) if verdict_path.is_file() else None
        full = claims(differences, verdicts)
        held = sorted({k[0] for k in full} | (set(verdicts.case) if verdicts is not None else set()))
        root = cls(path, config, params, held, full)
        for case, run in dem_runs(config):
            record = path / "dem" / case / run / "run.json"
            if case in held and size_study_cell(run) is None and record.is_file():
                root.records[(case, run)] = json.loads(record.read_text())
        return root

    def moved(self, p: str | Path) -> Path:
        """A layout path (under the config's output_root) under this root."""
        return self.path / Path(p).relative_to(layout.root(self.config))

    def runs(self, case: str) -> list[str]:
        return [run for (c, run) in self.records if c == case]

    def is_intruder(self, case: str) -> bool:
        return self.config["cases"][case]["geometry"] == "intruder"

    def replicas(self, case: str) -> list[int]:
        return sorted({replica_of(r) for r in self.runs(case)})

    def settings(self):
        from pipeline.scoring.scores import ScoringSettings

        return ScoringSettings.from_config(self.config)

    def costs(self, case: str) -> tuple[list[RunCost], dict[str, tuple[float, float]]]:
        costs = [run_cost(self.records[(case, r)]) for r in self.runs(case)]
        shared = {}
        for c in costs:
            fill = self.path / "dem" / case / str(c.shared) / "fill.json"
            if c.shared and fill.is_file():
                shared[c.shared] = shared_cost(json.loads(fill.read_text()))
            elif c.shared:  # the run's own record of the fill (no bed's shear in it)
                record = self.records[(case, c.run)]["shared_fill"]
                ranks = float(self.records[(case, c.run)].get("mpi_ranks", 1))
                shared[c.shared] = (ranks * float(record.get("wall_seconds", 0.0)),
                                    float(self.records[(case, c.run)]["particle_count"]) * float(record.get("steps", 0)))
        return costs, shared


# --------------------------------------------------------------------------- variant fields
def _link(source: Path, dest: Path) -> None:
    if dest.is_symlink() or dest.exists():
        if dest.is_symlink() and os.readlink(dest) == str(source):
            return
        dest.unlink()
    dest.symlink_to(source)


def prefix_fields(root: Root, case: str, run: str, fraction: float, fresh: bool = False) -> tuple[Path, Prefix]:
    """The fields of one run's production prefix (module docstring), on the root fields' z; reused
    when a previous call wrote them from the same dumps."""
    from pipeline.coarse_graining import fields as cg
    from pipeline.coarse_graining.coarse_grain import write_netcdf

    source = root.path / "dem" / case / run
    record = root.records[(case, run)]
    prefix = prefix_of(store_timesteps(source, record), record, fraction)
    tag = Variant(fraction).tag
    out = root.path / "claims_cost" / "fields" / tag / case / f"{run}.nc"
    newest = max(p.stat().st_mtime for p in (source / "run.json", source / "dumps.nc") if p.exists())
    if out.is_file() and not fresh and out.stat().st_mtime >= newest:
        with xr.open_dataset(out) as done:
            if math.isclose(float(done.attrs.get(FRACTION_ATTR, math.nan)), fraction) and \
                    int(done.attrs.get("number_of_snapshots", -1)) == prefix.kept:
                return out, prefix
    scratch = root.path / "claims_cost" / "dem" / tag / case / run
    scratch.mkdir(parents=True, exist_ok=True)
    atomic.write_json(prefix_record(record, prefix, fraction), scratch / "run.json")
    for name in ("dumps.nc", "series", "dumps"):
        if (source / name).exists():
            _link((source / name).resolve(), scratch / name)
    with xr.open_dataset(root.path / "fields" / case / f"{run}.nc") as ref:
        z = np.array(ref.z.values, dtype=float)
    # run_fields makes its profile grid from the kept snapshots' wall heights; the models are on
    # the root fields' nodes, so the variant is evaluated there (the grid is where, not what, it averages).
    result, _ = cg.run_fields(root.config, scratch, checks=False, z=z)
    ds = result.dataset
    if int(ds.attrs.get("number_of_snapshots", prefix.kept)) != prefix.kept:
        raise ValueError(f"{case}/{run}: {ds.attrs.get('number_of_snapshots')} snapshots averaged, {prefix.kept} meant")
    ds.attrs.update({FRACTION_ATTR: fraction, "claims_cost_snapshots_production": prefix.total,
                     "claims_cost_note": f"first {prefix.kept} of the production's {prefix.total} snapshots "
                                         f"(pipeline.scoring.claims_cost); the root's fields are the whole production"})
    write_netcdf(ds, out)
    return out, prefix


def reframe(ds: xr.Dataset, ref: xr.Dataset) -> xr.Dataset:
    """``ds`` on ``ref``'s z, placed by its depth below its own top contact plane (as
    :func:`pipeline.scoring.replicas.align_replicas`), its heights (:data:`Z_ATTRS`) moved with it."""
    shift = top_plane(ref) - top_plane(ds)
    moved = ds.assign_coords(z=ds.z.values + shift).interp(z=ref.z.values).assign_attrs(ds.attrs)
    for name in Z_ATTRS:
        if name in ds.attrs:
            moved.attrs[name] = float(ds.attrs[name]) + shift
    return moved


def first_on_model_grid(files: list[Path], reference: Path, scratch: Path) -> list[Path]:
    """``files`` with the first one on ``reference``'s z (the models' nodes): as it is where its z is
    that already, else re-framed (:func:`reframe`) into ``scratch``."""
    with xr.open_dataset(files[0]) as first, xr.open_dataset(reference) as ref:
        if first.sizes["z"] == ref.sizes["z"] and np.allclose(first.z.values, ref.z.values):
            return files
        moved = reframe(first.load(), ref.load())
    from pipeline.coarse_graining.coarse_grain import write_netcdf

    out = scratch / f"{files[0].stem}.on_{reference.stem}.nc"
    write_netcdf(moved, out)
    return [out] + files[1:]


# ---------------------------------------------------------------------------------- scoring
def judge_case(frames: list[pd.DataFrame], samples: dict, confidence: float) -> dict[Key, str]:
    """The claims of scored rows (every row held out) and their resamples."""
    frames = [f for f in frames if not f.empty]
    if not frames:
        return {}
    scores = pd.concat(frames, ignore_index=True)
    scores["role"] = "held_out"
    outcome = verdict.judge(scores, samples, confidence)
    return claims(outcome.differences, outcome.verdicts)


def score_planar(root: Root, case: str, field_files: list[Path]) -> dict[Key, str]:
    from pipeline.scoring.scores import score_case

    models = {Path(p).stem: root.moved(p) for p in layout.model_paths(root.config) if Path(p).parent.name == case}
    models = {m: p for m, p in models.items() if p.is_file()}
    draws = {Path(p).stem: root.moved(p) for p in layout.model_draw_paths(root.config) if Path(p).parent.name == case}
    draws = {m: p for m, p in draws.items() if p.is_file() and m in models}
    settings = root.settings()
    frame, samples = score_case(case, field_files, models, root.params, draws, settings)
    return judge_case([frame], samples, settings.confidence)


def score_rods(root: Root, case: str, records: list[dict[str, Any]]) -> dict[Key, str]:
    from pipeline.scoring.force_sweep import score_force_sweep
    from pipeline.scoring.intruder_scores import score_intruder
    from pipeline.scoring.scores import COLUMNS as SCORE_COLUMNS

    files = {Path(p).stem: root.moved(p) for p in layout.intruder_model_paths(root.config) if Path(p).parent.name == case}
    files = {m: p for m, p in files.items() if p.is_file()}
    ens = {Path(p).stem: root.moved(p) for p in layout.intruder_model_draw_paths(root.config) if Path(p).parent.name == case}
    ens = {m: p for m, p in ens.items() if p.is_file() and m in files}
    settings = root.settings()
    rows, samples = score_intruder(records, files, ens, settings)
    frames = [pd.DataFrame(rows, columns=SCORE_COLUMNS)]
    sweep_rows, extra, _ = score_force_sweep(records, files, ens, settings)
    if sweep_rows:
        frames.append(pd.DataFrame(sweep_rows, columns=SCORE_COLUMNS))
        samples |= extra
    # score_intruder names its case "intruder"; a differently named intruder case is its own.
    out = judge_case(frames, samples, settings.confidence)
    return {(case, *k[1:]): v for k, v in out.items()}


@dataclass
class Outcome:
    row: dict[str, Any]
    pairs: list[dict[str, Any]]


#: Metrics the variants do not rescore: the intruder's fields (the x-z fields would be coarse-grained
#: again over the prefix); their claims are left out of every row's counts, and the notes say so.
NOT_RESCORED = ("intruder_field_",)


def rescored(claims_of: dict[Key, str], case: str) -> dict[Key, str]:
    """The claims of one case on the metrics the variants rescore."""
    return {k: v for k, v in claims_of.items() if k[0] == case and not k[1].startswith(NOT_RESCORED)}


def run_variant(root: Root, case: str, variant: Variant, fresh: bool = False) -> Outcome | None:
    """Score and judge one case under one variant; None where it is no variant of the case."""
    keep = variant.kept(root.replicas(case))
    if keep is None:
        return None
    runs = [r for r in root.runs(case) if replica_of(r) in keep]
    notes = [MODELS_FIXED]
    kept_fraction: dict[str, float] = {}
    started = time.perf_counter()
    try:
        if root.is_intruder(case):
            from pipeline.dem.intruder_run import rest_speed_of

            records = []
            for run in runs:
                record = root.records[(case, run)]
                if variant.fraction < 1.0:
                    record, note = prefix_rod(record, rod_series(root.path / "dem" / case / run), variant.fraction,
                                              rest_speed_of(root.config, case))
                    if note.endswith("left out"):
                        notes.append(note)
                        continue
                    if note:
                        notes.append(note)
                kept_fraction[run] = variant.fraction
                records.append(record)
            if variant.fraction < 1.0:
                notes.append("rods' speeds over the prefix of their production window; depths as the whole production's")
            found = score_rods(root, case, records)
        else:
            files = []
            for run in runs:
                if variant.fraction < 1.0:
                    path, prefix = prefix_fields(root, case, run, variant.fraction, fresh)
                    kept_fraction[run] = prefix.kept_fraction
                else:
                    path = root.path / "fields" / case / f"{run}.nc"
                    kept_fraction[run] = 1.0
                files.append(path)
            scratch = root.path / "claims_cost" / "fields" / variant.tag / case
            scratch.mkdir(parents=True, exist_ok=True)
            # The models are on the nodes of the first of the root's fields files (sorted, as the scoring reads them).
            reference = sorted(root.path / "fields" / case / f"{r}.nc" for r in root.runs(case))[0]
            found = score_planar(root, case, first_on_model_grid(files, reference, scratch))
    except (MetricError, ValueError) as exc:
        notes.append(f"not scored: {exc}")
        found = {}
    if len(keep) == 1 < len(root.replicas(case)):
        notes.append("one replica: u_dem from its stated errors alone (no replica scatter, no offset term, the points "
                     "taken as uncorrelated), so narrower intervals than the full root's")
    full = rescored(root.full, case)
    if len(full) < sum(1 for k in root.full if k[0] == case):
        notes.append("the intruder's field scores are not rescored: their claims are left out")
    counts = count_claims(full, found, case)
    costs, shared = root.costs(case)
    # Every kept run paid its prefix, scored or not (a rod left out of a short prefix still ran).
    cost = variant_cost(costs, {r: kept_fraction.get(r, variant.fraction) for r in runs}, shared)
    full_cost = variant_cost(costs, {r: 1.0 for r in root.runs(case)}, shared)
    fractions = sorted(set(round(v, 4) for v in kept_fraction.values()))
    if variant.fraction < 1.0 and fractions and not root.is_intruder(case):
        notes.append("production kept: " + ", ".join(f"{v:g}" for v in fractions) + " of the snapshots")
    notes.append(f"{time.perf_counter() - started:.1f} s")
    row = {"case": case, "variant": variant.name, "fraction": variant.fraction, "replicas": len(keep),
           "dem_core_hours": cost.core_hours, **counts, "dem_core_hours_full": full_cost.core_hours,
           "dem_core_hours_with_window": cost.core_hours_with_window, "particle_steps": cost.particle_steps,
           "runs": " ".join(runs), "notes": "; ".join(notes)}
    pairs = [{"case": case, "variant": variant.name, "metric": k[1], "model_a": k[2], "model_b": k[3],
              "claim_full": full.get(k, "not scored"), "claim_variant": v or "not scored", "status": status}
             for k, (status, v, _) in compare_claims(full, {k: v for k, v in found.items() if k[0] == case}).items()]
    return Outcome(row, pairs)


def claims_cost(root_path: Path, fractions: Iterable[float] = FRACTIONS, min_replicas: int = 1, combine: bool = False,
                cases: list[str] | None = None, fresh: bool = False, log=print) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every (case, variant) row and every compared pair of a root (module docstring)."""
    root = Root.read(root_path)
    rows, pairs = [], []
    for case in root.held_out:
        if cases and case not in cases:
            continue
        if not root.runs(case):
            log(f"{case}: no finished DEM runs under {root.path / 'dem' / case}: left out")
            continue
        n = len(root.replicas(case))
        for v in variants(fractions, n, min_replicas, combine):
            outcome = run_variant(root, case, v, fresh)
            if outcome is None:
                continue
            log(f"{case:<22} {v.name:<28} confirmed {outcome.row['confirmed']:>3} lost {outcome.row['lost']:>3} "
                f"contradicted {outcome.row['contradicted']:>2} new {outcome.row['new']:>2} of {outcome.row['claims_full']:>3}"
                f"  {outcome.row['dem_core_hours']:.4g} core-h")
            rows.append(outcome.row)
            pairs += outcome.pairs
    return pd.DataFrame(rows, columns=COLUMNS), pd.DataFrame(pairs, columns=PAIR_COLUMNS)


# ----------------------------------------------------------------------------------- figure
def claims_figure(table: pd.DataFrame):
    """Per case: the claims each variant confirms (filled), contradicts (red crosses) and adds (open)
    against its DEM core-hours; the full root's claims dashed. Circles: prefixes of the production;
    squares: fewer replicas; diamonds: both; star: the full root."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = sorted(table.case.unique())
    fig, axes = plt.subplots(1, max(1, len(cases)), figsize=(4.6 * max(1, len(cases)), 3.9), squeeze=False)
    for ax, case in zip(axes[0], cases):
        sub = table[table.case == case]
        full = int(sub.claims_full.max()) if len(sub) else 0
        ax.axhline(full, color="k", ls="--", lw=0.8, label=f"told apart by the full root ({full})")
        for r in sub.itertuples(index=False):
            prefix, fewer = r.fraction < 1.0, r.replicas < sub.replicas.max() or "replicas" in r.variant
            marker = "*" if r.variant == "full" else ("D" if prefix and fewer else ("o" if prefix else "s"))
            ax.plot(r.dem_core_hours, r.confirmed, marker=marker, color="C0", ms=9 if marker == "*" else 6, ls="none")
            if r.contradicted:
                ax.plot(r.dem_core_hours, r.contradicted, marker="x", color="C3", ls="none")
            if r.new:
                ax.plot(r.dem_core_hours, r.new, marker=marker, mfc="none", color="C2", ls="none")
            ax.annotate(r.variant.replace("prefix ", "").replace("replicas ", ""), (r.dem_core_hours, r.confirmed),
                        fontsize=6, textcoords="offset points", xytext=(3, 3))
        ax.plot([], [], "o", color="C0", label="confirmed: prefix of the production")
        ax.plot([], [], "s", color="C0", label="confirmed: fewer replicas")
        ax.plot([], [], "x", color="C3", label="contradicted")
        ax.plot([], [], "o", mfc="none", color="C2", label="new")
        # From zero: the distance to the full root's point is the DEM a variant saves.
        ax.set_xlim(0.0, 1.08 * float(sub.dem_core_hours.max()) if len(sub) else 1.0)
        ax.set_ylim(bottom=-0.5, top=max(full, int(sub.confirmed.max()) if len(sub) else 0) * 1.12 + 1)
        ax.set_title(case, fontsize=9)
        ax.set_xlabel("DEM of the case (core-hours)")
        ax.legend(fontsize=6, loc="best")
    axes[0][0].set_ylabel("pairs of models told apart at 95 % (claims)")
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="The claims of model_differences.csv with less DEM, against its cost.")
    parser.add_argument("--root", type=Path, required=True, help="a finished output root (validation/model_differences.csv)")
    parser.add_argument("--out", type=Path, required=True, help="the table, e.g. ROOT/validation/claims_cost.csv")
    parser.add_argument("--figure", type=Path, help="the chart, e.g. ROOT/figures/claims_cost.png")
    parser.add_argument("--pairs-out", type=Path, help="every compared pair (default: <out>_pairs.csv beside --out)")
    parser.add_argument("--fractions", type=float, nargs="+", default=list(FRACTIONS),
                        help="fractions of every production kept (default 1/8 1/4 1/2)")
    parser.add_argument("--min-replicas", type=positive_int, default=1, help="fewest replicas a subset keeps (default 1)")
    parser.add_argument("--combine", action="store_true", help="also every prefix of every replica subset")
    parser.add_argument("--cases", nargs="+", help="only these held-out cases")
    parser.add_argument("--fresh", action="store_true", help="coarse-grain the prefixes again even where done")
    args = parser.parse_args(argv)
    for f in args.fractions:
        if not 0.0 < f <= 1.0:
            parser.error(f"--fractions {f}: expected 0 < fraction <= 1")
    table, pairs = claims_cost(args.root, args.fractions, args.min_replicas, args.combine, args.cases, args.fresh)
    atomic.write_csv(table, args.out)
    atomic.write_csv(pairs, args.pairs_out or args.out.with_name(f"{args.out.stem}_pairs.csv"))
    if args.figure is not None:
        import matplotlib.pyplot as plt

        fig = claims_figure(table)
        args.figure.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.figure, dpi=110, bbox_inches="tight")
        plt.close(fig)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.drop(columns=["runs", "notes"]).to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
