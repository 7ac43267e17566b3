"""Is a rod's speed steady? Its travel over the production and the production's halves
(pipeline.scoring.rod_steadiness), and the intruder score on steady rods only (synthetic run.json
records, no LIGGGHTS)."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from pipeline.dem.rod_speed import creep_speed, production_halves
from pipeline.scoring import rod_steadiness as rs
from pipeline.scoring.intruder_scores import METRIC, METRIC_UNSTEADY, score_intruder

D = 0.002


def record(travel_over_d: float = 2.0, first: float = 1.0, second: float = 1.0, err: float = 0.05,
           arrested: bool = False, window: tuple[float, float] = (1.0, 3.0), run: str = "D5-r1", depth: float = 5.0,
           control: bool = False, halves: bool = True) -> dict:
    """A run record whose rod travels ``travel_over_d`` d over ``window``; its halves' speeds
    ``first`` and ``second`` are given as multiples of the mean speed, each with the error ``err`` of it."""
    duration = window[1] - window[0]
    speed = travel_over_d * D / duration
    rod = {"control": control, "force_sweep": False, "depth_target_over_d": depth, "depth_over_d": depth + 0.1,
           "push_over_yield": 0.5, "force": 1e-3, "speed": speed, "speed_err": err * speed, "arrested": arrested,
           "displacement": travel_over_d * D, "window": list(window),
           "halves": ({"first": first * speed, "first_err": err * speed, "second": second * speed,
                       "second_err": err * speed, "blocks": 8} if halves else None)}
    return {"case": "intruder", "run": run, "d": D, "intruder": rod}


def test_travel_is_the_recorded_displacement_and_each_half_its_speed_times_its_duration() -> None:
    """A rod at 1 mm/s over a 2 s window travels 1 d; its halves (1.2 and 0.8 mm/s over 1 s each,
    an old record without their durations) 0.6 and 0.4 d."""
    rec = record(travel_over_d=1.0, first=1.2, second=0.8)
    assert rec["intruder"]["speed"] == pytest.approx(1e-3)
    travel = rs.rod_travel(rec)
    assert travel["travel_over_d"] == pytest.approx(1.0)
    assert travel["travel_first_half_over_d"] == pytest.approx(0.6)
    assert travel["travel_second_half_over_d"] == pytest.approx(0.4)
    assert travel["travel_source"] == "position series"
    # A record without the displacement: the speed times the window's duration, the same travel.
    del rec["intruder"]["displacement"]
    again = rs.rod_travel(rec)
    assert again["travel_over_d"] == pytest.approx(1.0) and again["travel_source"] == "speed x window"


def test_the_halves_durations_make_their_travels_add_up_to_the_production_s() -> None:
    """On a series of uneven samples, :func:`split_durations` cuts where production_halves does, so
    each half's speed times its duration is its displacement and the two add up to the window's."""
    rng = np.random.default_rng(3)
    time = np.sort(rng.uniform(1.0, 2.0, 161))
    x = 0.003 * (time - 1.0) ** 0.7 + 1e-5 * rng.standard_normal(time.size)
    whole = creep_speed(time, x)
    halves = production_halves(time, x)
    halves["first_duration"], halves["second_duration"] = rs.split_durations(time)
    rec = {"d": D, "intruder": {"displacement": whole.displacement, "window": [time[0], time[-1]], "halves": halves}}
    travel = rs.rod_travel(rec)
    assert travel["travel_over_d"] == pytest.approx(whole.displacement / D)
    assert travel["travel_first_half_over_d"] + travel["travel_second_half_over_d"] == pytest.approx(
        travel["travel_over_d"], rel=1e-12)


@pytest.mark.parametrize(("rec", "steady", "kind", "words"), [
    (record(travel_over_d=2.0), True, "steady", "halves agree"),
    (record(travel_over_d=0.4), False, "unsteady", "travel 0.4 d < 1 d"),
    (record(travel_over_d=2.0, first=1.3, second=0.7), False, "unsteady", "halves differ"),
    (record(travel_over_d=0.4, first=1.3, second=0.7), False, "unsteady", "; halves differ"),
    (record(travel_over_d=2.0, first=1.05, second=0.95), True, "steady", "halves agree"),
    (record(travel_over_d=-1.5), True, "steady", "travel -1.5 d"),
    (record(travel_over_d=2.0, halves=False), True, "steady", "travel alone"),
    (record(travel_over_d=0.01, arrested=True), False, "at_rest", "at rest"),
    (record(travel_over_d=5.0, arrested=True), False, "at_rest", "at rest"),
])
def test_the_rule_needs_a_grain_of_travel_and_halves_that_agree(rec: dict, steady: bool, kind: str, words: str) -> None:
    """Travel above and below a grain, halves agreeing (z 1.4) and not (z 8.5), both failing, a rod
    moving backwards (its distance counts), halves not measured, and rods at rest (their own class,
    whatever they travelled)."""
    verdict = rs.classify(rec)
    assert verdict["steady"] is steady and rs.is_steady(rec) is steady
    assert verdict["rod_class"] == kind and words in verdict["reason"]


def test_halves_z_is_the_normal_deviate_of_the_student_t() -> None:
    """Halves 1.1 and 0.9 of U, each 5 % of U: t = -2.83 with 14 degrees of freedom, whose normal
    equivalent is smaller in size (-2.58) but still beyond 2."""
    z, dof, z_normal = rs.halves_deviate(record(first=1.1, second=0.9)["intruder"]["halves"])
    assert z == pytest.approx(-0.2 / math.hypot(0.05, 0.05)) and dof == pytest.approx(14.0)
    assert -z > -z_normal > 2.0
    halves = dict(record()["intruder"]["halves"])
    del halves["blocks"]
    assert rs.halves_deviate(halves)[2] == rs.halves_deviate(halves)[0]
    assert all(math.isnan(v) for v in rs.halves_deviate(None))


def test_a_record_without_what_the_travel_needs_is_unknown() -> None:
    rec = {"intruder": {"control": False, "arrested": False, "speed": 1e-3}}
    verdict = rs.classify(rec)
    assert verdict["rod_class"] == "unknown" and not verdict["steady"]


def test_the_csv_lists_every_rod_with_its_travel_halves_and_reason(tmp_path) -> None:
    runs = [record(travel_over_d=0.3, run="D7-r1", depth=7.0), record(travel_over_d=3.0, run="D5-r1"),
            record(travel_over_d=0.0, arrested=True, control=True, run="D5-control-r1")]
    paths = []
    for r in runs:
        path = tmp_path / r["run"] / "run.json"
        path.parent.mkdir()
        path.write_text(json.dumps(r))
        paths.append(str(path))
    out = tmp_path / "validation" / "rod_steadiness.csv"
    assert rs.main(["--intruder-runs", *paths, "--out", str(out)]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == rs.COLUMNS
    assert list(table.run) == ["D5-control-r1", "D5-r1", "D7-r1"]
    assert list(table.rod_class) == ["at_rest", "steady", "unsteady"]
    assert list(table.steady) == [False, True, False]
    assert table.travel_over_d.tolist() == pytest.approx([0.0, 3.0, 0.3])
    assert table.push_over_yield.tolist() == [0.5] * 3
    assert table.first_half_speed.tolist() == pytest.approx([r["intruder"]["halves"]["first"] for r in
                                                             (runs[2], runs[1], runs[0])])
    # No runs: the columns and no row.
    assert rs.main(["--intruder-runs", "--out", str(out)]) == 0
    assert list(pd.read_csv(out).columns) == rs.COLUMNS and len(pd.read_csv(out)) == 0


def _model_file(tmp_path, depths, speeds):
    path = tmp_path / "ngf.nc"
    xr.Dataset({"speed": ("depth_over_d", np.asarray(speeds, dtype=float))},
               coords={"depth_over_d": np.asarray(depths, dtype=float)},
               attrs={"n_grid": 100, "solve_seconds": 1.0}).to_netcdf(path)
    return path


def test_the_depth_sweep_score_uses_steady_rods_and_scores_the_others_apart(tmp_path) -> None:
    """D5: two steady replicas; D7: one steady and one unsteady; D9: one unsteady (no steady rod:
    no point of the steady score). The steady score covers D5 and D7 with the steady rods' means;
    the unsteady one D7 and D9 with the unsteady rods'."""
    runs = [record(travel_over_d=2.0, run="D5-r1", depth=5.0), record(travel_over_d=4.0, run="D5-r2", depth=5.0),
            record(travel_over_d=2.0, run="D7-r1", depth=7.0), record(travel_over_d=0.5, run="D7-r2", depth=7.0),
            record(travel_over_d=0.2, run="D9-r1", depth=9.0),
            record(travel_over_d=0.0, arrested=True, control=True, run="D5-control-r1")]
    speed = {r["run"]: r["intruder"]["speed"] for r in runs}
    model = {5.1: 1e-3, 7.1: 1e-4, 9.1: 1e-5}
    rows, samples = score_intruder(runs, {"ngf": _model_file(tmp_path, list(model), list(model.values()))})
    by_metric = {row["metric"]: row for row in rows}
    assert set(by_metric) == {METRIC, METRIC_UNSTEADY}
    assert by_metric[METRIC]["points"] == "D5 D7" and by_metric[METRIC_UNSTEADY]["points"] == "D7 D9"
    steady_terms = [math.log10(1e-3 / np.mean([speed["D5-r1"], speed["D5-r2"]])), math.log10(1e-4 / speed["D7-r1"])]
    unsteady_terms = [math.log10(1e-4 / speed["D7-r2"]), math.log10(1e-5 / speed["D9-r1"])]
    assert by_metric[METRIC]["value"] == pytest.approx(math.sqrt(np.mean(np.square(steady_terms))))
    assert by_metric[METRIC_UNSTEADY]["value"] == pytest.approx(math.sqrt(np.mean(np.square(unsteady_terms))))
    assert set(samples) == {("intruder", "ngf", METRIC), ("intruder", "ngf", METRIC_UNSTEADY)}


def test_no_steady_rod_leaves_only_the_unsteady_score(tmp_path) -> None:
    runs = [record(travel_over_d=0.3, run="D5-r1", depth=5.0), record(travel_over_d=0.5, run="D7-r1", depth=7.0)]
    rows, _ = score_intruder(runs, {"ngf": _model_file(tmp_path, [5.1, 7.1], [1e-3, 1e-4])})
    assert [row["metric"] for row in rows] == [METRIC_UNSTEADY]
    assert rows[0]["points"] == "D5 D7"
