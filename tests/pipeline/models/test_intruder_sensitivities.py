"""pipeline.models.intruder_sensitivities (issue 57, item 1): the plastic models' draws propagated
from the nominal solution's speed sensitivities to first order in ln U, with one check solve per
scene. On the small intruder bed (12 d, cell 8 d, 2 cells per d) with the volume-averaged model,
whose ln U is curved in its length (docs/dem_cost.md section 25):

* a draw holding the calibration's values is the nominal speed exactly (s = 0);
* the propagation's error against a draw's own solve is second order in the offset: a draw at a
  tenth of another's offsets is off by about a hundredth as much (a wrong derivative would give a
  tenth); the bound 0.03 leaves room for the third-order term, and the solves agree to 1e-6;
* the check solve is the check draw's own solve, and its recorded error is that draw's.
"""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from pipeline.calibration.parameter_sets import model_parameters, params_of_draw
from pipeline.models.intruder import scenes_of, solve_scene, solve_scenes
from pipeline.models.intruder_sensitivities import draw_parameters, linearised_speeds, sensitivities

from .intruder_bed import MU, PARAMS, fields, run

D = 0.002
CRITICAL = {"sin_phi": 0.374, "nu_ref": 0.5868, "kappa": 0.005, "p_ref": 300.0}
PLASTIC = copy.deepcopy(PARAMS) | {"critical_state": {k: {"value": v} for k, v in CRITICAL.items()},
                                   "nonlocal": {"volume_averaged": {"l": {"value": 1.165 * D}}}}
RUNS = [run("D5-r1", 5, 0.5)]
MODEL = "volume_averaged"


def draw(k: int, sin_phi: float, l_over_d: float, failed: bool = False) -> dict:
    values = dict(MU) | CRITICAL | {"sin_phi": sin_phi}
    return {"draw": k, "values": values, "sigma_zz_over_p": 1.058, "slip_length": 0.0,
            "nonlocal": {MODEL: None if failed else {"l": l_over_d * D}},
            "failed": {MODEL: "refit failed: test"} if failed else {}}


ENSEMBLE = {"seed": 1, "draws": [draw(0, 0.374, 1.165), draw(1, 0.372, 1.05), draw(2, 0.3738, 1.1535),
                                 draw(3, 0.374, 1.2, failed=True)]}


def test_offsets_cover_the_moved_parameters_and_keep_failed_draws_as_nan() -> None:
    indices, offsets, paths, failures = draw_parameters(PLASTIC, ENSEMBLE, MODEL)
    # the failed draw keeps its row (NaN): draw k is row k in every model's file
    assert indices == [0, 1, 2, 3] and set(failures) == {"3"} and np.all(np.isnan(offsets[3]))
    assert paths == ["critical.sin_phi", "l"]  # only what some draw moves
    assert np.allclose(offsets[0], 0.0) and offsets[1] == pytest.approx([-0.002, -0.115 * D])


def test_the_propagation_is_exponential_in_s_and_stays_zero_at_rest() -> None:
    s = np.array([0.0, -0.5, 0.3])
    assert np.allclose(linearised_speeds(2e-3, s), 2e-3 * np.exp(s))
    assert linearised_speeds(2e-3, s)[0] == 2e-3
    assert np.all(linearised_speeds(0.0, s) == 0.0)


@pytest.fixture(scope="module")
def propagated():
    scenes = scenes_of(RUNS, [fields()], PLASTIC)
    nominal, _ = solve_scenes(MODEL, model_parameters(PLASTIC, MODEL), scenes, 2.0)
    return scenes, nominal, sensitivities(MODEL, PLASTIC, ENSEMBLE, scenes, nominal, 2.0)


def own_speed(scenes, nominal, k: int) -> float:
    params = model_parameters(params_of_draw(PLASTIC, ENSEMBLE["draws"][k]), MODEL)
    result, reason = solve_scene(MODEL, params, scenes[0], 2.0, nominal[0])
    assert result is not None, reason
    return result.speed


def test_propagated_draws_against_their_own_solves(propagated) -> None:
    scenes, nominal, out = propagated
    u0 = nominal[0].speed
    assert u0 > 0.0 and out.attrs["u_input_method"] == "sensitivities"
    speed = out.speed.values[:, 0]
    assert speed[0] == u0  # the calibration's own values
    assert np.isnan(speed[3]) and out.refused.values[3, 0] == 1 and "3" in json.loads(out.attrs["failures"])
    s1, s2 = out.log_offset.values[1, 0], out.log_offset.values[2, 0]
    assert s2 == pytest.approx(0.1 * s1, rel=1e-6) and abs(s1) > 0.5  # a real offset, and a tenth of it
    errors = [abs(np.log(speed[k] / own_speed(scenes, nominal, k))) for k in (1, 2)]
    assert errors[0] > 1e-2  # the far draw is visibly off the first order (ln U is curved in l) ...
    assert errors[1] < 0.03 * errors[0]  # ... and the error falls as the offset squared, not linearly
    k = int(out.check_draw.values[0])
    assert out.check_speed.values[0] == pytest.approx(own_speed(scenes, nominal, k), rel=1e-6)
    assert out.check_dln_linear.values[0] == pytest.approx(np.log(out.check_speed.values[0] / u0)
                                                           - out.log_offset.sel(draw=k).values[0], abs=1e-12)


def test_the_layout_merges_the_propagated_part_for_plastic_models_only() -> None:
    """``models.intruder_plastic_u_input: sensitivities`` puts one propagated part in place of the
    plastic models' draws parts; NGF (no Newton solver) keeps its draws; absent means draws."""
    from continuum.intruder import INTRUDER_MODELS
    from continuum.intruder.sensitivity import has_jacobian
    from pipeline.common import layout

    # the layout's list is the registry's Newton yield-stress solvers
    assert set(layout.PLASTIC_INTRUDER_MODELS) == {m for m in INTRUDER_MODELS if has_jacobian(m)}
    config = {"output_root": "R", "models": {"intruder_draw_jobs": 2}}
    assert [p.rsplit("/", 1)[1] for p in layout.intruder_draw_part_paths(config, "intruder", "cosserat")] == \
        ["draws-1-of-2.nc", "draws-2-of-2.nc", "refined.nc"]
    config["models"]["intruder_plastic_u_input"] = "sensitivities"
    assert [p.rsplit("/", 1)[1] for p in layout.intruder_draw_part_paths(config, "intruder", "cosserat")] == \
        ["sensitivities.nc", "refined.nc"]
    assert [p.rsplit("/", 1)[1] for p in layout.intruder_draw_part_paths(config, "intruder", "ngf")] == \
        ["draws-1-of-2.nc", "draws-2-of-2.nc", "refined.nc"]


NGF_ENSEMBLE = {"seed": 1, "draws": [
    {"draw": k, "values": dict(MU), "sigma_zz_over_p": 1.058, "slip_length": 0.0, "nonlocal": {"ngf": {"A": a}},
     "failed": {}} for k, a in enumerate((0.327, 0.327 * 1.2, 0.327 * 1.02))]}


def test_ngf_draws_are_propagated_by_secants_of_its_own_solves() -> None:
    """NGF (no Newton Jacobian): dU/dA is a central secant of two warm solves over +- the draws'
    spread of A. The propagation converges as the offset shrinks: a tenth of the offset gives under
    a fifth of the error against the draw's own solve (a secant's first-order bias would give about
    a tenth, the curvature about a hundredth); the calibration's own values give U_0 exactly."""
    scenes = scenes_of(RUNS, [fields()], PARAMS)
    nominal, _ = solve_scenes("ngf", model_parameters(PARAMS, "ngf"), scenes, 2.0)
    out = sensitivities("ngf", PARAMS, NGF_ENSEMBLE, scenes, nominal, 2.0)
    assert list(out.parameter.values) == ["A"]
    speed, u0 = out.speed.values[:, 0], nominal[0].speed
    assert speed[0] == u0 and u0 > 0.0

    def own(k: int) -> float:
        params = model_parameters(params_of_draw(PARAMS, NGF_ENSEMBLE["draws"][k]), "ngf")
        result, reason = solve_scene("ngf", params, scenes[0], 2.0, nominal[0])
        assert result is not None, reason
        return result.speed

    errors = [abs(np.log(speed[k] / own(k))) for k in (1, 2)]
    assert abs(np.log(own(1) / u0)) > 0.02  # the far draw moves the rod
    assert errors[1] < 0.2 * errors[0], errors
    assert np.isfinite(out.check_speed.values[0])


def test_a_scene_whose_propagation_fails_its_check_solves_its_draws() -> None:
    """The check's rule (a quarter of the predicted change, floor 0.01 in ln U), and a scene that
    fails it: with the check's bound made impossible to meet, the scene's first draws are its own
    solves (the nominal draw's the nominal speed), the rest NaN with the reason, not propagated."""
    from pipeline.models import intruder_sensitivities as mod

    assert mod.check_passes(0.02, 0.1) and not mod.check_passes(0.04, 0.1) and not mod.check_passes(np.nan, 0.1)
    scenes = scenes_of(RUNS, [fields()], PLASTIC)
    nominal, _ = solve_scenes(MODEL, model_parameters(PLASTIC, MODEL), scenes, 2.0)
    saved = (mod.CHECK_RELATIVE, mod.CHECK_FLOOR)
    mod.CHECK_RELATIVE, mod.CHECK_FLOOR = 0.0, -1.0  # no check can pass
    try:
        out = mod.sensitivities(MODEL, PLASTIC, ENSEMBLE, scenes, nominal, 2.0, fallback_draws=2)
    finally:
        mod.CHECK_RELATIVE, mod.CHECK_FLOOR = saved
    speed = out.speed.values[:, 0]
    assert out.propagated.values[0] == 0 and "failed its check" in json.loads(out.attrs["sensitivity_failures"])["D5-r1"]
    assert speed[0] == pytest.approx(nominal[0].speed, rel=1e-6)  # draw 0 holds the calibration's values
    assert speed[1] == pytest.approx(own_speed(scenes, nominal, 1), rel=1e-9)
    assert np.all(np.isnan(speed[2:])) and np.all(out.refused.values[2:, 0] == 1)
