"""How far down the creep is resolved (pipeline.scoring.creep_resolution), on exponential creep
profiles of known errors."""
from __future__ import annotations

import math

import numpy as np
import xarray as xr

from pipeline.scoring.creep_resolution import DecadesTargets, replica_mean_resolution, target_reach


def creep_fields(tmp_path, case: str, stated: float, lengths: tuple[float, ...]) -> list:
    """Replica fields files of a creeping bed, one per decay length ``lengths`` (in d): u/V =
    0.5 exp(-depth / length) below the top contact plane (20 d of bed, contact planes at 0 and
    0.04 m; replicas of different lengths stand for frozen packings, apart more the deeper),
    stated errors ``stated`` V everywhere."""
    d, v = 0.002, 0.1
    z = np.linspace(0.0, 0.04, 161)
    depth = (0.04 - z) / d
    folder = tmp_path / "fields" / case
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("r*.nc"):
        old.unlink()
    paths = []
    for k, length in enumerate(lengths):
        u = 0.5 * v * np.exp(-depth / length)
        err = np.full(z.size, stated * v)
        ds = xr.Dataset({"u_x": ("z", u), "u_x_err": ("z", 10 * err), "u_x_disp": ("z", u), "u_x_disp_err": ("z", err)},
                        coords={"z": z}, attrs={"d": d, "wall_speed": v, "gravity": 9.81, "z_top_contact_plane": 0.04,
                                                "z_bottom_contact_plane": 0.0, "z_top_wall": 0.0408, "z_bottom_wall": -0.0008})
        paths.append(folder / f"r{k + 1}.nc")
        ds.to_netcdf(paths[-1])
    return paths
def test_replica_mean_resolution_names_what_stops_it(tmp_path) -> None:
    """Exponential creep, u/V = 0.5 exp(-depth / 1.5 d), inside the 1 d wall margins (1-19 d), three replicas:
    - errors of 1e-9 V, replicas alike: resolved to the margin, over the whole bed's
      log10(exp(18 / 1.5)) = 5.21 decades (``wall margin``);
    - errors of 1e-4 V: resolved while u > 2e-4 / sqrt(3) V, to 12.6 d below the top:
      log10(exp(11.6 / 1.5)) = 3.35 decades (``stated errors``);
    - errors of 1e-9 V, decay lengths 1.0, 1.5 and 2.5 d: the replicas part with depth until
      their scatter stops the walk (``replica scatter``) above the margin."""
    table = {case: replica_mean_resolution(creep_fields(tmp_path, case, stated, lengths))[0]
             for case, stated, lengths in (("margin", 1e-9, (1.5,) * 3), ("stated", 1e-4, (1.5,) * 3),
                                           ("scatter", 1e-9, (1.0, 1.5, 2.5)))}
    assert table["margin"]["limited_by"] == "wall margin"
    assert abs(table["margin"]["decades_best"] - 18.0 / 1.5 / math.log(10)) < 0.01
    assert table["margin"]["decades_in_bed"] == table["margin"]["decades_best"]
    assert abs(table["margin"]["deepest_interior_over_d"] - 19.0) < 0.01
    assert table["stated"]["limited_by"] == "stated errors"
    expected = math.log(0.5 / (2e-4 / math.sqrt(3))) / math.log(10) - 1.0 / 1.5 / math.log(10)  # from 1 d down
    assert abs(table["stated"]["decades_best"] - expected) < 0.125 / 1.5 / math.log(10) + 1e-9  # one 0.125 d grid step
    assert table["scatter"]["limited_by"] == "replica scatter"
    assert 0 < table["scatter"]["decades_best"] < table["scatter"]["decades_in_bed"]


def test_target_reach_on_exponential_creep() -> None:
    """u = exp(-z / 1.5) with a uniform error e: 3 decades lie 3 x 1.5 ln 10 = 10.36 deep (to the
    grid step), and the deepest point of the stretch asks the most, 2 e / u there."""
    z = np.arange(0.0, 20.0, 0.125)
    u = np.exp(-z / 1.5)
    e = 1e-4
    reach = target_reach(u, np.full(z.size, e), z, 3.0)
    assert 3 * 1.5 * math.log(10) <= reach["target_depth_over_d"] < 3 * 1.5 * math.log(10) + 0.125
    assert math.isclose(reach["error_over_needed"], 2 * e / math.exp(-reach["target_depth_over_d"] / 1.5), rel_tol=1e-12)
    # Read in either direction: the walk starts at the fastest point.
    flipped = target_reach(u[::-1], np.full(z.size, e), z[::-1], 3.0)
    assert flipped == reach
    # 20 d of this bed span 5.8 decades: 6 are out of its reach.
    assert all(math.isnan(v) for v in target_reach(u, np.full(z.size, e), z, 6.0).values())


def test_the_replicas_asked_for_reach_the_target_and_one_fewer_does_not(tmp_path) -> None:
    """Alike replicas (no scatter) of stated error 9e-5 V: the mean's error falls as 1 / sqrt(n),
    so the count the table asks for meets the 3.5-decade target and one replica fewer falls short
    (the count is the least that does, not a rough scale)."""
    targets = DecadesTargets("calib", calibration=4.0, held_out=3.5)
    three = replica_mean_resolution(creep_fields(tmp_path, "held", 9e-5, (1.5,) * 3), targets)[0]
    assert three["role"] == "held_out" and three["decades_target"] == 3.5
    assert not three["target_met"] and three["error_over_needed"] > 1
    needed = three["replicas_for_target"]
    assert needed == math.ceil(3 * three["error_over_needed"] ** 2)
    enough = replica_mean_resolution(creep_fields(tmp_path, "held", 9e-5, (1.5,) * needed), targets)[0]
    fewer = replica_mean_resolution(creep_fields(tmp_path, "held", 9e-5, (1.5,) * (needed - 1)), targets)[0]
    assert enough["target_met"] and enough["decades_best"] >= 3.5 and enough["error_over_needed"] < 1
    assert not fewer["target_met"] and fewer["error_over_needed"] > 1
    assert enough["replicas_for_target"] == needed  # met: no more than it has


def test_a_bed_too_shallow_for_its_target_asks_for_no_replica_count(tmp_path) -> None:
    """The calibration case's target of 6 decades is beyond 18 d of u/V = 0.5 exp(-depth / 1.5 d)
    (5.21 decades inside the margins): resolved to the wall margin, never met, no replica count."""
    targets = DecadesTargets("calib", calibration=6.0, held_out=3.5)
    row = replica_mean_resolution(creep_fields(tmp_path, "calib", 1e-9, (1.5,) * 3), targets)[0]
    assert row["role"] == "calibration" and row["limited_by"] == "wall margin"
    assert not row["target_met"] and math.isnan(row["target_depth_over_d"]) and math.isnan(row["replicas_for_target"])


def test_targets_come_from_the_config_or_not_at_all() -> None:
    config = {"calibration": {"nonlocal_case": "shear_gravity"}, "scoring": {"creep_decades": {"calibration": 4, "held_out": 3.5}}}
    targets = DecadesTargets.from_config(config)
    assert targets.of("shear_gravity") == ("calibration", 4.0) and targets.of("heavy") == ("held_out", 3.5)
    assert DecadesTargets.from_config({"calibration": {"nonlocal_case": "shear_gravity"}, "scoring": {}}) is None
