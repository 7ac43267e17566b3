"""Helpers the Snakefile calls to list targets: paths follow ../shared/contract.md."""
from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path
from typing import Any

from pipeline.config import dem_config, dem_runs, size_study_cell, validate_config

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


def report_figures(config: dict[str, Any]) -> list[str]:
    """Names of the figures the report writes for this config."""
    return (list(REPORT_FIGURES) + (["intruder", "intruder_field"] if intruder_cases(config) else [])
            + (["dem_convergence"] if convergence_cases(config) else []))


def fields_paths(config: dict[str, Any], case: str | None = None, size_study: bool = False) -> list[str]:
    """``fields/{case}/{run}.nc`` of every DEM run (of one case if given); the runs of a
    ``size_study`` (other cell sizes, never scored) only when asked for."""
    return [
        str(root(config) / "fields" / c / f"{run}.nc") for c, run in dem_runs(config)
        if (case is None or c == case) and (size_study or size_study_cell(run) is None)
    ]


def convergence_cases(config: dict[str, Any]) -> list[str]:
    """Scored cases with two or more replicas: their DEM noise has a convergence study."""
    return [case for case in scored_cases(config) if config["cases"][case]["replicas"] >= 2]


def convergence_paths(config: dict[str, Any]) -> list[str]:
    """``dem_convergence/{case}.csv`` of every case with a DEM convergence study."""
    return [str(root(config) / "dem_convergence" / f"{case}.csv") for case in convergence_cases(config)]


def _convergence_runs(config: dict[str, Any], case: str) -> list[str]:
    """Run ids of a case's replicas and size-study runs, in DEM-run order."""
    return [run for c, run in dem_runs(config) if c == case]


def convergence_run_jsons(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """run.json of the case's replicas and size-study runs, in :func:`convergence_fields` order."""
    return [str(root(config) / "dem" / wildcards.case / run / "run.json") for run in _convergence_runs(config, wildcards.case)]


def convergence_fields(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """Fields of the case's replicas and size-study runs."""
    return [str(root(config) / "fields" / wildcards.case / f"{run}.nc") for run in _convergence_runs(config, wildcards.case)]


def convergence_stores(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """Dump stores of the case's replicas (the averaging-time sweep re-averages their snapshots)."""
    return [str(root(config) / "dem" / wildcards.case / Path(f).stem / "dumps.nc") for f in fields_paths(config, wildcards.case)]


def mpi_launcher(config: dict[str, Any]) -> str:
    """Launcher for the DEM rule's ``resources.mpi`` ('none': run the binary directly)."""
    return config["dem"]["mpi_launcher"] or "none"


def mpi_ranks(config: dict[str, Any]) -> int:
    """MPI ranks of one DEM run (``resources.tasks``)."""
    return int(config["dem"]["mpi_ranks"])


def effective_config_file(config: dict[str, Any], dem_case: str | None = None) -> str:
    """Write the validated config (with any ``--config`` overrides) where the rules read it.

    The file is rewritten only when its content changes, so an unchanged config does not make
    Snakemake rerun anything. With ``dem_case`` it holds only what that case's DEM runs depend on
    (``config.dem.<case>.json``), so changing a model setting or another case does not rerun
    them. Returns its path.
    """
    name = f"config.dem.{dem_case}.json" if dem_case else "config.effective.json"
    path = root(config) / name
    text = json.dumps(dem_config(config, dem_case) if dem_case else config, indent=1, sort_keys=True)
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
    """Planar cases the 1D continuum models are solved on and scored against (not the rheometer)."""
    return [case for case, spec in config["cases"].items() if case != "rheometer" and spec["geometry"] == "planar_shear"]


def model_paths(config: dict[str, Any]) -> list[str]:
    """``models/{case}/{model}.nc`` for every scored planar case and model."""
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


def intruder_cases(config: dict[str, Any]) -> list[str]:
    """Cases with an intruder (scored by the intruder's speed)."""
    return [case for case, spec in config["cases"].items() if spec["geometry"] == "intruder"]


#: Models that predict an intruder speed (continuum.intruder); Cosserat is not solved in 2D.
INTRUDER_MODELS = ("ngf", "local_mu_i", "critical_state", "volume_averaged")


def intruder_model_paths(config: dict[str, Any]) -> list[str]:
    """``models/{case}/{model}.nc`` of the intruder cases."""
    return [str(root(config) / "models" / case / f"{model}.nc") for case in intruder_cases(config)
            for model in model_names(config) if model in INTRUDER_MODELS]


def intruder_run_jsons(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """run.json of every run of the intruder case named by the wildcards."""
    return [str(root(config) / "dem" / c / r / "run.json") for c, r in dem_runs(config) if c == wildcards.case]


def all_intruder_run_jsons(config: dict[str, Any]) -> list[str]:
    """run.json of every run of every intruder case."""
    return [str(root(config) / "dem" / c / r / "run.json") for c, r in dem_runs(config) if c in intruder_cases(config)]


def intruder_plane_paths(config: dict[str, Any]) -> list[str]:
    """``fields_xz/{case}/{run}.nc`` (x-z fields in the rod's frame) of every intruder run."""
    return [str(root(config) / "fields_xz" / c / f"{r}.nc") for c, r in dem_runs(config) if c in intruder_cases(config)]
