"""Which files say that a background workflow's DEM and coarse-graining are done (the tests of the
DEM's own output start then, while its models compute; the SLURM rerun copies them then)."""
from __future__ import annotations

from pathlib import Path

from pipeline.common.config import dem_runs, load_config


def dem_outputs(root: Path, runs: set[tuple[str, str]] | None = None) -> list[Path] | None:
    """The benchmark files Snakemake writes when the jobs that make ``runs``' DEM folders, dump
    stores and fields in ``root`` have ended (every DEM run of the root's config if None): a shared
    fill's DEM job, a run's fields job, and an intruder run's rod-frame fields job. None while the
    root has no ``config.effective.json`` yet."""
    if not (root / "config.effective.json").is_file():
        return None
    config = load_config(root / "config.effective.json")
    geometry = {case: c["geometry"] for case, c in config["cases"].items()}
    paths = []
    for case, run in sorted(set(dem_runs(config)) if runs is None else runs):
        if run.startswith("fill-"):
            paths.append(root / "benchmarks" / "dem" / case / f"{run}.tsv")
            continue
        paths.append(root / "benchmarks" / "fields" / case / f"{run}.tsv")
        if geometry[case] == "intruder":
            paths.append(root / "benchmarks" / "fields_xz" / case / f"{run}.tsv")
    return paths
