"""Failure catalogue: the continuum rows record the solvers' real failures (and the silent grid
dominance of l << dx); the DEM failures run the real LIGGGHTS on tiny configs and must end in a
DEMRunError naming the run and the cause."""
from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from pipeline.stability import failure_catalogue as fc
from pipeline.common.config import load_config
from pipeline.dem.liggghts_log import DEMRunError

REPO = Path(__file__).resolve().parents[3]
D = 0.002


def reference_params() -> dict:
    def entry(v: float) -> dict:
        return {"value": v, "error": 0.0, "fitted_on": "glass-bead reference"}

    return {
        "local": {k: entry(v) for k, v in dict(mu_s=0.3819, mu_2=0.6435, I_0=0.279, nu_c=0.6, a=0.3).items()},
        "critical_state": {k: entry(v) for k, v in dict(sin_phi=0.3819, nu_ref=0.59, kappa=0.01, p_ref=300.0, n=1.05).items()},
        "nonlocal": {"ngf": {"A": entry(0.48)}, "cosserat": {"l": entry(2 * D)}, "volume_averaged": {"l": entry(2 * D)}},
        "normal_stresses": {"sigma_zz_over_p": entry(1.0)},
        "wall": {"slip_length": entry(0.0)},
        "rheometer_states": [{"I": 0.2}],
        "d": D, "rho_s": 2500.0,
    }


@pytest.fixture(scope="module")
def continuum_rows() -> pd.DataFrame:
    config = load_config(REPO / "config" / "ci.yaml")
    rows = fc.continuum_attempts(fc.config_geometry(config), reference_params())
    return pd.DataFrame([r.as_dict() for r in rows])


def row(table: pd.DataFrame, component: str, setting: str, value: float) -> pd.Series:
    hit = table[(table.component == component) & (table.setting.str.startswith(setting)) & (table.value == value)]
    assert len(hit) == 1, (component, setting, value, hit)
    return hit.iloc[0]


def test_local_mu_i_fails_exactly_at_the_end_of_the_nu_law(continuum_rows) -> None:
    # homogeneous shear at I = 0.99 and 1.01 of I_max = nu_c / a: the law's range ends in between
    assert row(continuum_rows, "local_mu_i", "rheometer I / I_max", 0.99).outcome == "converged"
    beyond = row(continuum_rows, "local_mu_i", "rheometer I / I_max", 1.01)
    assert beyond.outcome == "OutOfRangeError" and "nu(I)" in beyond.message
    fast = row(continuum_rows, "local_mu_i", "shear_gravity wall speed", 100.0)
    assert fast.outcome == "OutOfRangeError" and "needs I above 2" in fast.message


def test_rate_independent_models_on_coarse_grids(continuum_rows) -> None:
    # l << dx: the volume-averaged band silently becomes the local one, 1.6 cells wide
    coarse = row(continuum_rows, "volume_averaged", "l / d on a 16-node", 0.001)
    assert coarse.outcome == "converged" and "= 1.6 dx" in coarse.message
    # the loose-packing evolution converges; a layer at uniform pressure has no determined velocity
    assert row(continuum_rows, "volume_averaged", "initial nu below critical", 0.2).outcome == "converged"
    assert "not determined" in row(continuum_rows, "critical_state", "uniform pressure", 0.0).message


def test_cosserat_and_ngf_failures_carry_the_solver_message(continuum_rows) -> None:
    big_l = row(continuum_rows, "cosserat", "l / d on a 1024-node", 4.0)
    assert big_l.outcome == "ConvergenceError" and big_l.message.startswith("cosserat on case 'catalogue' did not converge")
    assert row(continuum_rows, "cosserat", "l / d on a 1024-node", 1.0).outcome == "converged"
    rest = row(continuum_rows, "ngf", "wall speed (m/s)", 0.0)
    assert rest.outcome == "OutOfRangeError" and "at rest" in rest.message


def test_cli_without_dem_writes_the_table(tmp_path: Path) -> None:
    import json

    (tmp_path / "params.json").write_text(json.dumps(reference_params()))
    out = tmp_path / "stability" / "failure_catalogue.csv"
    assert fc.main(["--config", str(REPO / "config" / "ci.yaml"), "--params", str(tmp_path / "params.json"),
                    "--out", str(out), "--no-dem"]) == 0
    table = pd.read_csv(out)
    assert list(table.columns) == fc.COLUMNS
    assert {"converged", "ConvergenceError", "OutOfRangeError"} <= set(table.outcome)
    assert not list(out.parent.glob("*.tmp"))


def test_schema_rejects_the_obviously_bad_settings() -> None:
    config = load_config(REPO / "config" / "ci.yaml")
    base = fc.tiny_config(config)
    for key, value in (("dt_over_contact_time", 0.1), ("design_overlap", 0.02)):
        bad = base | {"material": base["material"] | {key: value}}
        attempt = fc.attempt("dem_config", key, value, lambda b=bad: str(fc.validate_config(b, "test")))
        assert attempt.outcome == "ConfigError" and f"material.{key}" in attempt.message


@pytest.fixture(scope="module")
def dem_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    config = load_config(REPO / "config" / "ci.yaml")
    runs = fc.dem_failure_runs(config, tmp_path_factory.mktemp("catalogue"))
    return {run.run_dir.name: run for _, _, run in runs}


@pytest.mark.liggghts
def test_large_time_step_fails_with_the_runs_checks(dem_runs) -> None:
    run = dem_runs["large_time_step"]
    with pytest.raises(DEMRunError) as info:
        run.run()
    message = str(info.value)
    assert "DEM run rheometer/I0.2-P200-r1" in message
    assert any(cause in message for cause in ("lost grains", "kinetic energy", "overlap")), message
    assert "fill" not in message.split(":")[0]  # the designed step settles the bed; shearing fails


@pytest.mark.liggghts
def test_soft_grains_break_the_overlap_bound(dem_runs) -> None:
    with pytest.raises(DEMRunError, match=r"DEM run rheometer/I0.2-P2000-r1 stage shear_000: contact overlap reached"):
        dem_runs["soft_grains"].run()


@pytest.mark.liggghts
def test_too_few_grains_is_refused_naming_the_run(dem_runs) -> None:
    with pytest.raises(DEMRunError, match=r"DEM run rheometer/I0.2-P200-r1.*too few grains"):
        dem_runs["too_few_grains"].run()
