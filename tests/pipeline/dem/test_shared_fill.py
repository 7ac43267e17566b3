"""Fills several runs start from (pipeline/dem/shared_fill.py).

On the reduced workflow's real output (config/ci.yaml sets ``cases.rheometer.shared_fill`` and an
intruder control): every rheometer state starts from the one settled packing of its replica, the
intruder's control from its sheared twin's, and none pays a fill of its own; the fill's work is
recorded once. A fill made with other physics than a run's config gives it is refused.
"""
from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

from pipeline.common.config import dem_runs, fill_physics, load_config, run_config
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.planar_run import FILL_FILES, FILL_RECORD, PlanarShearRun

REPO = Path(__file__).resolve().parents[3]


@pytest.mark.liggghts
def test_the_states_of_a_replica_shear_from_one_settled_packing(reduced_dem: Path) -> None:
    fill_dir = reduced_dem / "dem" / "rheometer" / "fill-r1"
    fill = json.loads((fill_dir / FILL_RECORD).read_text())
    assert fill["steps_by_stage"]["fill"] > 0 and fill["run"] == "fill-r1"
    states = sorted(p.parent for p in (reduced_dem / "dem" / "rheometer").glob("I*-r1/run.json"))
    assert len(states) == 5
    restart = (fill_dir / "fill.restart").read_bytes()
    for state in states:
        record = json.loads((state / "run.json").read_text())
        # The same packing and walls: the restart it sheared from is the fill's, byte for byte.
        assert (state / "fill.restart").read_bytes() == restart, state.name
        assert record["settled_gap"] == fill["fill"]["settled_gap"]
        assert record["wall_coverage"] == fill["fill"]["wall_coverage"]
        # Its fill costs nothing here: the work is the fill's, counted once.
        assert record["steps_by_stage"]["fill"] == 0
        assert record["shared_fill"] == {"run": "fill-r1", "steps": fill["fill"]["steps"],
                                         "wall_seconds": fill["fill"]["wall_seconds"]}
        # It sheared a steady-state window at the least (which may be its production's start).
        window = record["provenance"]["config"]["dem"]["steady_window_chunks"]
        assert record["shear_chunks"] + record["production_chunks_from_steady_window"] >= window
        assert record["steps_by_stage"]["production"] > 0
    # Each state sheared to its own steady state: the states' wall speeds differ (their own I, P).
    speeds = [json.loads((s / "run.json").read_text())["wall_speed"] for s in states]
    assert len(set(speeds)) == len(speeds)


@pytest.mark.liggghts
def test_an_intruder_replica_s_rods_go_into_one_sheared_bed(reduced_dem: Path) -> None:
    """config/ci.yaml sets cases.intruder.shared_bed (pipeline/dem/sheared_bed.py): one bed, sheared to
    steady state with the creep test, and every run of the replica (depths, pushes, control) restarts
    from its final state with its rod inserted; the bed's work is counted once."""
    dem = reduced_dem / "dem" / "intruder"
    config = load_config(reduced_dem / "config.effective.json")
    fills = sorted(dem.glob("fill-*/fill.json"))
    assert [f.parent.name for f in fills] == ["fill-sheared-r1"]
    bed = json.loads(fills[0].read_text())
    test = bed["bed"]["steady_state_test"]
    assert test["stationary"] and test["creep"]["stationary"]
    assert bed["steps_by_stage"]["fill"] > 0 and bed["steps_by_stage"]["shear"] > 0
    restart = (fills[0].parent / bed["bed"]["restart"]).read_bytes()
    runs = [run for case, run in dem_runs(config) if case == "intruder"]
    for run in runs:
        record = json.loads((dem / run / "run.json").read_text())
        assert (dem / run / "bed.restart").read_bytes() == restart, run
        assert record["shared_fill"] == {"run": "fill-sheared-r1", "steps": sum(bed["steps_by_stage"].values()),
                                         "wall_seconds": sum(bed["wall_seconds_by_stage"].values())}
        assert record["steps_by_stage"]["fill"] == 0
        inserted = record["intruder"]["inserted"]
        # The bed's grains less those the rod overlapped, and no others, are the run's.
        assert 0 < inserted["removed_grains"] and record["flowing_grains"] == bed["bed"]["n_grains"] - inserted["removed_grains"]
        # Its time runs on from the bed's: the run continued the bed's flow.
        assert record["production_window"][0] > bed["bed"]["time"]
    control = json.loads((dem / f"D{min(config['cases']['intruder']['depths_below_top']):g}-control-r1" / "run.json").read_text())
    assert control["wall_speed"] == 0 and control["shared_fill"]["run"] == "fill-sheared-r1"


@pytest.mark.liggghts
def test_a_fast_state_shears_from_the_slower_state_s_final_packing(reduced_dem: Path) -> None:
    dem = reduced_dem / "dem" / "rheometer"
    fast, slow = (json.loads((dem / run / "run.json").read_text()) for run in ("I0.3-P50-r1", "I0.2-P200-r1"))
    slow_state = json.loads((dem / "I0.2-P200-r1" / "state.json").read_text())
    assert fast["started_from"] == {"run": "I0.2-P200-r1", "restart": slow_state["chunks"][-1]["restart"],
                                    "after_chunks": len(slow_state["chunks"])}
    assert (dem / "I0.3-P50-r1" / "start.restart").read_bytes() == (dem / "I0.2-P200-r1" / slow_state["chunks"][-1]["restart"]).read_bytes()
    assert slow["started_from"] is None
    # It then reached a steady state of its own, at its own load: the wall force over the load
    # is the state's friction, as for every state.
    assert fast["steady_state_test"]["stationary"]
    assert fast["wall_pressure"] == 50.0 and slow["wall_pressure"] == 200.0


def test_a_start_from_another_fill_is_refused(tmp_path: Path) -> None:
    config = load_config(REPO / "config" / "ci.yaml")
    state = run_config(config, "rheometer", "I0.3-P50-r1")
    source = _fake_fill(tmp_path, state, "fill-r1")
    other = tmp_path / "other"
    other.mkdir()
    (other / "run.json").write_text(json.dumps({"seed": 12345}))
    (other / "state.json").write_text(json.dumps({"fingerprint": {"case": "rheometer", "run": "I0.2-P200-r1"},
                                                  "fill": {"steps": 5}, "chunks": [{"restart": "restart/x.restart"}]}))
    run = PlanarShearRun(state, "rheometer", "I0.3-P50-r1", tmp_path / "run", fill_from=source, start_from=other)
    with pytest.raises(DEMRunError, match=r"did not grow from this run's shared fill 'fill-r1' \(its seed 12345, the fill's \d+\)"):
        run.run()


def _fake_fill(tmp_path: Path, config: dict, fill: str) -> Path:
    """A fill folder with the record a run checks and empty stand-ins for the files it copies
    (the refusal happens before any copy or LIGGGHTS call)."""
    source = tmp_path / fill
    for name in FILL_FILES:
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        (source / name).write_text("")
    record = {"run": fill, "physics": fill_physics(config, "rheometer", fill),
              "fill": {"steps": 10, "wall_seconds": 1.0, "settled_gap": 0.03}}
    (source / FILL_RECORD).write_text(json.dumps(record))
    return source


def test_a_fill_made_with_other_physics_is_refused(tmp_path: Path) -> None:
    config = run_config(load_config(REPO / "config" / "ci.yaml"), "rheometer", "I0.02-P200-r1")
    other = copy.deepcopy(config)
    other["material"]["friction"] = 0.3
    source = _fake_fill(tmp_path, other, "fill-r1")
    run = PlanarShearRun(config, "rheometer", "I0.02-P200-r1", tmp_path / "run", fill_from=source)
    with pytest.raises(DEMRunError, match=r"fill\.json is fill 'fill-r1' made with other settings"):
        run.run()
    assert not (tmp_path / "run" / "fill.restart").exists()


def test_a_fill_of_another_replica_is_refused(tmp_path: Path) -> None:
    config = load_config(REPO / "config" / "ci.yaml")
    config["cases"]["rheometer"]["replicas"] = 2
    state = run_config(config, "rheometer", "I0.02-P200-r1")
    source = _fake_fill(tmp_path, state, "fill-r2")
    run = PlanarShearRun(state, "rheometer", "I0.02-P200-r1", tmp_path / "run", fill_from=source)
    with pytest.raises(DEMRunError, match=r"its shared fill 'fill-r1'"):
        run.run()


def test_a_missing_fill_is_named(tmp_path: Path) -> None:
    config = run_config(load_config(REPO / "config" / "ci.yaml"), "rheometer", "I0.02-P200-r1")
    (tmp_path / "empty").mkdir()
    shutil.rmtree(tmp_path / "run", ignore_errors=True)
    run = PlanarShearRun(config, "rheometer", "I0.02-P200-r1", tmp_path / "run", fill_from=tmp_path / "empty")
    with pytest.raises(DEMRunError, match=r"no fill\.json there"):
        run.run()
