"""Helpers the Snakefile calls to list targets: paths follow ../shared/contract.md."""
from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path
from typing import Any

from pipeline.config import dem_config, dem_runs, validate_config

#: Figures the report writes as PNG files (flagged with Snakemake's report()).
REPORT_FIGURES = ("profiles", "calibration", "pareto", "well_posedness", "mesh_convergence", "wall_series")


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


def effective_config_file(config: dict[str, Any], dem_only: bool = False) -> str:
    """Write the validated config (with any ``--config`` overrides) where the rules read it.

    The file is rewritten only when its content changes, so an unchanged config does not make
    Snakemake rerun anything. With ``dem_only`` it holds only what DEM runs depend on
    (``config.dem.json``), so that changing a model setting does not rerun the DEM. Returns its path.
    """
    path = root(config) / ("config.dem.json" if dem_only else "config.effective.json")
    text = json.dumps(dem_config(config) if dem_only else config, indent=1, sort_keys=True)
    if not path.exists() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return str(path)


def model_names(config: dict[str, Any]) -> list[str]:
    """Continuum models to solve (config ``models.names``, all five by default)."""
    names = (config.get("models") or {}).get("names")
    return list(names) if names else ["local_mu_i", "critical_state", "cosserat", "ngf", "volume_averaged"]


def scored_cases(config: dict[str, Any]) -> list[str]:
    """Cases the continuum models are solved on and scored against (all but the rheometer)."""
    return [case for case in config["cases"] if case != "rheometer"]


def model_paths(config: dict[str, Any]) -> list[str]:
    """``models/{case}/{model}.nc`` for every scored case and model."""
    return [str(root(config) / "models" / case / f"{model}.nc") for case in scored_cases(config) for model in model_names(config)]


def nonlocal_calibration_fields(config: dict[str, Any]) -> str:
    """Fields file of the run the non-local parameters are fitted on."""
    calib = config.get("calibration") or {}
    case = calib.get("nonlocal_case", "shear_gravity")
    run = calib.get("nonlocal_run", "r1")
    if (case, run) not in dem_runs(config):
        raise ValueError(f"calibration.nonlocal_case/nonlocal_run = {case}/{run} is not a DEM run of this config")
    return str(root(config) / "fields" / case / f"{run}.nc")


def case_fields(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """Input function body: the fields files of the case named by the wildcards."""
    return fields_paths(config, wildcards.case)


# Params functions of the Snakefile (Snakemake passes wildcards, input, output by name).
def output_folder(wildcards: Any, output: Any) -> str:
    """Folder of a rule's first output (a DEM run folder)."""
    return str(Path(output[0]).parent)


def run_folder_of_input(wildcards: Any, input: Any) -> str:  # noqa: A002 (Snakemake's name)
    """Folder of the rule's ``run`` input (run.json of a DEM run)."""
    return str(Path(input.run).parent)


def figure_folder(wildcards: Any, output: Any) -> str:
    """Folder the report's figures are written to."""
    return str(Path(output.figures[0]).parent)


def python_path_prefix() -> str:
    """Shell prefix putting the running interpreter's folder first on PATH (rules call ``python``)."""
    return f"export PATH={shlex.quote(str(Path(sys.executable).parent))}:$PATH; "
