"""Benchmark: does the verdict depend on the age of the planar beds' creep?

The deep creep of the planar beds with gravity still slows over the production (issue 29): its
first half is faster than its second at 5-11 d below the top wall. This benchmark asks whether
that ageing moves what the workflow concludes. It derives, from a finished output root, a root
whose planar gravity fields carry the creep of one half of each run's production only
(``u_x_disp`` := ``u_x_disp_first_half`` or ``u_x_disp_second_half``, the coarse-graining's own
half-window estimates, their errors no smaller than the creep's structural error), and reruns
everything downstream of the fields (calibration, models, scores, report) on it with Snakemake.
The DEM, the dumps and the intruder fields are hard links to the source root's, so nothing
upstream reruns.

``benchmarks/verdict_stability.py FIRST SECOND`` then reads the two derived roots against each
other: the same DEM, the creep of two ages (strain since shear start 1.6 x apart in the default).

Run as::

    python benchmarks/creep_age.py prepare ROOT CONFIG --half first --out DERIVED
    bash scripts/snakemake.sh --cores 2 --configfile DERIVED/config.creep_age.yaml -n > /dev/null
    python benchmarks/creep_age.py settle ROOT DERIVED
    bash scripts/snakemake.sh --cores 2 --configfile DERIVED/config.creep_age.yaml \
        --forcerun calibrate decay_length error_check scores
    python benchmarks/creep_age.py ageing ROOT

The dry run writes the derived root's per-run configs (they name its output root); ``settle``
gives them their source's times, so Snakemake reruns nothing upstream of the fields, and
``--forcerun`` reruns every rule that reads the planar fields and what follows from them.

``ageing`` prints, per case and depth band, the log-log slope of the creep speed against the strain
since the shear started (``d log10 u / d log10 t``, 0 for steady creep), from the quarters of
each run's production, with its error from the runs' scatter.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.common import atomic  # noqa: E402
from pipeline.common.observables import creep_half  # noqa: E402
from pipeline.dem import precision  # noqa: E402
from pipeline.dem.steady_state import band_speeds  # noqa: E402
from pipeline.dem.wall_series import read_wall_series  # noqa: E402

#: Depth bands (edges in d below the top wall's grain centres) of the ageing slopes.
AGEING_BANDS = (3.0, 5.0, 7.0, 9.0, 11.0, 13.0)
#: The deep creep pooled in one line (d below the top wall's grain centres): below the band that
#: the shear band's tail keeps steady, above the walls' margin in the thinnest (heavy) bed.
DEEP_OVER_D = (5.0, 11.0)


def link_tree(source: Path, dest: Path) -> None:
    """``dest`` as a copy of ``source`` whose DEM runs (``dem/``, 3 GB in the default) are hard
    links: no DEM rule reruns on the derived root, while the rules that do may write their
    outputs and logs in place, which must not reach the source root through a shared file."""
    if dest.exists():
        raise SystemExit(f"creep_age: {dest}: exists; give a new output root")
    shutil.copytree(source, dest, symlinks=True, ignore=lambda folder, names: ["dem"] if Path(folder) == source else [])
    shutil.copytree(source / "dem", dest / "dem", copy_function=os.link, symlinks=True)


def prepare(root: Path, config_path: Path, half: str, out: Path) -> None:
    """Link ``root`` to ``out``, replace its planar gravity fields by their ``half``-window creep,
    and write ``out/config.creep_age.yaml`` (``config_path`` with ``output_root: out``)."""
    link_tree(root, out)
    changed = 0
    # "whole" changes no fields: the same DEM, everything downstream rerun with today's code.
    for path in sorted((out / "fields").glob("*/*.nc")) if half != "whole" else []:
        with xr.open_dataset(path) as source:
            ds = source.load()
        # The intruder's far-field profiles are not the planar beds' (their rods are scored on speed).
        if (float(ds.attrs.get("gravity", 0.0)) <= 0 or ds.attrs.get("case") == "intruder"
                or f"u_x_disp_{half}_half" not in ds):
            continue
        derived = creep_half(ds, half)
        path.unlink()  # a hard link: the source root's file must stay as it is
        atomic.write_netcdf(derived, path)
        changed += 1
    if changed == 0 and half != "whole":
        raise SystemExit(f"creep_age: no planar gravity fields with half-window creep under {out / 'fields'}")
    config = yaml.safe_load(config_path.read_text())
    config["output_root"] = str(out)
    (out / "config.creep_age.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    carries = "keep their whole window's creep" if half == "whole" else f"now carry the {half} half's creep"
    print(f"creep_age: {changed or 'all'} planar fields files {carries}; run "
          f"`bash scripts/snakemake.sh --cores 2 --configfile {out / 'config.creep_age.yaml'}`")


def settle(root: Path, out: Path) -> None:
    """Give ``out``'s config files (rewritten by Snakemake's parse: they name the output root) the
    modification times of ``root``'s, so that no rule reruns because of them."""
    count = 0
    for path in sorted(out.glob("config.*.json")):
        source = root / path.name
        if source.is_file() and not path.samefile(source):
            stat = source.stat()
            os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
            count += 1
    print(f"creep_age: {count} config files of {out} given {root}'s times")


@dataclass
class RunAgeing:
    """One planar gravity run's production in ``segments`` consecutive parts: each part's strain
    since the shear started (middle), mean creep speed over V in each band of :data:`AGEING_BANDS`,
    mean solid fraction in the same bands, and the top wall's mean height (in d)."""

    case: str
    run: str
    strain: np.ndarray
    speed: np.ndarray      # (segments, bands)
    nu: np.ndarray         # (segments, bands)
    height_over_d: np.ndarray
    edges: list[tuple[float, float]]


def run_ageing(run_dir: Path, segments: int) -> RunAgeing:
    """The production of ``run_dir`` cut into ``segments`` parts (:class:`RunAgeing`)."""
    record = json.loads((run_dir / "run.json").read_text())
    state = json.loads((run_dir / "state.json").read_text())
    produced = [c for c in state["chunks"] if c["kind"] == "production"]
    d = float(record["d"])
    means = precision.chunk_means([run_dir / c["dumps"][0] for c in produced], d, float(record["time_step"]),
                                  float(record["wall_speed"]), 3.0 * d)
    speed, edges = band_speeds(means.u_disp_over_v, means.depth, d, AGEING_BANDS)
    nu, _ = band_speeds(means.nu, means.depth, d, AGEING_BANDS)
    height = np.array([float(read_wall_series(run_dir / c["series"])["h_top"].mean()) / d for c in produced])
    chunk = float(record["production_strain"]) / len(produced)
    # Strain since shear start of each production chunk's middle: the shear chunks that did not
    # become production come first.
    strain = chunk * (record["shear_chunks"] + np.arange(len(produced)) + 0.5)

    def split(x: np.ndarray) -> np.ndarray:
        return np.array([np.nanmean(part, axis=0) for part in np.array_split(x, segments)])

    return RunAgeing(record["case"], record["run"], split(strain), split(speed), split(nu), split(height), edges)


def creep_slope(run: RunAgeing, band: int) -> float:
    """``d log10 u / d log10 t`` of one band over the run's segments (NaN where a segment's mean
    speed is not positive, or the band is the shear band's, faster than 0.1 V)."""
    u = run.speed[:, band]
    if not (np.all(np.isfinite(u)) and np.all(u > 0)) or u.max() > 0.1:
        return math.nan
    return float(np.polyfit(np.log10(run.strain), np.log10(u), 1)[0])


def mean_and_error(values: list[float]) -> str:
    v = np.asarray([x for x in values if math.isfinite(x)])
    if v.size == 0:
        return "   n/a"
    err = v.std(ddof=1) / math.sqrt(v.size) if v.size > 1 else math.nan
    return f"{v.mean():+.2f} +- {err:.2f} ({v.size})"


def ageing(root: Path, segments: int) -> None:
    """Print, per planar gravity run and pooled per case and band: the log-log slope of the creep
    speed against strain since the shear started (0 for steady creep), the change of the bands'
    solid fraction and of the bed's height (compaction) from the first segment to the last."""
    runs = [run_ageing(r, segments) for r in sorted((root / "dem").glob("shear_gravity*/r*"))
            if json.loads((r / "run.json").read_text()).get("gravity", 0.0) > 0]
    if not runs:
        raise SystemExit(f"creep_age: no planar gravity runs under {root / 'dem'}")
    edges = runs[0].edges
    names = [f"{a:g}-{b:g}" for a, b in edges]
    print(f"segments of each production: {segments}; bands in d below the top wall's grain centres")
    for run in runs:
        print(f"{run.case}/{run.run}: strain " + " ".join(f"{t:.1f}" for t in run.strain)
              + "; height/d " + " ".join(f"{h:.3f}" for h in run.height_over_d))
        for k, name in enumerate(names):
            print(f"    {name:6s} log10 u/V " + " ".join(f"{math.log10(u):+.2f}" if u > 0 else "  n/a" for u in run.speed[:, k])
                  + "   nu " + " ".join(f"{x:.4f}" for x in run.nu[:, k]))
    print(f"\n{'case':22s} {'band (d)':9s} d log10 u / d log10 t   nu last - first (1e-3)")
    for case in sorted({r.case for r in runs}) + ["all cases"]:
        members = [r for r in runs if case in (r.case, "all cases")]
        for k, name in enumerate(names):
            slopes = [creep_slope(r, k) for r in members]
            dnu = [1e3 * (r.nu[-1, k] - r.nu[0, k]) for r in members]
            print(f"{case:22s} {name:9s} {mean_and_error(slopes):22s} {mean_and_error(dnu)}")
        deep = [creep_slope(r, k) for r in members for k, (a, _) in enumerate(edges) if DEEP_OVER_D[0] <= a < DEEP_OVER_D[1]]
        dh = [r.height_over_d[-1] - r.height_over_d[0] for r in members]
        print(f"{case:22s} {DEEP_OVER_D[0]:g}-{DEEP_OVER_D[1]:g} d  {mean_and_error(deep):22s} (run-bands); "
              f"bed height last - first {mean_and_error(dh)} d")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("prepare", help="derive a root whose planar creep is one half of the production")
    p.add_argument("root", type=Path)
    p.add_argument("config", type=Path)
    p.add_argument("--half", choices=("first", "second", "whole"), required=True,
                   help="the production half whose creep the planar fields carry (whole: the fields as they are)")
    p.add_argument("--out", type=Path, required=True)
    t = sub.add_parser("settle", help="give the derived root's rewritten config files the source's times")
    t.add_argument("root", type=Path)
    t.add_argument("out", type=Path)
    a = sub.add_parser("ageing", help="the creep's log-log slope against strain since shear start")
    a.add_argument("root", type=Path)
    a.add_argument("--segments", type=int, default=4, help="parts of each production (default 4)")
    args = parser.parse_args(argv)
    for folder in ("dem", "fields") if args.command != "settle" else ("dem",):
        if not (args.root / folder).is_dir():
            parser.error(f"{args.root}: no {folder}/ folder (is it a finished output root?)")
    if args.command == "prepare" and not args.config.is_file():
        parser.error(f"{args.config}: config file not found")
    if args.command == "prepare":
        prepare(args.root, args.config, args.half, args.out)
    elif args.command == "settle":
        settle(args.root, args.out)
    else:
        ageing(args.root, args.segments)


if __name__ == "__main__":
    main()
