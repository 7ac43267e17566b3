"""The continuum models' parameter sets from a calibration (``params.json`` content).

Builders from the flat name -> value map of the local and critical-state parameters to each
model's parameter dataclass (:mod:`continuum.parameters`), and the few readers every stage that
solves a model on a DEM case shares. Pure: no files, no fits.
"""
from __future__ import annotations

import copy
from typing import Any

from continuum.parameters import (
    CosseratParameters,
    CriticalStateLine,
    CriticalStateParameters,
    LocalMuIParameters,
    MuIParameters,
    NGFParameters,
    SolidFractionLaw,
    VolumeAveragedParameters,
)


class CalibrationError(ValueError):
    """The fields cannot calibrate the models; the message names the file and the cause."""


CALIBRATION_DEFAULTS: dict[str, Any] = {
    "nonlocal_case": "shear_gravity",
    "bulk_margin_over_d": 3.0,
    # Creeping points below this fraction of the wall speed are left out of the log fit: the
    # DEM resolves them only above its noise (checked against the point's own error too).
    "min_speed_over_wall_speed": 1e-5,
    "critical_state_n": 1.05,
    "cosserat_beta": 1.0,
    "cosserat_wall_spin_ratio": 0.5,
    # The models' walls slip as the DEM's rheometer walls do (issue 54, pipeline/calibration/wall_slip.py).
    "wall_slip": "rheometer",
}


def calibration_settings(config: dict[str, Any]) -> dict[str, Any]:
    """The config's ``calibration`` section over :data:`CALIBRATION_DEFAULTS`."""
    return CALIBRATION_DEFAULTS | (config.get("calibration") or {})


def _mu_i(v: dict[str, float]) -> MuIParameters:
    return MuIParameters(v["mu_s"], v["mu_2"], v["I_0"])


def local_mu_i_parameters(v: dict[str, float]) -> LocalMuIParameters:
    return LocalMuIParameters(_mu_i(v), SolidFractionLaw(v["nu_c"], v["a"]))


def ngf_parameters(v: dict[str, float], A: float) -> NGFParameters:
    return NGFParameters(_mu_i(v), A=A, nu=v["nu_c"])


def critical_state_parameters(v: dict[str, float], settings: dict[str, Any] | None = None) -> CriticalStateParameters:
    n = v.get("n", (settings or CALIBRATION_DEFAULTS)["critical_state_n"])
    return CriticalStateParameters(v["sin_phi"], CriticalStateLine(v["nu_ref"], v["kappa"], v["p_ref"]), n=n)


def cosserat_parameters(v: dict[str, float], l: float, settings: dict[str, Any] | None = None) -> CosseratParameters:
    s = settings or CALIBRATION_DEFAULTS
    return CosseratParameters(critical_state_parameters(v, s), l=l, beta=s["cosserat_beta"],
                              wall_spin_ratio=s["cosserat_wall_spin_ratio"])


def volume_averaged_parameters(v: dict[str, float], l: float, settings: dict[str, Any] | None = None) -> VolumeAveragedParameters:
    return VolumeAveragedParameters(critical_state_parameters(v, settings), l=l)


def values(params: dict[str, Any]) -> dict[str, float]:
    """Flat name -> value of the local and critical-state parameters of a params.json."""
    return {name: entry["value"] for name, entry in (params["local"] | params["critical_state"]).items()}


def model_parameters(params: dict[str, Any], model: str) -> Any:
    """The continuum parameter dataclass of ``model`` from a params.json content."""
    v = values(params)
    nonlocal_ = params.get("nonlocal", {})
    if model == "local_mu_i":
        return local_mu_i_parameters(v)
    if model == "critical_state":
        return critical_state_parameters(v)
    if model not in nonlocal_:
        raise CalibrationError(f"params.json has no non-local calibration for model {model!r}")
    if model == "ngf":
        return ngf_parameters(v, A=nonlocal_["ngf"]["A"]["value"])
    if model == "cosserat":
        return cosserat_parameters(v, l=nonlocal_["cosserat"]["l"]["value"])
    if model == "volume_averaged":
        return volume_averaged_parameters(v, l=nonlocal_["volume_averaged"]["l"]["value"])
    raise CalibrationError(f"unknown model {model!r}")


def normal_stress_ratio(params: dict[str, Any]) -> float:
    """sigma_zz / p the models use: their p is sigma_zz over it (continuum.geometry). Measured in the
    calibration case's planar bed where it is in the rheometer's I range (``models_sigma_zz_over_p``),
    or the rheometer bulk's in a params.json without it."""
    stresses = params.get("normal_stresses", {})
    if "models_sigma_zz_over_p" in stresses:
        return float(stresses["models_sigma_zz_over_p"]["value"])
    try:
        return float(params["normal_stresses"]["sigma_zz_over_p"]["value"])
    except KeyError:
        raise CalibrationError("params.json has no normal_stresses.sigma_zz_over_p: written by an older "
                               "calibration, rerun it") from None


def slip_length(params: dict[str, Any]) -> float:
    """The models' wall slip length b (m; ``continuum.geometry.PlanarShear.slip_length``) of a
    ``params.json`` (its ``wall`` entry, pipeline/calibration/wall_slip.py)."""
    try:
        return float(params["wall"]["slip_length"]["value"])
    except KeyError:
        raise CalibrationError("params.json has no wall.slip_length: written by a calibration from before "
                               "issue 54 (the wall's slip), rerun it") from None


def params_of_draw(params: dict[str, Any], draw: dict[str, Any]) -> dict[str, Any]:
    """A ``params.json``-shaped dict holding one draw's values (for ``model_parameters`` and the
    solvers); every entry the draw does not set is the calibration's own."""
    out = copy.deepcopy({k: v for k, v in params.items() if k not in ("rheometer_states",)})
    out["rheometer_states"] = params.get("rheometer_states", [])
    for section in ("local", "critical_state"):
        for name in out[section]:
            out[section][name]["value"] = float(draw["values"][name])
    key = "models_sigma_zz_over_p" if "models_sigma_zz_over_p" in out["normal_stresses"] else "sigma_zz_over_p"
    out["normal_stresses"][key]["value"] = float(draw["sigma_zz_over_p"])
    if "slip_length" in draw:
        out["wall"]["slip_length"]["value"] = float(draw["slip_length"])
    out["nonlocal"] = {model: {name: {"value": v} for name, v in entry.items()}
                       for model, entry in draw["nonlocal"].items() if entry is not None}
    return out
