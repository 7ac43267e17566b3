"""Helpers the Snakefile calls to list targets: paths follow ../shared/contract.md."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pipeline.config import dem_runs, validate_config


def checked(config: dict[str, Any], source: str = "workflow config") -> dict[str, Any]:
    """The Snakemake config, validated (schema plus cross-key checks)."""
    return validate_config(config, source)


def root(config: dict[str, Any]) -> Path:
    """The output root folder of a config."""
    return Path(config["output_root"])


def run_json_paths(config: dict[str, Any]) -> list[str]:
    """``dem/{case}/{run}/run.json`` of every DEM run."""
    return [str(root(config) / "dem" / case / run / "run.json") for case, run in dem_runs(config)]


def fields_paths(config: dict[str, Any], case: str | None = None) -> list[str]:
    """``fields/{case}/{run}.nc`` of every DEM run (of one case if given)."""
    return [
        str(root(config) / "fields" / c / f"{run}.nc") for c, run in dem_runs(config) if case is None or c == case
    ]


def mpi_launcher(config: dict[str, Any]) -> str:
    """Launcher for the DEM rule's ``resources.mpi`` ('none': run the binary directly)."""
    return config["dem"]["mpi_launcher"] or "none"


def mpi_ranks(config: dict[str, Any]) -> int:
    """MPI ranks of one DEM run (``resources.tasks``)."""
    return int(config["dem"]["mpi_ranks"])


def effective_config_file(config: dict[str, Any]) -> str:
    """Write the validated config (with any ``--config`` overrides) where the rules read it.

    The file is rewritten only when its content changes, so an unchanged config does not make
    Snakemake rerun anything. Returns its path.
    """
    path = root(config) / "config.effective.json"
    text = json.dumps(config, indent=1, sort_keys=True)
    if not path.exists() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return str(path)
