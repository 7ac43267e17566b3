"""Where the workflow writes each result: the paths of the results layout (docs/outputs.md,
../shared/contract.md) and the case lists they are built from. The Snakefile's rules and the
stages that read results (the report) both name files through this module."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from pipeline.common.config import dem_fills, dem_runs, size_study_cell, validation_cases


#: Figures the report writes as PNG files (flagged with Snakemake's report()).
REPORT_FIGURES = ("decay_length", "profiles", "calibration", "wall_slip", "pareto", "well_posedness", "mesh_convergence",
                  "wall_series")
#: Category of each figure in Snakemake's report: the stage that made what it shows.
REPORT_CATEGORIES = {"decay_length": "Validation", "profiles": "Scoring", "pareto": "Scoring", "calibration": "Calibration",
                     "well_posedness": "Stability", "mesh_convergence": "Stability", "wall_series": "DEM",
                     "dem_convergence": "DEM", "intruder": "Intruder", "intruder_field": "Intruder", "intruder_force": "Intruder", "verdict": "Validation",
                     "creep_halves": "DEM", "wall_slip": "Calibration"}


def root(config: dict[str, Any]) -> Path:
    """The output root folder of a config."""
    return Path(config["output_root"])


def run_json_paths(config: dict[str, Any]) -> list[str]:
    """``dem/{case}/{run}/run.json`` of every DEM run."""
    return [str(root(config) / "dem" / case / run / "run.json") for case, run in dem_runs(config)]


def shared_fill_paths(config: dict[str, Any]) -> list[str]:
    """``dem/{case}/{fill}/fill.json`` of every fill several runs start from."""
    return [str(root(config) / "dem" / case / fill / "fill.json") for case, fill in dem_fills(config)]


def report_figures(config: dict[str, Any]) -> list[str]:
    """Names of the figures the report writes for this config."""
    sweep = any(config["cases"][c].get("force_sweep") for c in intruder_cases(config))
    return (list(REPORT_FIGURES) + (["intruder", "intruder_field"] if intruder_cases(config) else [])
            + (["intruder_force"] if sweep else [])
            + (["dem_convergence"] if convergence_cases(config) else [])
            + (["creep_halves"] if creeping_cases(config) else [])
            + (["verdict"] if validation_cases(config) else []))


def fields_paths(config: dict[str, Any], case: str | None = None, size_study: bool = False) -> list[str]:
    """``fields/{case}/{run}.nc`` of every DEM run (of one case if given); the runs of a
    ``size_study`` (other cell sizes, never scored) only when asked for."""
    return [
        str(root(config) / "fields" / c / f"{run}.nc") for c, run in dem_runs(config)
        if (case is None or c == case) and (size_study or size_study_cell(run) is None)
    ]


def compared_roots(config: dict[str, Any]) -> list[dict[str, str]]:
    """``scoring.compare_roots``: the other roots this root's claims are set against (label, root)."""
    return list((config.get("scoring") or {}).get("compare_roots") or [])


def claims_across_paths(config: dict[str, Any]) -> list[str]:
    """``validation/claims_across_roots.csv`` when other roots are compared, else nothing."""
    return [str(root(config) / "validation" / "claims_across_roots.csv")] if compared_roots(config) else []


def convergence_cases(config: dict[str, Any]) -> list[str]:
    """Scored cases with two or more replicas: their DEM noise has a convergence study."""
    return [case for case in scored_cases(config) if config["cases"][case]["replicas"] >= 2]


def convergence_paths(config: dict[str, Any]) -> list[str]:
    """``dem_convergence/{case}.csv`` of every case with a DEM convergence study."""
    return [str(root(config) / "dem_convergence" / f"{case}.csv") for case in convergence_cases(config)]


def model_names(config: dict[str, Any]) -> list[str]:
    """Continuum models to solve (config ``models.names``, all five by default)."""
    names = (config.get("models") or {}).get("names")
    return list(names) if names else ["local_mu_i", "critical_state", "cosserat", "ngf", "volume_averaged"]


def scored_cases(config: dict[str, Any]) -> list[str]:
    """Planar cases the 1D continuum models are solved on and scored against (not the rheometer)."""
    return [case for case, spec in config["cases"].items() if case != "rheometer" and spec["geometry"] == "planar_shear"]


def creeping_cases(config: dict[str, Any]) -> list[str]:
    """Scored planar cases with gravity: a creeping zone below the shear band, whose production's
    halves the error check compares (``validation/creep_halves.csv``)."""
    return [case for case in scored_cases(config) if float(config["cases"][case].get("gravity", 0.0)) > 0]


def model_paths(config: dict[str, Any]) -> list[str]:
    """``models/{case}/{model}.nc`` for every scored planar case and model."""
    return [str(root(config) / "models" / case / f"{model}.nc") for case in scored_cases(config) for model in model_names(config)]


def model_draw_paths(config: dict[str, Any]) -> list[str]:
    """``model_draws/{case}/{model}.nc`` (every parameter draw, and the refined grid) for every
    scored planar case and model."""
    return [str(root(config) / "model_draws" / case / f"{model}.nc") for case in scored_cases(config)
            for model in model_names(config)]


def intruder_cases(config: dict[str, Any]) -> list[str]:
    """Cases with an intruder (scored by the intruder's speed)."""
    return [case for case, spec in config["cases"].items() if spec["geometry"] == "intruder"]


#: Models that predict an intruder speed (continuum.intruder: each its own 2D solve).
INTRUDER_MODELS = ("ngf", "local_mu_i", "critical_state", "volume_averaged", "cosserat")
#: The intruder models with a Newton yield-stress solver (``continuum.intruder.yield2d``): their
#: u_input can be propagated through the speed's sensitivities (``models.intruder_plastic_u_input``).
PLASTIC_INTRUDER_MODELS = ("local_mu_i", "critical_state", "volume_averaged", "cosserat")


def intruder_model_paths(config: dict[str, Any]) -> list[str]:
    """``models/{case}/{model}.nc`` of the intruder cases."""
    return [str(root(config) / "models" / case / f"{model}.nc") for case in intruder_cases(config)
            for model in model_names(config) if model in INTRUDER_MODELS]


def intruder_model_fields_dirs(config: dict[str, Any]) -> list[str]:
    """``model_fields/{case}/{model}`` folders (each model's 2D fields per scene) of the intruder cases."""
    return [str(root(config) / "model_fields" / case / model) for case in intruder_cases(config)
            for model in model_names(config) if model in INTRUDER_MODELS]


def intruder_draw_jobs(config: dict[str, Any]) -> int:
    """Jobs the parameter draws of each intruder model are split into (``models.intruder_draw_jobs``;
    absent: one)."""
    return int((config.get("models") or {}).get("intruder_draw_jobs", 1))


def plastic_u_input(config: dict[str, Any]) -> str:
    """How the 2D plastic intruder models' u_input is made (``models.intruder_plastic_u_input``):
    ``draws`` (each draw solved; absent means this) or ``sensitivities``
    (``pipeline.models.intruder_sensitivities``)."""
    return str((config.get("models") or {}).get("intruder_plastic_u_input", "draws"))


def intruder_u_input(config: dict[str, Any], model: str) -> str:
    """``draws`` or ``sensitivities`` for one intruder model: ``models.intruder_plastic_u_input``
    for the plastic ones, ``models.intruder_ngf_u_input`` for NGF (absent: draws)."""
    if model in PLASTIC_INTRUDER_MODELS:
        return plastic_u_input(config)
    return str((config.get("models") or {}).get(f"intruder_{model}_u_input", "draws"))


def intruder_draw_part_paths(config: dict[str, Any], case: str, model: str) -> list[str]:
    """``model_draws/{case}/parts/{model}/draws-{k}-of-{n}.nc`` for every part (or its
    ``sensitivities.nc``, for a model whose u_input is propagated), then the grid study's
    ``refined.nc``: what ``model_draws/{case}/{model}.nc`` is merged from."""
    n = intruder_draw_jobs(config)
    folder = root(config) / "model_draws" / case / "parts" / model
    if intruder_u_input(config, model) == "sensitivities":
        return [str(folder / "sensitivities.nc"), str(folder / "refined.nc")]
    return [str(folder / f"draws-{k}-of-{n}.nc") for k in range(1, n + 1)] + [str(folder / "refined.nc")]


def intruder_model_draw_paths(config: dict[str, Any]) -> list[str]:
    """``model_draws/{case}/{model}.nc`` of the intruder cases."""
    return [str(root(config) / "model_draws" / case / f"{model}.nc") for case in intruder_cases(config)
            for model in model_names(config) if model in INTRUDER_MODELS]


def all_intruder_run_jsons(config: dict[str, Any]) -> list[str]:
    """run.json of every run of every intruder case."""
    return [str(root(config) / "dem" / c / r / "run.json") for c, r in dem_runs(config) if c in intruder_cases(config)]


def intruder_plane_paths(config: dict[str, Any]) -> list[str]:
    """``fields_xz/{case}/{run}.nc`` (x-z fields in the rod's frame) of every intruder run."""
    return [str(root(config) / "fields_xz" / c / f"{r}.nc") for c, r in dem_runs(config) if c in intruder_cases(config)]
