"""Config validation names the bad key; seeds are deterministic (pipeline.common.config, pipeline.common.runs)."""
from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from pipeline.common.config import (
    ConfigError,
    case_production,
    dem_runs,
    derived_seed,
    fill_owner_run,
    fill_physics,
    liggghts_seed,
    load_config,
    predecessor_state,
    run_config,
    run_state,
    shared_fill_ids,
    shared_fill_of,
    validate_config,
)
from pipeline.common.runs import _is_prime


@pytest.fixture
def config() -> dict:
    return load_config("config/ci.yaml")


SHIPPED_CONFIGS = sorted(str(p) for p in (*Path("config").glob("*.yaml"), *Path("config/studies").glob("*.yaml"))
                         if p.name != "schema.yaml")


@pytest.mark.parametrize("path", SHIPPED_CONFIGS)
def test_every_shipped_config_is_valid(path: str) -> None:
    # The studies are full configs run as they are (config/studies/*.yaml): one that no longer
    # validates would be found only when its hours of DEM were due.
    assert load_config(path)["cases"]


def test_the_shipped_configs_include_the_default_the_ci_and_the_studies() -> None:
    assert {"config/config.yaml", "config/ci.yaml", "config/studies/damping_off_liggghts_seed2.yaml"} <= set(SHIPPED_CONFIGS)


@pytest.mark.parametrize(
    ("mutate", "key"),
    [
        (lambda c: c["material"].__setitem__("friction", "half"), "material.friction"),
        (lambda c: c["material"].__setitem__("dt_over_contact_time", 0.2), "material.dt_over_contact_time"),
        (lambda c: c["cases"]["rheometer"].__setitem__("n_grains", 10), "cases.rheometer.n_grains"),
        (lambda c: c["cases"]["rheometer"].__setitem__("gravity", 9.81), "cases.rheometer.gravity"),
        (lambda c: c["dem"].__setitem__("mpi_ranks", 0), "dem.mpi_ranks"),
        (lambda c: c["dem"].__setitem__("unknown_key", 1), "dem"),
        # Replicas never share a fill: only the rheometer's states may.
        (lambda c: c["cases"]["shear_gravity"].__setitem__("shared_fill", True), "cases.shear_gravity"),
        (lambda c: c.__setitem__("seed", -1), "seed"),
    ],
)
def test_invalid_value_is_reported_with_its_key(config: dict, mutate, key: str) -> None:
    bad = copy.deepcopy(config)
    mutate(bad)
    with pytest.raises(ConfigError) as err:
        validate_config(bad, "my.yaml")
    assert f"my.yaml: {key}:" in str(err.value)


def test_design_overlap_must_stay_below_hard_bound(config: dict) -> None:
    bad = copy.deepcopy(config)
    bad["material"]["design_overlap"] = bad["material"]["max_overlap"]
    with pytest.raises(ConfigError, match="design_overlap"):
        validate_config(bad, "x.yaml")


def test_missing_and_malformed_files(tmp_path) -> None:
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "nope.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("seed: [1, 2\n")
    with pytest.raises(ConfigError, match=r"broken.yaml:2: not valid YAML"):
        load_config(broken)


def test_runs_and_seeds_are_deterministic(config: dict) -> None:
    runs = dem_runs(config)
    rheo = config["cases"]["rheometer"]
    n_rheo = (len(rheo["inertial_numbers"]) + len(rheo.get("extra_states", []))) * rheo["replicas"]
    # Intruder runs: one per depth and replica, plus the controls (tests/pipeline/test_intruder_run.py).
    n_intruder = sum(1 for case, _ in runs if case == "intruder")
    n_planar = 0
    for name, case in config["cases"].items():
        if name != "rheometer" and case["geometry"] == "planar_shear":
            study = case.get("size_study", {})
            n_planar += case["replicas"] + len(study.get("cells", [])) * study.get("replicas", 0)
    assert len(runs) == n_rheo + n_planar + n_intruder
    assert run_state("I0.03-P200-r1") == pytest.approx((0.03, 200.0))
    with pytest.raises(ValueError, match="not a rheometer run id"):
        run_state("r1")
    assert derived_seed(7, "a", "b") == derived_seed(7, "a", "b") != derived_seed(8, "a", "b")
    seed = liggghts_seed(7, "insert")
    assert seed > 10000 and _is_prime(seed)


def test_schema_is_yaml_loadable() -> None:
    with open("config/schema.yaml") as fh:
        assert yaml.safe_load(fh)["type"] == "object"


def test_numbers_in_exponent_form_read_as_numbers(tmp_path) -> None:
    # PyYAML (YAML 1.1) reads 1e-05 as a string; the workflow writes per-run configs as JSON, which
    # spells small numbers that way, and a user may too.
    import yaml as _yaml

    from pipeline.common.config import _Loader

    assert _yaml.load("a: 1e-05\nb: 2.5E+3\nc: 1_000\nd: e5", Loader=_Loader) == {"a": 1e-05, "b": 2500.0, "c": 1000, "d": "e5"}


def test_a_case_produces_with_its_own_targets_and_cap(config: dict) -> None:
    own = copy.deepcopy(config)
    own["cases"]["rheometer"] |= {"precision": {"mu": 0.004}, "production_strain": 3.0}
    validate_config(own, "own.yaml")
    dem = own["dem"]
    rheometer = case_production(dem, own["cases"]["rheometer"])
    # Its targets replace the global set (no u_x, nu target left); the minimum strain and whether
    # the steady window counts are global.
    own_targets = {"min_production_strain": dem["precision"]["min_production_strain"], "mu": 0.004}
    own_targets |= {"steady_window_is_production": dem["precision"]["steady_window_is_production"]}
    assert rheometer["precision"] == own_targets
    assert rheometer["production_strain"] == 3.0
    # The dumps stay as dense in strain as every other case's.
    assert rheometer["snapshot_strain"] == dem["production_strain"]
    other = case_production(dem, own["cases"]["shear_gravity"])
    assert other["precision"] == dem["precision"] and other["production_strain"] == dem["production_strain"]


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda c: c["dem"].pop("precision"), "cases.rheometer.precision: its targets replace dem.precision's"),
        (lambda c: c["cases"]["rheometer"].__setitem__("production_strain", 0.1), "cases.rheometer.production_strain (0.1) is below"),
        (lambda c: c["cases"]["rheometer"]["precision"].__setitem__("log_speed", 0.1), "cases.rheometer.precision: log_speed and"),
    ],
)
def test_case_targets_that_cannot_work_are_refused(config: dict, mutate, message: str) -> None:
    bad = copy.deepcopy(config)
    bad["cases"]["rheometer"]["precision"] = {"mu": 0.004}
    mutate(bad)
    with pytest.raises(ConfigError) as err:
        validate_config(bad, "bad.yaml")
    assert message in str(err.value)


def test_a_rheometer_replica_shares_one_fill_and_replicas_do_not(config: dict) -> None:
    config["cases"]["rheometer"]["replicas"] = 2
    rheometer = config["cases"]["rheometer"]
    assert shared_fill_ids("rheometer", rheometer) == ["fill-r1", "fill-r2"]
    states = [r for c, r in dem_runs(config) if c == "rheometer"]
    assert {shared_fill_of("rheometer", rheometer, r) for r in states if r.endswith("-r2")} == {"fill-r2"}
    assert shared_fill_ids("shear_gravity", config["cases"]["shear_gravity"]) == []
    assert shared_fill_of("shear_gravity", config["cases"]["shear_gravity"], "r1") is None
    # The replicas' fills have seeds of their own, none a state's.
    seeds = {fill: fill_physics(config, "rheometer", fill)["seed"] for fill in ("fill-r1", "fill-r2")}
    assert len(set(seeds.values())) == 2
    assert not set(seeds.values()) & {derived_seed(config["seed"], "rheometer", r) for r in states}
    # The fill reads its replica's first state's config; appending a state changes neither it
    # nor what the fill depends on.
    owner = fill_owner_run("rheometer", rheometer, "fill-r1")
    before = run_config(config, "rheometer", owner), fill_physics(config, "rheometer", "fill-r1")
    rheometer["extra_states"].append({"inertial_number": 0.5, "wall_pressure": 20.0})
    assert fill_owner_run("rheometer", rheometer, "fill-r1") == owner
    assert (run_config(config, "rheometer", owner), fill_physics(config, "rheometer", "fill-r1")) == before
    # Any state's own config gives the same fill physics as the owner's: each run can check it.
    for run in states:
        assert fill_physics(run_config(config, "rheometer", run), "rheometer", "fill-r1") == before[1]
    with pytest.raises(ValueError, match="not a shared fill"):
        fill_owner_run("rheometer", rheometer, "fill-r3")


def test_an_intruder_control_starts_from_its_sheared_twin_s_fill(config: dict) -> None:
    intruder = config["cases"]["intruder"]
    # The design without a shared sheared bed (cases.intruder.shared_bed false; the bed's own test is
    # tests/pipeline/dem/test_intruder_run.py).
    intruder["shared_bed"] = False
    shallowest = min(intruder["depths_below_top"])
    fills = [f"fill-D{shallowest:g}-r{k + 1}" for k in range(intruder["replicas"])]
    assert shared_fill_ids("intruder", intruder) == fills
    for k, fill in enumerate(fills, start=1):
        assert shared_fill_of("intruder", intruder, f"D{shallowest:g}-r{k}") == fill
        assert shared_fill_of("intruder", intruder, f"D{shallowest:g}-control-r{k}") == fill
        assert fill_owner_run("intruder", intruder, fill) == f"D{shallowest:g}-r{k}"
    deeper = [r for c, r in dem_runs(config) if c == "intruder" and not r.startswith(f"D{shallowest:g}-")]
    assert deeper and all(shared_fill_of("intruder", intruder, r) is None for r in deeper)
    intruder["control"] = False
    assert shared_fill_ids("intruder", intruder) == []


def test_a_fast_rheometer_state_continues_from_the_next_slower_one(config: dict) -> None:
    rheometer = config["cases"]["rheometer"]
    rheometer["continue_above"] = 0.05
    rheometer["extra_states"].append({"inertial_number": 0.2, "wall_pressure": 20.0})
    chain = {run: predecessor_state("rheometer", rheometer, run) for c, run in dem_runs(config) if c == "rheometer"}
    # Above 0.05 only, each from the largest slower target I, of two at one I the nearer pressure.
    assert chain["I0.02-P200-r1"] is None
    assert chain["I0.07-P200-r1"] == "I0.02-P200-r1" and chain["I0.07-P600-r1"] == "I0.02-P200-r1"
    assert chain["I0.2-P200-r1"] == "I0.07-P200-r1" and chain["I0.2-P20-r1"] == "I0.07-P200-r1"
    assert chain["I0.3-P50-r1"] == "I0.2-P20-r1"  # |log(50/20)| < |log(50/200)|
    assert predecessor_state("shear_gravity", config["cases"]["shear_gravity"], "r1") is None
    del rheometer["shared_fill"]
    with pytest.raises(ConfigError, match="cases.rheometer.continue_above: .* needs shared_fill: true"):
        validate_config(config, "my.yaml")


def test_a_cases_min_shear_strain_is_its_own_runs_only() -> None:
    """The held-out beds with gravity shear 3 strain units before their window; the rest keep
    dem.min_shear_strain, and their run configs (what decides a rerun) do not change."""
    from pathlib import Path as _Path

    from pipeline.common.config import run_config
    from pipeline.dem.planar_run import PlanarShearRun

    config = load_config("config/config.yaml")
    assert config["cases"]["shear_gravity_heavy"]["min_shear_strain"] == 3.0
    heavy = PlanarShearRun(config, "shear_gravity_heavy", "r1", _Path("unused"))
    rheometer = PlanarShearRun(config, "rheometer", dem_runs(config)[0][1], _Path("unused"))
    assert heavy.min_shear_strain() == 3.0
    assert rheometer.min_shear_strain() == config["dem"]["min_shear_strain"] == 1.0
    plain = copy.deepcopy(config)
    for case in plain["cases"].values():
        case.pop("min_shear_strain", None)
    run = dem_runs(config)[0]
    assert run_config(plain, *run) == run_config(config, *run)
    assert run_config(plain, "shear_gravity_heavy", "r1") != run_config(config, "shear_gravity_heavy", "r1")


def test_lammps_engine_with_an_intruder_case_is_refused(config: dict) -> None:
    # The rod's stages are LIGGGHTS templates only: the config check refuses the mix rather than
    # running the intruder silently under another engine than the config names.
    bad = copy.deepcopy(config)
    bad["dem"]["engine"] = "lammps"
    assert any(case["geometry"] == "intruder" for case in bad["cases"].values())
    with pytest.raises(ConfigError, match=r"my.yaml: dem.engine: lammps runs planar cases only, and cases.intruder"):
        validate_config(bad, "my.yaml")
    planar_only = copy.deepcopy(bad)
    planar_only["cases"] = {k: v for k, v in bad["cases"].items() if v["geometry"] != "intruder"}
    planar_only["calibration"] = bad["calibration"]
    validate_config(planar_only, "my.yaml")
