"""Helpers the Snakefile calls: input and params functions, the per-rule config files.

The result paths themselves are :mod:`pipeline.common.layout`."""
from __future__ import annotations

import json
import os
import shlex
import sys
from pathlib import Path
from typing import Any

from pipeline.common.config import (RHEOMETER, ConfigError, calibration_runs, dem_runs, nonlocal_runs, fill_owner_run, predecessor_state, run_config,
                                    shared_fill_of, validate_config)
from pipeline.common.layout import fields_paths, root
from pipeline.workflow.priorities import AFTER_DEM_PRIORITY, dem_priority, intruder_model_priority  # noqa: F401


def user_error(message: str) -> None:
    """End the workflow with one line and exit status 1: raised in the Snakefile or an input
    function, any exception (SystemExit too) reaches the user wrapped in Snakemake's stack frames."""
    # The process's own stderr: while the DAG is built Snakemake may have replaced sys.stderr.
    print(f"error: {message}", file=sys.__stderr__, flush=True)
    os._exit(1)


def checked(config: dict[str, Any], configfiles: Any = ()) -> dict[str, Any]:
    """The Snakemake config, validated (schema plus cross-key checks) and its output root usable. A
    user error ends the workflow here with the message alone (naming the config file and key)."""
    source = ", ".join(str(f) for f in configfiles) or "workflow config"
    try:
        validate_config(config, source)
    except ConfigError as exc:
        user_error(str(exc))
    check_output_root(config, source)
    return config


def check_output_root(config: dict[str, Any], source: str) -> None:
    """``output_root`` must be a folder that exists or can be made, and that can be written to."""
    out = root(config)
    if out.exists() and not out.is_dir():
        user_error(f"{source}: output_root = {out}: an existing file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        user_error(f"{source}: output_root = {out}: cannot be created ({exc.strerror or exc})")
    if not os.access(out, os.W_OK | os.X_OK):
        user_error(f"{source}: output_root = {out}: not writable")


def known_run(config: dict[str, Any], case: str, run: str) -> None:
    """A target's DEM run must be one of the config's: name it and the case's runs otherwise."""
    if (case, run) in dem_runs(config):
        return
    if case not in config["cases"]:
        user_error(f"target run {case}/{run}: the config has no case {case!r} (cases: {', '.join(config['cases'])})")
    runs = [r for c, r in dem_runs(config) if c == case]
    shown = ", ".join(runs[:12]) + (f" and {len(runs) - 12} more" if len(runs) > 12 else "")
    user_error(f"target run {case}/{run}: not a run of this config (runs of {case}: {shown})")


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
    """Launcher for the DEM rule's ``resources.mpi`` ('none': run the binary directly; a one-rank run
    starts the bare binary whatever is named, ``pipeline.dem.engines.liggghts.Launcher``)."""
    return config["dem"]["mpi_launcher"] or "none"


def mpi_ranks(config: dict[str, Any]) -> int:
    """MPI ranks of one DEM run (``resources.tasks``)."""
    return int(config["dem"]["mpi_ranks"])


def effective_config_file(config: dict[str, Any], dem_run: tuple[str, str] | None = None) -> str:
    """Write the validated config (with any ``--config`` overrides) where the rules read it.

    The file is rewritten only when its content changes, so an unchanged config does not make
    Snakemake rerun anything. With ``dem_run = (case, run)`` it holds only what that DEM run
    depends on (``config.dem.<case>.<run>.json``, :func:`pipeline.common.runs.run_config`), so
    changing a model setting, another case or another rheometer state does not rerun it.
    Returns its path.
    """
    if dem_run is not None:
        known_run(config, *dem_run)
    name = f"config.dem.{dem_run[0]}.{dem_run[1]}.json" if dem_run else "config.effective.json"
    path = root(config) / name
    text = json.dumps(run_config(config, *dem_run) if dem_run else config, indent=1, sort_keys=True)
    if not path.exists() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return str(path)


def shared_fill_config_file(config: dict[str, Any], case: str, fill: str) -> str:
    """The per-run config a shared fill reads: its replica's first state's (the fill depends on
    none of a state's own settings, :func:`pipeline.common.runs.fill_physics`)."""
    if case not in config["cases"]:
        user_error(f"target fill {case}/{fill}: the config has no case {case!r} (cases: {', '.join(config['cases'])})")
    try:
        owner = fill_owner_run(case, config["cases"][case], fill)
    except ValueError as exc:
        user_error(f"target fill {case}/{fill}: {exc}")
    return effective_config_file(config, dem_run=(case, owner))


def shared_fill_record(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """Input function body: ``fill.json`` of the shared fill a DEM run starts from, if any."""
    known_run(config, wildcards.case, wildcards.run)
    fill = shared_fill_of(wildcards.case, config["cases"][wildcards.case], wildcards.run)
    return [str(root(config) / "dem" / wildcards.case / fill / "fill.json")] if fill else []


def fill_from_option(wildcards: Any, input: Any) -> str:  # noqa: A002 (Snakemake's name)
    """``--fill-from <folder>`` for a run with a shared fill among its inputs, else nothing."""
    return f"--fill-from {shlex.quote(str(Path(input.fill[0]).parent))}" if input.fill else ""


def predecessor_record(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """Input function body: ``run.json`` of the slower state a rheometer state continues from, if any."""
    known_run(config, wildcards.case, wildcards.run)
    previous = predecessor_state(wildcards.case, config["cases"][wildcards.case], wildcards.run)
    return [str(root(config) / "dem" / wildcards.case / previous / "run.json")] if previous else []


def start_from_option(wildcards: Any, input: Any) -> str:  # noqa: A002 (Snakemake's name)
    """``--start-from <folder>`` for a run with a predecessor among its inputs, else nothing."""
    return f"--start-from {shlex.quote(str(Path(input.start[0]).parent))}" if input.start else ""


def nonlocal_calibration_fields(config: dict[str, Any]) -> list[str]:
    """Fields files of the runs the non-local parameters are fitted on (their replica mean)."""
    return [str(root(config) / "fields" / c / f"{r}.nc") for c, r in nonlocal_runs(config)]


def rheometer_calibration_fields(config: dict[str, Any]) -> list[str]:
    """Fields files of the rheometer runs (the local laws)."""
    return [str(root(config) / "fields" / c / f"{r}.nc") for c, r in calibration_runs(config) if c == RHEOMETER]


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


def output_root_of_scores(wildcards: Any, input: Any) -> str:  # noqa: A002 (Snakemake's name)
    """The output root a rule reads, from its ``scores`` input (``ROOT/scores.csv``)."""
    return str(Path(input.scores).parent)


def figure_folder(wildcards: Any, output: Any) -> str:
    """Folder the report's figures are written to."""
    return str(Path(output.figures[0]).parent)


def python_path_prefix() -> str:
    """Shell prefix putting the running interpreter's folder first on PATH (rules call ``python``)."""
    return f"export PATH={shlex.quote(str(Path(sys.executable).parent))}:$PATH; "


def intruder_run_jsons(wildcards: Any, config: dict[str, Any]) -> list[str]:
    """run.json of every run of the intruder case named by the wildcards."""
    return [str(root(config) / "dem" / c / r / "run.json") for c, r in dem_runs(config) if c == wildcards.case]


def dem_job_priority(config: dict[str, Any], case: str, job: str) -> int:
    """Snakemake ``priority`` of a DEM run or shared fill: its upward rank (:mod:`pipeline.workflow.priorities`).
    Every rule after the DEM has :data:`AFTER_DEM_PRIORITY` or more (the intruder models' jobs:
    :func:`pipeline.workflow.priorities.intruder_model_priority`)."""
    return dem_priority(config, case, job)
