"""The calibration's uncertainty as an ensemble of parameter sets: ``calibration/draws.json``.

Every prediction is solved once per draw (pipeline.models) and the spread of each score over the
draws is its ``u_input`` (pipeline.scoring). A draw is a whole calibration, so the parameters'
correlations are carried into the predictions:

1. the local laws from the fits' covariances in ``params.json``: (mu_s, mu_2, I_0) of mu(I),
   (nu_c, a) of nu(I), the critical-state line (nu_ref, kappa, a) (with kappa at its floor, as the
   calibration set it when the DEM resolves no pressure dependence, nu_ref follows nu_c), sin_phi
   = the drawn mu_s (the calibration's own definition), and the models' sigma_zz / p from its error; draws
   outside the laws' domain (I_0 <= 0, mu_2 <= mu_s, kappa <= 0, nu_c outside (0, 1)) are drawn
   again and counted; the walls' slip length from its calibration error (normal, held >= 0, from
   a stream of its own);
2. each non-local parameter refitted on the calibration case's replica mean with the drawn local
   laws (:func:`pipeline.calibration.nonlocal_fit.fit_length`): the length the creep asks for
   moves with mu_s, which a draw of the length alone would miss;
3. times ``exp(epsilon)``, epsilon normal with the length's replica error in log (the jackknife of
   the log values in ``params.json``, or the curvature error with one replica): the realisation
   scatter of the calibration case, which the refit on one replica mean does not see; and, in
   quadrature, the length's error from the creep's age (``age.error_age_log``, half the log
   difference of the lengths fitted on the production's two halves: the deep creep slows as the
   bed compacts, docs/dem.md); held to the fit's own range (:data:`DRAW_BOUNDS`).

A draw whose refit fails (no admissible length, a solver failure) keeps no value for that model
(``null``) and says why; the models stage then has no solution for it.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

import continuum
from pipeline.calibration.nonlocal_fit import NONLOCAL_PARAMETER, fit_length, mean_creep
from pipeline.calibration.parameter_sets import CalibrationError, calibration_settings
from pipeline.calibration.samplers import NormalSource, normal_source
from pipeline.common import atomic
from pipeline.common.config import derived_seed, load_config
from pipeline.common.formats import open_fields
from pipeline.common.provenance import provenance

#: Draws when the config's ``calibration.draws`` is absent.
DEFAULT_DRAWS = 64
MAX_REJECTIONS = 10_000


def _normal(source: NormalSource, cov_entry: dict[str, Any], means: dict[str, float]) -> dict[str, float]:
    names = cov_entry["names"]
    mean = np.array([means[n] for n in names])
    cov = np.asarray(cov_entry["matrix"], dtype=float)
    return dict(zip(names, map(float, source.multivariate_normal(mean, cov))))


def admissible(v: dict[str, float]) -> bool:
    """Whether a drawn parameter set lies in the laws' domain (module docstring, item 1)."""
    return (v["I_0"] > 0.0 and v["mu_2"] > v["mu_s"] > 0.0 and v["kappa"] > 0.0 and 0.0 < v["nu_c"] < 1.0
            and 0.0 < v["nu_ref"] < 1.0 and 0.0 < v["sin_phi"] < 1.0)


def draw_local(params: dict[str, Any], source: NormalSource) -> tuple[dict[str, float], float, int]:
    """One draw of the local and critical-state values (flat, as :func:`parameter_sets.values`),
    of sigma_zz / p, and the number of draws rejected before it (``source``: the normal deviates,
    :mod:`pipeline.calibration.samplers`)."""
    nominal = {name: e["value"] for name, e in params["local"].items()}
    critical = {name: e["value"] for name, e in params["critical_state"].items()}
    cov = params["covariance"]
    stresses = params["normal_stresses"]
    ratio = stresses.get("models_sigma_zz_over_p", stresses["sigma_zz_over_p"])
    for rejected in range(MAX_REJECTIONS):
        source.start_draw()
        mu = _normal(source, cov["mu_i"], nominal)
        nu = _normal(source, cov["nu_i"], nominal)
        cs_names = cov["critical_state"]["names"]
        # The line's block (nu_ref, kappa, a); sin_phi (row 0) is the drawn mu_s, p_ref is fixed.
        line = [n for n in cs_names if n in ("nu_ref", "kappa", "a")]
        index = [cs_names.index(n) for n in line]
        block = np.asarray(cov["critical_state"]["matrix"], dtype=float)[np.ix_(index, index)]
        drawn_line = dict(zip(line, map(float, source.multivariate_normal(np.array([critical[n] for n in line]), block))))
        if cov["critical_state"].get("kappa_floored"):
            drawn_line["kappa"], drawn_line["nu_ref"] = critical["kappa"], nu["nu_c"]
        values = nominal | mu | nu | critical | drawn_line | {"sin_phi": mu["mu_s"]}
        r = source.normal(ratio["value"], ratio["error"])
        if admissible(values) and 0.5 < r < 2.0:
            return values, r, rejected
    raise CalibrationError(f"no admissible parameter draw in {MAX_REJECTIONS} tries: the calibration's "
                           "covariance reaches outside the laws' domain almost everywhere")


def relative_replica_error(entry: dict[str, Any]) -> float:
    """The width in log of the non-local parameter's realisation error: the jackknife of log
    values, else the relative jackknife or curvature error turned into log (log(1 + e / value)), so
    that an error larger than the value (a fit at a bound of its range) gives a wide but finite factor."""
    if math.isfinite(entry.get("error_jackknife_log", math.nan)):
        return float(entry["error_jackknife_log"])
    error = entry.get("error_jackknife", entry["error_fit_curvature"])
    return float(math.log1p(error / entry["value"]))


def relative_draw_error(entry: dict[str, Any]) -> float:
    """The width in log of the factor a draw multiplies the refitted length by: the realisation
    error (:func:`relative_replica_error`) and the error from the creep's age (``age.error_age_log``
    of ``params.json``, where the fields carry their window's halves) in quadrature."""
    age = (entry.get("age") or {}).get("error_age_log", 0.0)
    return float(math.hypot(relative_replica_error(entry), age))


#: The range a drawn non-local parameter is held to: the fit's own bounds (NGF's A; the lengths in d).
DRAW_BOUNDS = {"ngf": (0.01, 10.0), "cosserat": (0.05, 20.0), "volume_averaged": (0.05, 20.0)}


def draw_ensemble(params: dict[str, Any], nonlocal_paths: list[Path], settings: dict[str, Any], n_draws: int,
                  seed: int, sampler: str = "random") -> dict[str, Any]:
    """The ``draws.json`` content: ``n_draws`` parameter sets (module docstring), their normal
    deviates from ``sampler`` (:mod:`pipeline.calibration.samplers`)."""
    source = normal_source(sampler, seed, n_draws)
    # The wall's slip length from a stream of its own: the other values of every draw are those
    # drawn before the wall had one (issue 54), so the wall's share of u_input is its own.
    wall_rng = np.random.default_rng([seed, 54])
    wall = params["wall"]["slip_length"]
    sets = [open_fields(p) for p in nonlocal_paths]
    draws, rejected_total = [], 0
    failures: dict[str, int] = {}
    try:
        for k in range(n_draws):
            values, ratio, rejected = draw_local(params, source)
            rejected_total += rejected
            slip = max(0.0, float(wall_rng.normal(wall["value"], wall["error"]))) if wall["error"] > 0 else wall["value"]
            # Independent of the refit's outcome: the realisation factors are drawn first.
            factors = {m: math.exp(source.normal(0.0, relative_draw_error(params["nonlocal"][m][name])))
                       for m, name in NONLOCAL_PARAMETER.items() if m in params.get("nonlocal", {})}
            draw: dict[str, Any] = {"draw": k, "values": values, "sigma_zz_over_p": ratio, "slip_length": slip,
                                    "nonlocal": {}, "refit": {}, "failed": {}}
            if sets and factors:
                data = mean_creep(sets, settings, ratio, slip)
                for model, factor in factors.items():
                    name = NONLOCAL_PARAMETER[model]
                    try:
                        fit = fit_length(model, values, data, settings)
                    except (CalibrationError, continuum.ContinuumError, ValueError, RuntimeError) as exc:
                        draw["nonlocal"][model] = None
                        draw["failed"][model] = f"refit failed: {exc}"[:300]
                        failures[model] = failures.get(model, 0) + 1
                        continue
                    draw["refit"][model] = {name: fit.value}
                    lo, hi = DRAW_BOUNDS[model]
                    scale = 1.0 if model == "ngf" else float(params["d"])
                    draw["nonlocal"][model] = {name: float(np.clip(fit.value * factor, lo * scale, hi * scale))}
            draws.append(draw)
    finally:
        for ds in sets:
            ds.close()
    return {"n_draws": n_draws, "seed": seed, "sampler": sampler, "rejected": rejected_total, "refit_failures": failures,
            "method": __doc__.split("\n\n", 1)[1].strip(), "draws": draws}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Draw parameter sets from the calibration's uncertainty.")
    parser.add_argument("--config", required=True)
    parser.add_argument("--params", required=True, type=Path, help="calibration/params.json")
    parser.add_argument("--nonlocal", dest="nonlocal_fields", nargs="*", default=[], type=Path,
                        help="fields files of the non-local calibration runs (the same as the calibration's)")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    settings = calibration_settings(config)
    params = json.loads(args.params.read_text())
    n_draws = int(settings.get("draws", DEFAULT_DRAWS))
    seed = derived_seed(int(config["seed"]), "calibration-draws")
    ensemble = draw_ensemble(params, args.nonlocal_fields, settings, n_draws, seed, settings.get("draw_sampler", "random"))
    ensemble["provenance"] = provenance(config)
    atomic.write_json(ensemble, args.out)
    print(f"{n_draws} draws (seed {seed}), {ensemble['rejected']} rejected outside the laws' domain, "
          f"refit failures {ensemble['refit_failures'] or 'none'}")
    for model, name in NONLOCAL_PARAMETER.items():
        got = [d["nonlocal"][model][name] for d in ensemble["draws"] if d["nonlocal"].get(model)]
        if got:
            print(f"{model}: {name} over the draws {np.mean(got):.4g} +- {np.std(got, ddof=1):.2g} "
                  f"({len(got)} of {n_draws}; calibration {params['nonlocal'][model][name]['value']:.4g})")
    return 0
