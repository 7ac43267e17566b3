"""The verdict against the DEM it had (pipeline.scoring.claims_cost): claims compared, prefixes, costs."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from pipeline.scoring import claims as cl
from pipeline.scoring import claims_cost as cc
from pipeline.scoring import dem_variants as dv
from pipeline.scoring.verdict import DIFFERENCE_COLUMNS


def differences(rows: list[tuple[str, str, str, str, str]]) -> pd.DataFrame:
    """A model_differences.csv of (case, metric, model_a, model_b, claim) rows."""
    frame = pd.DataFrame([{"case": c, "metric": m, "model_a": a, "model_b": b, "claim": claim}
                          for c, m, a, b, claim in rows])
    return frame.reindex(columns=DIFFERENCE_COLUMNS)


FULL = differences([
    ("fast", "velocity_rmse_rel", "local_mu_i", "ngf", "b_better"),          # ngf better
    ("fast", "velocity_rmse_rel", "cosserat", "ngf", "a_better"),            # cosserat better
    ("fast", "velocity_rmse_rel", "cosserat", "local_mu_i", "a_better"),
    ("fast", "nu_rmse", "local_mu_i", "ngf", "cannot_tell_apart"),
    ("fast", "nu_rmse", "cosserat", "ngf", "cannot_tell_apart"),
    ("heavy", "velocity_rmse_rel", "local_mu_i", "ngf", "a_better"),
])


def test_claims_counted_right():
    variant = cl.claims(differences([
        ("fast", "velocity_rmse_rel", "local_mu_i", "ngf", "b_better"),      # confirmed
        ("fast", "velocity_rmse_rel", "cosserat", "ngf", "b_better"),        # contradicted
        ("fast", "velocity_rmse_rel", "cosserat", "local_mu_i", "cannot_tell_apart"),  # lost
        ("fast", "nu_rmse", "local_mu_i", "ngf", "a_better"),                # new
        # (fast, nu_rmse, cosserat, ngf) not scored: still cannot tell apart
        ("fast", "wall_slip_err", "local_mu_i", "ngf", "a_better"),          # a metric the full root has not: ignored
        ("heavy", "velocity_rmse_rel", "local_mu_i", "ngf", "a_better"),     # another case
    ]))
    counts = cl.count_claims(cl.claims(FULL), variant, "fast")
    assert counts == {"confirmed": 1, "lost": 1, "contradicted": 1, "new": 1, "still_cannot_tell_apart": 1,
                      "unscored": 0, "pairs": 5, "claims_full": 3}
    heavy = cl.count_claims(cl.claims(FULL), variant, "heavy")
    assert (heavy["confirmed"], heavy["claims_full"], heavy["pairs"]) == (1, 1, 1)


def test_a_pair_the_variant_cannot_score_is_lost_and_unscored():
    counts = cl.count_claims(cl.claims(FULL), {}, "fast")
    assert (counts["lost"], counts["unscored"], counts["confirmed"], counts["still_cannot_tell_apart"]) == (3, 3, 0, 2)


def test_pairs_are_turned_to_one_order():
    """A pair given b before a (as a variant's may be) is the same pair with its claim turned."""
    turned = cl.claims(differences([("fast", "velocity_rmse_rel", "ngf", "local_mu_i", "a_better")]))
    assert turned == {("fast", "velocity_rmse_rel", "local_mu_i", "ngf"): "b_better"}
    status = cl.compare_claims(cl.claims(FULL), turned)[("fast", "velocity_rmse_rel", "local_mu_i", "ngf")]
    assert status == ("confirmed", "b_better", False)


def test_an_infinite_score_tells_a_pair_apart():
    """model_differences.csv holds finite pairs only; the verdict's infinite scores (no creep where
    the DEM creeps) make the finite model better, two infinite ones cannot be told apart."""
    verdicts = pd.DataFrame([
        {"case": "fast", "metric": "log_velocity_rmse", "model": "ngf", "value": 0.3, "verdict": "best"},
        {"case": "fast", "metric": "log_velocity_rmse", "model": "cosserat", "value": 0.5, "verdict": "worse"},
        {"case": "fast", "metric": "log_velocity_rmse", "model": "local_mu_i", "value": math.inf, "verdict": "worse"},
        {"case": "fast", "metric": "log_velocity_rmse", "model": "critical_state", "value": math.inf, "verdict": "worse"},
        {"case": "fast", "metric": "log_velocity_rmse", "model": "volume_averaged", "value": math.nan,
         "verdict": "no_prediction"},
    ])
    pairs = differences([("fast", "log_velocity_rmse", "cosserat", "ngf", "b_better")])
    found = cl.claims(pairs, verdicts)
    assert found == {
        ("fast", "log_velocity_rmse", "cosserat", "ngf"): "b_better",
        ("fast", "log_velocity_rmse", "cosserat", "local_mu_i"): "a_better",
        ("fast", "log_velocity_rmse", "cosserat", "critical_state"): "a_better",
        ("fast", "log_velocity_rmse", "local_mu_i", "ngf"): "b_better",
        ("fast", "log_velocity_rmse", "critical_state", "ngf"): "b_better",
        ("fast", "log_velocity_rmse", "critical_state", "local_mu_i"): "cannot_tell_apart",
    }


@pytest.mark.parametrize("n, fraction, kept", [(40, 1 / 8, 5), (40, 1 / 4, 10), (40, 1 / 2, 20), (40, 1.0, 40),
                                               (39, 1 / 8, 5), (41, 1 / 2, 21), (10, 1 / 8, 2), (3, 1 / 8, 2),
                                               (2, 1 / 8, 2)])
def test_prefix_count_keeps_the_first_fraction_never_fewer_than_two(n, fraction, kept):
    assert dv.prefix_count(n, fraction) == kept


@pytest.mark.parametrize("n, fraction", [(1, 0.5), (40, 0.0), (40, 1.5)])
def test_prefix_count_refuses(n, fraction):
    with pytest.raises(ValueError):
        dv.prefix_count(n, fraction)


def run_record(**extra) -> dict:
    record = {"case": "fast", "run": "r2", "time_step": 1e-5, "steady_state_window": [0.1, 0.5],
              "production_window": [0.1, 0.505]}
    return record | extra


def test_prefix_of_takes_the_first_snapshots_of_the_steady_window():
    # Snapshots every 1000 steps (0.01 s) from 0 to 0.6 s: the window [0.1, 0.5] holds 41 of them.
    steps = np.arange(0, 60_001, 1000)
    record = run_record()
    assert dv.production_indices(steps, record).size == 41
    prefix = dv.prefix_of(steps, record, 1 / 8)
    assert (prefix.kept, prefix.total) == (6, 41)
    assert prefix.window == (0.1, pytest.approx(0.15))           # the 6th snapshot of the window
    assert prefix.kept_fraction == pytest.approx(6 / 41)
    tiny = dv.prefix_of(steps, record, 0.01)
    assert tiny.kept == 2 and tiny.window[1] == pytest.approx(0.11)
    whole = dv.prefix_of(steps, record, 1.0)
    assert whole.window == (0.1, 0.5) and whole.kept == whole.total == 41


def test_prefix_record_cuts_both_windows_and_says_so():
    record = run_record()
    cut = dv.prefix_record(record, dv.Prefix((0.1, 0.15), 6, 41), 0.125)
    assert cut["steady_state_window"] == [0.1, 0.15] and cut["production_window"] == [0.1, 0.15]
    assert cut["claims_cost"]["snapshots_kept"] == 6 and record["steady_state_window"] == [0.1, 0.5]
    whole = dv.prefix_record(record, dv.Prefix((0.1, 0.5), 41, 41), 1.0)
    assert whole["production_window"] == [0.1, 0.505]


def cost_record(run: str, shared: str | None = None, window_chunks: int = 0) -> dict:
    return {"case": "fast", "run": run, "mpi_ranks": 2, "particle_count": 100,
            "wall_seconds_by_stage": {"fill": 100.0, "shear": 500.0, "production": 1200.0},
            "steps_by_stage": {"fill": 1000, "shear": 5000, "production": 12000},
            "production_chunks": 4, "production_chunks_from_steady_window": window_chunks,
            "shared_fill": {"run": shared, "steps": 10, "wall_seconds": 1.0} if shared else None}


def test_cost_scales_the_production_and_pays_the_rest_in_full():
    cost = dv.run_cost(cost_record("r1"))
    assert (cost.fixed_core_seconds, cost.production_core_seconds) == (1200.0, 2400.0)
    assert (cost.fixed_particle_steps, cost.production_particle_steps) == (6e5, 1.2e6)
    quarter = dv.variant_cost([cost], {"r1": 0.25}, {})
    assert quarter.core_hours == pytest.approx((1200.0 + 0.25 * 2400.0) / 3600.0)
    assert quarter.particle_steps == pytest.approx(6e5 + 0.25 * 1.2e6)
    assert dv.variant_cost([cost], {}, {}).core_hours == 0.0  # a run not kept costs nothing


def test_a_shared_fill_is_paid_once_and_the_window_floor():
    costs = [dv.run_cost(cost_record("D4-r1", "fill-sheared-r1", 3)), dv.run_cost(cost_record("D7-r1", "fill-sheared-r1", 3)),
             dv.run_cost(cost_record("D4-r2", "fill-sheared-r2", 3))]
    bed = dv.shared_cost({"mpi_ranks": 2, "particle_count": 50, "wall_seconds_by_stage": {"fill": 30.0, "shear": 70.0},
                          "steps_by_stage": {"fill": 100, "shear": 300}})
    assert bed == (200.0, 20000.0)
    shared = {"fill-sheared-r1": bed, "fill-sheared-r2": bed}
    one = dv.variant_cost(costs, {"D4-r1": 0.5, "D7-r1": 0.5}, shared)
    assert one.core_hours == pytest.approx((2 * (1200.0 + 1200.0) + 200.0) / 3600.0)
    # Three of the four production chunks are the steady-state test's window: at least 3/4 is paid.
    assert one.core_hours_with_window == pytest.approx((2 * (1200.0 + 0.75 * 2400.0) + 200.0) / 3600.0)
    both = dv.variant_cost(costs, {"D4-r1": 1.0, "D7-r1": 1.0, "D4-r2": 1.0}, shared)
    assert both.core_hours == pytest.approx((3 * 3600.0 + 400.0) / 3600.0)


def test_replicas_and_variants():
    assert dv.replica_of("r3") == 3 and dv.replica_of("D4-control-r2") == 2 and dv.replica_of("D7-F0.3-r1") == 1
    with pytest.raises(ValueError):
        dv.replica_of("fill")
    assert dv.replica_subsets(1) == []
    assert dv.replica_subsets(2) == [(2,), (1,)]
    assert dv.replica_subsets(3) == [(2, 3), (1, 3), (1, 2), (1,)]
    assert dv.replica_subsets(3, min_replicas=2) == [(2, 3), (1, 3), (1, 2)]
    names = [v.name for v in dv.variants(dv.FRACTIONS, 2)]
    assert names == ["full", "prefix 1/8", "prefix 1/4", "prefix 1/2", "replicas r2", "replicas r1"]
    assert dv.Variant(1.0, (1, 2)).kept([1, 2]) is None          # all of a two-replica case: no variant
    assert dv.Variant(1.0, (2, 3)).kept([1]) is None             # none of a one-replica case
    assert dv.Variant(1.0, (1, 3)).kept([1, 2, 3]) == [1, 3]
    assert dv.Variant(0.5, (1, 2)).kept([1, 2]) == [1, 2]
    assert dv.Variant().kept([1]) == [1]


def test_the_rods_speed_over_a_prefix():
    """A rod at 1e-4 m/s for the first half of its production, 3e-4 m/s after."""
    t = np.linspace(1.0, 2.0, 201)
    x = np.where(t < 1.5, 1e-4 * (t - 1.0), 0.5e-4 + 3e-4 * (t - 1.5))
    series = pd.DataFrame({"time": t, "x": x})
    record = {"run": "D4-r1", "production_window": [1.0, 2.0],
              "intruder": {"speed": 2e-4, "speed_err": 1e-6, "arrested": False, "control": False}}
    half, note = dv.prefix_rod(record, series, 0.5, 0.0)
    assert half["intruder"]["speed"] == pytest.approx(1e-4) and not half["intruder"]["arrested"] and note == ""
    assert record["intruder"]["speed"] == 2e-4  # the root's record is not touched
    whole, _ = dv.prefix_rod(record, series, 1.0, 0.0)
    assert whole["intruder"]["speed"] == pytest.approx(2e-4)
    short, note = dv.prefix_rod(record, series, 0.06, 0.0)  # 13 samples: 4 blocks
    assert short["intruder"]["speed_blocks"] == 4 and "4 blocks of 13 samples" in note
    _, note = dv.prefix_rod(record, series, 0.02, 0.0)
    assert note.endswith("left out")
    slow, _ = dv.prefix_rod(record, series, 0.5, 2e-4)  # below the rest speed: at rest
    assert slow["intruder"]["arrested"]


def test_reframe_puts_a_replica_on_the_first_ones_nodes():
    z = np.linspace(0.0, 0.04, 81)
    ref = xr.Dataset({"u_x": ("z", z.copy())}, coords={"z": z},
                     attrs={"z_top_contact_plane": 0.039, "z_bottom_contact_plane": 0.001, "z_top_wall": 0.0394, "d": 0.002})
    other_z = np.linspace(0.0003, 0.0403, 81)  # its own grid, its walls 0.0002 m higher
    other = xr.Dataset({"u_x": ("z", 0.0392 - other_z)}, coords={"z": other_z},  # its depth below its own top plane
                       attrs={"z_top_contact_plane": 0.0392, "z_bottom_contact_plane": 0.0012, "z_top_wall": 0.0396})
    moved = cc.reframe(other, ref)
    assert np.array_equal(moved.z.values, z)
    assert moved.attrs["z_top_contact_plane"] == pytest.approx(0.039)
    assert moved.attrs["z_bottom_contact_plane"] == pytest.approx(0.001)
    assert moved.attrs["z_top_wall"] == pytest.approx(0.0394)
    # Its profile keeps its place below its top plane, now the first one's; outside its grid, NaN.
    assert np.isnan(moved.u_x.values[0])
    assert np.allclose(moved.u_x.values[1:], 0.039 - z[1:])


def test_the_figure_draws_every_case():
    table = pd.DataFrame([
        {"case": "fast", "variant": "full", "fraction": 1.0, "replicas": 2, "dem_core_hours": 1.0, "confirmed": 5,
         "lost": 0, "contradicted": 0, "new": 0, "claims_full": 5},
        {"case": "fast", "variant": "prefix 1/8", "fraction": 0.125, "replicas": 2, "dem_core_hours": 0.4,
         "confirmed": 3, "lost": 1, "contradicted": 1, "new": 2, "claims_full": 5},
        {"case": "intruder", "variant": "replicas r1", "fraction": 1.0, "replicas": 1, "dem_core_hours": 0.2,
         "confirmed": 1, "lost": 1, "contradicted": 0, "new": 0, "claims_full": 2},
    ])
    fig = cc.claims_figure(table)
    assert [ax.get_title() for ax in fig.axes] == ["fast", "intruder"]


def test_the_report_section_reads_the_table(tmp_path):
    from pipeline.report.claims_section import claims_section
    from pipeline.report.html import figure_html

    class Figures:
        def add(self, name, fig, caption):
            return figure_html(fig, caption, vector=True)

    assert claims_section(tmp_path, Figures()) == ""
    (tmp_path / "validation").mkdir()
    rows = []
    for variant, hours, confirmed, contradicted in (("full", 2.0, 4, 0), ("prefix 1/8", 0.9, 2, 1), ("prefix 1/2", 1.3, 4, 0)):
        rows.append({"case": "fast", "variant": variant, "fraction": 1.0, "replicas": 2, "dem_core_hours": hours,
                     "confirmed": confirmed, "lost": 4 - confirmed - contradicted, "contradicted": contradicted, "new": 0,
                     "claims_full": 4, "unscored": 0, "dem_core_hours_full": 2.0})
    pd.DataFrame(rows).to_csv(tmp_path / "validation" / "claims_cost.csv", index=False)
    pd.DataFrame([{"case": "fast", "variant": "prefix 1/8", "metric": "nu_rmse", "model_a": "cosserat", "model_b": "ngf",
                   "claim_full": "a_better", "claim_variant": "b_better", "status": "contradicted"}]).to_csv(
        tmp_path / "validation" / "claims_cost_pairs.csv", index=False)
    text = claims_section(tmp_path, Figures())
    assert "The verdict against the DEM it had" in text and "<svg" in text
    assert "every one stands with prefix 1/2 (1.3 core-hours, 65%)" in text
    assert "the cheapest, prefix 1/8 (45%), confirms 2, loses 1, contradicts 1 and adds 0" in text
    assert "Contradicted claims" in text and "models fixed at the full calibration" in text


def test_the_rods_travel_and_steadiness_follow_the_prefix():
    """A record with the rod's halves (issue 55) gets them, its travel and its steadiness over the prefix."""
    t = np.linspace(1.0, 2.0, 201)
    series = pd.DataFrame({"time": t, "x": 1e-4 * (t - 1.0)})
    record = {"run": "D4-r1", "d": 1e-5, "production_window": [1.0, 2.0],
              "intruder": {"speed": 1e-4, "speed_err": 1e-6, "arrested": False, "control": False, "halves": None,
                           "window": [1.0, 2.0], "displacement": 1e-4, "travel_over_d": 10.0}}
    half, _ = dv.prefix_rod(record, series, 0.5, 0.0)
    rod = half["intruder"]
    assert rod["displacement"] == pytest.approx(0.5e-4) and rod["travel_over_d"] == pytest.approx(5.0)
    assert rod["halves"]["first"] == pytest.approx(1e-4) and rod["halves"]["first_duration"] == pytest.approx(0.25)
    assert set(rod["steadiness"]) == {"steady", "rod_class", "reason", "halves_z_normal"}
    short, _ = dv.prefix_rod(record, series, 0.03, 0.0)  # 7 samples: too few for the halves; 0.3 d of travel
    assert short["intruder"]["halves"] is None and short["intruder"]["steadiness"]["rod_class"] == "unsteady"
