"""pipeline.models.intruder: one scene per target depth and push, NGF's coupled speed with the
ngf_frozen approximation beside it, draws warm-started from the nominal solution, the grid study.
A small bed (12 d, cell 8 d, 2 cells per d; 3 for the grid study) keeps the 2D solves cheap."""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from pipeline.models.intruder import predict, scenes_of
from pipeline.models.intruder_draws import draw_parts, merge, predict_draws, solve_draws, solve_refined
from pipeline.models.intruder_states import load_states, save_states

from .intruder_bed import MU, PARAMS, fields, run


RUNS = [run("D4-r1", 4, 0.8), run("D4-F0.3-r1", 4, 0.5, True, 0.3), run("D4-F0.6-r1", 4, 1.0, True, 0.6),
        run("D4-F0.6-r2", 4, 1.0, True, 0.6)]


def test_one_scene_per_depth_and_push_ordered_by_force() -> None:
    scenes = scenes_of(RUNS, [fields()] * len(RUNS), PARAMS)
    assert [s.run["run"] for s in scenes] == ["D4-F0.3-r1", "D4-r1", "D4-F0.6-r1"]


@pytest.fixture(scope="module")
def solved() -> tuple[xr.Dataset, list]:
    return predict("ngf", PARAMS, RUNS, [fields()] * len(RUNS), cells_per_d=2.0)


def test_ngf_file_has_the_coupled_speeds_and_the_frozen_beside_them(solved) -> None:
    out, results = solved
    assert out.attrs["converged"] == 1 and json.loads(out.attrs["refused"]) == []
    assert out.speed.attrs["units"] == "m s-1" and out.sizes["depth_over_d"] == 1
    assert list(out.push_over_yield.values) == [0.3, 0.6]
    # The push raises U faster than the frozen fluidity's linear response (issue 43's table).
    sweep, frozen = out.sweep_speed.values, out.sweep_speed_frozen.values
    assert 0.0 < sweep[0] < sweep[1] < 0.1 and 0.0 < frozen[0] < frozen[1]
    assert sweep[1] / sweep[0] > frozen[1] / frozen[0]
    assert all(r is not None and r.method == "2d" for r in results)


def test_a_draw_equal_to_the_calibration_reproduces_the_nominal_speed(solved) -> None:
    """Warm-started from the nominal solution, a draw holding the calibration's own values is the
    same problem: its speed is the nominal one within the rod-speed tolerance (1e-3), in fewer
    map evaluations than the nominal cold solve."""
    out, results = solved
    draw = {"values": dict(MU), "sigma_zz_over_p": 1.058, "nonlocal": {"ngf": {"A": 0.327}}}
    ens = predict_draws("ngf", PARAMS, {"draws": [draw], "seed": 1}, RUNS, [fields()] * len(RUNS), 1, results,
                        cells_per_d=2.0, refined_cells_per_d=3.0, draws_cells_per_d=2.0)
    nominal = np.array([r.speed for r in results])
    assert np.allclose(ens.speed.values[0], nominal, rtol=2e-3)
    assert np.all(ens.iterations.values[0] < np.array([r.iterations for r in results]))
    assert np.all(np.isfinite(ens.speed_refined.values)) and ens.attrs["warm_start"] == 1


def test_plastic_solvers_take_their_own_draw_count() -> None:
    # The 2D plastic solves cost tens of CPU seconds each, NGF's seconds: the config sets their
    # draw counts apart (models.intruder_plastic_draws), and a config without the key gives every
    # model models.intruder_draws.
    from pipeline.common.config import load_config
    from pipeline.models.intruder import intruder_draws
    config = load_config("config/ci.yaml")
    models = config["models"]
    assert models["intruder_plastic_draws"] != models["intruder_draws"]
    for plastic in ("local_mu_i", "critical_state", "volume_averaged", "cosserat"):
        assert intruder_draws(config, plastic) == models["intruder_plastic_draws"]
    for other in ("ngf", "ngf_frozen", "local_mu_i_layer_sliding"):
        assert intruder_draws(config, other) == models["intruder_draws"]
    del models["intruder_plastic_draws"]
    assert intruder_draws(config, "critical_state") == models["intruder_draws"]


def test_a_scene_without_a_nominal_prediction_is_not_solved_for_draws_or_grid(solved) -> None:
    """Where the calibration's own parameters have no prediction (refused or not converged), the
    draws (u_input) and the finer grid (u_num) would be uncertainties of no score: that scene is
    left unsolved (NaN, refused = 1, not counted as a draw's failure), the others solved as
    before."""
    out, results = solved
    draw = {"values": dict(MU), "sigma_zz_over_p": 1.058, "nonlocal": {"ngf": {"A": 0.327}}}
    nominal = [results[0], None, results[2]]
    ens = predict_draws("ngf", PARAMS, {"draws": [draw], "seed": 1}, RUNS, [fields()] * len(RUNS), 1, nominal,
                        cells_per_d=2.0, refined_cells_per_d=3.0, draws_cells_per_d=2.0)
    assert np.isnan(ens.speed.values[0, 1]) and ens.refused.values[0, 1] == 1
    assert np.isnan(ens.speed_refined.values[1]) and json.loads(ens.attrs["failures"]) == {}
    # a scene the nominal solve has no speed for is not solved on the finer grid: no failure of it
    assert json.loads(ens.attrs["refined_failures"]) == {}
    assert np.all(np.isfinite(ens.speed.values[0, [0, 2]])) and np.all(np.isfinite(ens.speed_refined.values[[0, 2]]))


def test_draw_parts_cover_every_draw_once() -> None:
    assert draw_parts(8, 2) == [[0, 1, 2, 3], [4, 5, 6, 7]]
    assert sum(draw_parts(5, 3), []) == [0, 1, 2, 3, 4] and [len(p) for p in draw_parts(5, 3)] == [2, 2, 1]


def test_the_draws_in_parts_from_stored_states_equal_one_job(solved, tmp_path) -> None:
    """The split jobs (issue 45): the nominal states through their file, the draws in two parts and
    the grid study apart, merged, give the one-call file's speeds to the last bit (the same warm
    starts, the same solves), the draws in order and a scene without a nominal speed unsolved."""
    _, results = solved
    nominal = [results[0], None, results[2]]
    draws = [{"values": dict(MU, mu_s=mu_s), "sigma_zz_over_p": 1.058, "nonlocal": {"ngf": {"A": 0.327}}}
             for mu_s in (0.372, 0.374, 0.376)]
    ensemble = {"draws": draws, "seed": 7}
    one = predict_draws("ngf", PARAMS, ensemble, RUNS, [fields()] * len(RUNS), 3, nominal,
                        cells_per_d=2.0, refined_cells_per_d=3.0, draws_cells_per_d=2.0)
    path = tmp_path / "ngf.states.npz"
    save_states(nominal, path, "ngf", 2.0)
    warm, cells = load_states(path, "ngf", 3)
    assert cells == 2.0 and warm[1] is None
    assert all(np.array_equal(warm[0].state[k], nominal[0].state[k]) for k in nominal[0].state)
    scenes = scenes_of(RUNS, [fields()] * len(RUNS), PARAMS)
    parts = [solve_draws("ngf", PARAMS, ensemble, scenes, idx, warm, 2.0) for idx in reversed(draw_parts(3, 2))]
    split = merge("ngf", scenes, parts, solve_refined("ngf", PARAMS, scenes, warm, 3.0), 2.0, 7, True)
    assert list(split.draw.values) == [0, 1, 2]
    np.testing.assert_array_equal(split.speed.values, one.speed.values)
    np.testing.assert_array_equal(split.speed_refined.values, one.speed_refined.values)
    np.testing.assert_array_equal(split.refused.values, one.refused.values)
    assert split.attrs["draws_parts"] == 2 and split.attrs["draws_seed"] == 7
    with pytest.raises(ValueError, match="ngf.states.npz: states of ngf for 3 scenes, not of local_mu_i"):
        load_states(path, "local_mu_i", 3)


@pytest.mark.parametrize("part", ["0/2", "3/2", "1-2", "two"])
def test_a_bad_draws_part_is_refused_before_any_input_is_read(part, tmp_path, capsys) -> None:
    from pipeline.models.intruder_draws import main
    missing = tmp_path / "absent"
    with pytest.raises(SystemExit) as stop:
        main(["draws", "--config", str(missing), "--params", str(missing), "--model", "ngf", "--runs", str(missing),
              "--fields", str(missing), "--states", str(missing), "--out", str(tmp_path / "out.nc"),
              "--draws", str(missing), "--part", part])
    assert stop.value.code == 2
    assert f"--part {part!r}" in capsys.readouterr().err
    assert not (tmp_path / "out.nc").exists()
