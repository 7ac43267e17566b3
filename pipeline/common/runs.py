"""The DEM runs a config asks for: their names (rheometer states, rods, replicas, size-study cells),
the shared fills and sheared beds they start from, the states that continue from slower ones, the
calibration set, the seeds derived from the master seed, and each run's own slice of the config.

Pure functions of a validated config (``pipeline.common.config`` validates it, and re-exports these
for the stages that read both from there).
"""
from __future__ import annotations

import hashlib
import math
import re
from typing import Any


def case_production(dem: dict[str, Any], case: dict[str, Any]) -> dict[str, Any]:
    """The ``dem`` settings one case's runs produce with: its own ``precision`` targets (in place of
    ``dem.precision``'s, with ``dem.precision.min_production_strain``) and ``production_strain``
    cap and ``min_shear_strain`` where the case names them. ``snapshot_strain`` keeps the strain ``dem.snapshots`` are
    spread over (``dem.production_strain``), so a longer cap does not thin the dumps."""
    out = dict(dem) | {"snapshot_strain": dem["production_strain"]}
    if "precision" in case:
        kept = {k: dem["precision"][k] for k in ("min_production_strain", "steady_window_is_production") if k in dem["precision"]}
        out["precision"] = kept | dict(case["precision"])
    if "production_strain" in case:
        out["production_strain"] = case["production_strain"]
    if "min_shear_strain" in case:
        out["min_shear_strain"] = case["min_shear_strain"]
    return out


def rheometer_states(case: dict[str, Any]) -> list[tuple[float, float]]:
    """(target inertial number, wall pressure in Pa) of every rheometer state, in config order.

    The states are ``inertial_numbers`` at ``wall_pressure``, then the ``extra_states`` (other
    pressures, which the critical-state line p_c(nu) needs).
    """
    states = [(float(i), float(case["wall_pressure"])) for i in case["inertial_numbers"]]
    states += [(float(s["inertial_number"]), float(s["wall_pressure"])) for s in case.get("extra_states", [])]
    return states


def run_ids(case_name: str, case: dict[str, Any]) -> list[str]:
    """Names of the DEM runs of one case: one per (state, replica) or per replica."""
    replicas = [f"r{k + 1}" for k in range(case["replicas"])]
    if case_name == "rheometer":
        return [f"I{i:g}-P{p:g}-{rep}" for i, p in rheometer_states(case) for rep in replicas]
    if case["geometry"] == "intruder":
        # D<depth in d>-r<k>; the control (top wall at rest) at the shallowest depth: D<depth>-control-r<k>.
        depths = case["depths_below_top"]
        runs = [f"D{depth:g}-{rep}" for depth in depths for rep in replicas]
        if case.get("control", False):
            runs += [f"D{min(depths):g}-control-{rep}" for rep in replicas]
        sweep = case.get("force_sweep")
        if sweep:
            runs += [f"D{float(sweep['depth']):g}-F{float(f):g}-{rep}" for f in sweep["forces"] for rep in replicas]
        return runs
    return replicas + size_study_runs(case)


def size_study_runs(case: dict[str, Any]) -> list[str]:
    """Runs of the DEM system-size study of a planar case: ``L<cell in d>-r<k>``."""
    study = case.get("size_study") or {}
    return [f"L{cell:g}-r{k + 1}" for cell in study.get("cells", []) for k in range(study.get("replicas", 0))]


def size_study_cell(run: str) -> float | None:
    """Cell length (in d) of a size-study run id ``L<cell>-r<k>``; None for any other run."""
    match = re.fullmatch(r"L([0-9.eE+-]+)-r\d+", run)
    return float(match.group(1)) if match else None


def run_case(case: dict[str, Any], run: str) -> dict[str, Any]:
    """The case spec one run uses: a size-study run has a square L x L cell and the grains per
    area of the case (same bed height, same pressures) and the study's own ``production_strain``
    cap where it names one; every other run the case as given."""
    cell = size_study_cell(run)
    if cell is None:
        return case
    scale = cell * cell / (case["cell_x"] * case["cell_y"])
    sized = {**case, "cell_x": cell, "cell_y": cell, "n_grains": int(round(case["n_grains"] * scale))}
    cap = (case.get("size_study") or {}).get("production_strain")
    return sized if cap is None else sized | {"production_strain": cap}


def dem_runs(config: dict[str, Any]) -> list[tuple[str, str]]:
    """Every (case, run) pair of the config, in a stable order."""
    return [(name, run) for name, case in config["cases"].items() for run in run_ids(name, case)]


#: Settings of a case that the fill (pour and settle, walls and bodies made) reads; nothing else changes it.
FILL_CASE_KEYS = ("geometry", "cell_x", "cell_y", "n_grains", "gravity", "rod_diameter")


def shared_fill_ids(case_name: str, case: dict[str, Any]) -> list[str]:
    """The fills of a case that several runs start from, each poured once in its own folder.

    - The rheometer with ``shared_fill``: ``fill-r<k>``, one per replica, for all its states (they
      are states at different I and P, not replicas of each other, and each shears 1 strain or more
      at its own rate to its own steady packing before anything is measured).
    - An intruder case with ``control``: ``fill-D<depth>-r<k>``, the shallowest run's, which its
      control (the same run with the top wall at rest) has always poured again from the same seed.
    - An intruder case with ``shared_bed``: ``fill-sheared-r<k>``, one per replica, poured without
      the rod and sheared to steady state; every run of the replica inserts its rod into it
      (:mod:`pipeline.dem.sheared_bed`).
    Replicas never share a fill: their scatter is the DEM noise.
    """
    replicas = [f"r{k + 1}" for k in range(case["replicas"])]
    if case_name == RHEOMETER and case.get("shared_fill", False):
        return [f"fill-{rep}" for rep in replicas]
    if is_sheared_bed_case(case):
        return [f"{SHEARED_BED_PREFIX}{rep}" for rep in replicas]
    if case["geometry"] == "intruder" and case.get("control", False):
        return [f"fill-D{min(case['depths_below_top']):g}-{rep}" for rep in replicas]
    return []


def shared_fill_of(case_name: str, case: dict[str, Any], run: str) -> str | None:
    """The shared fill a run starts from, or None (it pours its own)."""
    if not shared_fill_ids(case_name, case) or size_study_cell(run) is not None:
        return None
    if case["geometry"] == "intruder":
        depth, _, replica = intruder_run(run)
        if is_sheared_bed_case(case):
            return f"{SHEARED_BED_PREFIX}{replica}"
        fill = f"fill-D{depth:g}-{replica}"
        return fill if fill in shared_fill_ids(case_name, case) else None
    return f"fill-{run.rsplit('-', 1)[1]}"


def fill_owner_run(case_name: str, case: dict[str, Any], fill: str) -> str:
    """The run whose per-run config a shared fill reads (and whose set-up, with the fill's seed, pours it).

    Rheometer: the replica's first state in config order (the fill reads none of a state's own
    settings; the first is the stable choice when states are appended). Intruder: the sheared run
    at the fill's depth.
    """
    if fill not in shared_fill_ids(case_name, case):
        raise ValueError(f"{fill!r} is not a shared fill of case {case_name!r} "
                         f"(its fills: {', '.join(shared_fill_ids(case_name, case)) or 'none'})")
    if is_sheared_bed_case(case):
        return f"D{min(case['depths_below_top']):g}-{fill.removeprefix(SHEARED_BED_PREFIX)}"
    if case["geometry"] == "intruder":
        return fill.removeprefix("fill-")
    replica = fill.split("-", 1)[1]
    return next(run for run in run_ids(case_name, case) if run.endswith(f"-{replica}"))


def fill_physics(config: dict[str, Any], case_name: str, fill: str) -> dict[str, Any]:
    """What a shared fill's packing depends on: the material, the case's cell, grains and bodies
    (an intruder's rod: its depth is in the fill's id), and the fill's own seed (from its id, so
    any run's own config gives it). A run adopting the fill checks it against its own config's."""
    case = config["cases"][case_name]
    physics = {"material": dict(config["material"]), "case": case_name, "fill": fill,
               "cell": {k: case[k] for k in FILL_CASE_KEYS if k in case},
               "seed": derived_seed(config["seed"], case_name, fill)}
    if is_sheared_bed_case(case):
        # A sheared bed also depends on its shear: the load, the wall speed and the DEM settings.
        physics["cell"] |= {k: case[k] for k in SHEARED_BED_CASE_KEYS if k in case}
        physics["dem"] = {k: v for k, v in case_production(config["dem"], case).items()
                          if k not in ("mpi_ranks", "mpi_launcher", "liggghts")}
    return physics


#: Prefix of an intruder case's shared pre-sheared beds (``cases.<case>.shared_bed``): ``fill-sheared-r<k>``.
SHEARED_BED_PREFIX = "fill-sheared-"
#: Settings of an intruder case that its sheared bed reads besides the fill's.
SHEARED_BED_CASE_KEYS = ("wall_pressure", "wall_speed", "rod_diameter", "min_shear_strain")


def is_sheared_bed_case(case: dict[str, Any]) -> bool:
    """Whether an intruder case's runs insert their rods into a shared pre-sheared bed (``shared_bed``)."""
    return case.get("geometry") == "intruder" and bool(case.get("shared_bed", False))


def continues_from_slower(case_name: str, case: dict[str, Any], run: str) -> bool:
    """Whether a run shears from a slower state's final packing: a rheometer state whose target
    inertial number is above ``continue_above`` (read from the run's own config alone)."""
    threshold = case.get("continue_above") if case_name == RHEOMETER else None
    return threshold is not None and size_study_cell(run) is None and run_state(run)[0] > threshold


def predecessor_state(case_name: str, case: dict[str, Any], run: str) -> str | None:
    """The rheometer state a state starts from, with ``continue_above``: for a target inertial
    number above it, the replica's state with the next lower target I (of those, the pressure
    nearest its own), whose final packing it shears from; None for every other run.

    The fast states dilate far from the settled packing (nu about 0.6 to below 0.5), which a load
    of a few Pa drives slowly; the next slower state has done most of it.
    """
    if not continues_from_slower(case_name, case, run):
        return None
    inertial, pressure = run_state(run)
    replica = run.rsplit("-", 1)[1]
    slower = [(i, p) for i, p in rheometer_states(case) if i < inertial]
    if not slower:
        return None
    top = max(i for i, _ in slower)
    i, p = min(((i, p) for i, p in slower if i == top), key=lambda state: abs(math.log(state[1] / pressure)))
    return f"I{i:g}-P{p:g}-{replica}"


def dem_fills(config: dict[str, Any]) -> list[tuple[str, str]]:
    """Every (case, shared fill) pair of the config."""
    return [(name, fill) for name, case in config["cases"].items() for fill in shared_fill_ids(name, case)]


_RHEOMETER_RUN = re.compile(r"^I([0-9.eE+-]+)-P([0-9.eE+-]+)-r\d+$")


def run_state(run: str) -> tuple[float, float]:
    """Target inertial number and wall pressure (Pa) of a rheometer run id (``I0.02-P200-r1``)."""
    match = _RHEOMETER_RUN.match(run)
    if match is None:
        raise ValueError(f"run id {run!r} is not a rheometer run id (expected 'I<inertial number>-P<pressure>-r<k>')")
    return float(match.group(1)), float(match.group(2))


_INTRUDER_RUN = re.compile(r"^D([0-9.eE+-]+?)-(?:F([0-9.eE+-]+?)-)?(control-)?(r\d+)$")


def intruder_run(run: str) -> tuple[float, bool, str]:
    """Depth below the top wall (in d), control flag and replica of an intruder run id
    (``D6-control-r1``, ``D7-F0.6-r2``)."""
    match = _INTRUDER_RUN.match(run)
    if match is None:
        raise ValueError(f"run id {run!r} is not an intruder run id (expected 'D<depth in d>-[F<push>-][control-]r<k>')")
    return float(match.group(1)), match.group(3) is not None, match.group(4)


def intruder_push(run: str) -> float | None:
    """The push of a force-sweep run (``D7-F0.6-r1``: 0.6 of the yield force at its own depth), or
    None for a depth-sweep run or a control (the case's ``force`` of the shallowest depth's yield force)."""
    match = _INTRUDER_RUN.match(run)
    if match is None:
        raise ValueError(f"run id {run!r} is not an intruder run id")
    return float(match.group(2)) if match.group(2) is not None else None


def derived_seed(master_seed: int, *labels: str) -> int:
    """A deterministic 31-bit seed from the master seed and labels (stable across Python runs)."""
    text = ":".join([str(master_seed), *labels]).encode()
    return int.from_bytes(hashlib.sha256(text).digest()[:4], "little") & 0x7FFFFFFF


def _is_prime(n: int) -> bool:
    if n < 2:
        return False
    if n % 2 == 0:
        return n == 2
    k = 3
    while k * k <= n:
        if n % k == 0:
            return False
        k += 2
    return True


def liggghts_seed(master_seed: int, *labels: str) -> int:
    """A prime above 10000 derived from the master seed (LIGGGHTS requires prime seeds)."""
    n = 10007 + derived_seed(master_seed, *labels) % 50_000_000
    while not _is_prime(n):
        n += 1
    return n


#: The case whose runs calibrate the local laws (homogeneous shear, no gravity).
RHEOMETER = "rheometer"


def nonlocal_runs(config: dict[str, Any]) -> list[tuple[str, str]]:
    """The planar runs the non-local lengths are fitted on: the replicas (``r<k>``) of
    ``calibration.nonlocal_case``, all of them by default (``nonlocal_runs: all``), or the subset
    ``nonlocal_runs`` lists (the older single ``nonlocal_run`` is a subset of one). The fit is to
    their replica mean; the lengths' errors come from leaving one replica out at a time."""
    calib = config.get("calibration") or {}
    case = calib.get("nonlocal_case", "shear_gravity")
    if "nonlocal_run" in calib:
        return [(case, str(calib["nonlocal_run"]))]
    chosen = calib.get("nonlocal_runs", "all")
    if chosen == "all":
        spec = (config.get("cases") or {}).get(case)
        if spec is None:
            return []
        return [(case, f"r{k + 1}") for k in range(int(spec.get("replicas", 1)))]
    return [(case, str(run)) for run in chosen]


def calibration_runs(config: dict[str, Any]) -> list[tuple[str, str]]:
    """The calibration set: every rheometer run and the planar runs of :func:`nonlocal_runs`.
    Nothing else may reach the calibration."""
    return [(c, r) for c, r in dem_runs(config) if c == RHEOMETER] + nonlocal_runs(config)


def validation_cases(config: dict[str, Any]) -> list[str]:
    """Cases none of whose runs is in the calibration set: their scores are predictions."""
    used = {c for c, _ in calibration_runs(config)}
    return [name for name in config["cases"] if name not in used]


#: Config sections that do not change what a DEM run computes.
NON_DEM_SECTIONS = ("coarse_grain", "calibration", "models", "scoring")


def dem_config(config: dict[str, Any], case: str | None = None) -> dict[str, Any]:
    """The part of a config a DEM run depends on (still a valid config on its own).

    With ``case``, only that case is kept: adding or changing another case does not touch it.
    """
    out = {key: value for key, value in config.items() if key not in NON_DEM_SECTIONS}
    if case is not None:
        # A size study adds runs of other cell sizes; it does not change the case's own runs.
        out["cases"] = {case: {k: v for k, v in config["cases"][case].items() if k != "size_study"}}
    return out


def run_config(config: dict[str, Any], case: str, run: str) -> dict[str, Any]:
    """What one DEM run depends on and nothing more, as a config of its own: :func:`dem_config` of
    its case, a rheometer case narrowed to the run's own state (``inertial_numbers: [I]`` at its
    ``wall_pressure``), a size-study run's case with the study's ``production_strain``. Adding a
    rheometer state or another case leaves every other run as it is."""
    out = dem_config(config, case)
    cap = (config["cases"][case].get("size_study") or {}).get("production_strain")
    if size_study_cell(run) is not None and cap is not None:
        # The study's cap is this run's (the study itself is left out of its case's DEM config).
        out["cases"][case] = out["cases"][case] | {"production_strain": cap}
    if case == RHEOMETER:
        inertial, pressure = run_state(run)
        spec = {k: v for k, v in out["cases"][case].items() if k != "extra_states"}
        out["cases"] = {case: spec | {"inertial_numbers": [inertial], "wall_pressure": pressure}}
    return out


def run_physics(config: dict[str, Any], case: str, run: str) -> dict[str, Any]:
    """The part of :func:`run_config` that changes what LIGGGHTS computes: without the output
    folder, the executable and the MPI layout (a run may resume elsewhere or on other ranks)."""
    out = run_config(config, case, run)
    out.pop("output_root", None)
    out["dem"] = {k: v for k, v in out["dem"].items() if k not in ("mpi_ranks", "mpi_launcher", "liggghts")}
    return out
