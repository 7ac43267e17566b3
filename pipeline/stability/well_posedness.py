"""Well-posedness of every model about simple shear: ``stability/well_posedness.csv``.

Two parameter sets: the glass-bead reference (``continuum.stability.GLASS_BEADS_REFERENCE``)
and the parameters calibrated on our DEM (``calibration/params.json``). The calibrated
Cosserat and volume-averaged models have different lengths l, so each is classified with its own.

Usage: ``python -m pipeline.stability.well_posedness --params params.json --out stability/well_posedness.csv``
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from continuum import stability
from pipeline.common import atomic
from pipeline.calibration.parameter_sets import values

#: Inertial numbers of the classification grid (log-spaced across the dense-flow range).
I_GRID = np.logspace(-4, 0.5, 28)


def calibrated_sets(params: dict[str, Any]) -> dict[str, dict[str, float]]:
    """Stability parameter dicts from params.json: one per non-local length."""
    v = values(params)
    base = {k: v[k] for k in ("mu_s", "mu_2", "I_0", "nu_c", "a", "sin_phi")}
    base["pc_log_slope"] = 1.0 / v["kappa"]  # p_c = p_ref exp((nu - nu_ref) / kappa)
    base["n_exp"] = v["n"]
    sets = {"calibrated": dict(base)}
    nonlocal_ = params.get("nonlocal", {})
    if "ngf" in nonlocal_:
        sets["calibrated"]["A"] = nonlocal_["ngf"]["A"]["value"]
    for model in ("cosserat", "volume_averaged"):
        if model in nonlocal_:
            sets[f"calibrated:{model}"] = base | {"l_over_d": nonlocal_[model]["l"]["value"] / params["d"]}
    return sets


def table(params: dict[str, Any] | None, I_values: np.ndarray = I_GRID) -> pd.DataFrame:
    """The contract's well-posedness table for the reference and the calibrated parameters."""
    frames = [stability.well_posedness_table({"glass_beads_reference": stability.GLASS_BEADS_REFERENCE}, I_values)]
    if params is not None:
        sets = calibrated_sets(params)
        calibrated = stability.well_posedness_table({"calibrated": sets["calibrated"]}, I_values)
        for model in ("cosserat", "volume_averaged"):
            key = f"calibrated:{model}"
            if key in sets:
                own = stability.well_posedness_table({"calibrated": sets[key]}, I_values, include_variants=False)
                calibrated = pd.concat([calibrated[calibrated.model != model], own[own.model == model]])
        frames.append(calibrated)
    return pd.concat(frames, ignore_index=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Classify every model's well-posedness about simple shear.")
    parser.add_argument("--params", type=Path, help="calibration/params.json (omit for the reference set only)")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    params = json.loads(args.params.read_text()) if args.params else None
    result = table(params)
    atomic.write_csv(result, args.out)
    summary = result.groupby(["model", "parameter_set"])["well_posed"].agg(["sum", "count"])
    print(summary.to_string())
    return 0
