"""Two grains, both engines, step by step (benchmarks/two_grain_contact.py, issue 56): the real
LIGGGHTS 3.8 and LAMMPS binaries run one contact through normal loading, sticking, sliding,
reversal and a rigid turn (1520 steps each, four runs, about 5 s), from the same state with the
same motion, through the pipeline's own template copy (``material.tangential_damping``), rendering
and launch.

With the tangential damping off the tangential forces agree at every step within the bound the
benchmark derives (terms 4 and 5 of docs/dem.md "Two engines", plus round-off): a law, not a
fitted tolerance. With it on, the sliding phase differs by far more than that bound (the switch
does something). And each engine's dumped force is the law read from its source, replayed on its
dumped motion, to round-off (the term-by-term reading of docs/dem.md is the engines' law).
"""
from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from pipeline.common.config import load_config

REPO = Path(__file__).resolve().parents[3]
SPEC = importlib.util.spec_from_file_location("two_grain_contact", REPO / "benchmarks" / "two_grain_contact.py")
bench = importlib.util.module_from_spec(SPEC)
sys.modules[SPEC.name] = bench  # its dataclasses look their module up
SPEC.loader.exec_module(bench)



@pytest.fixture(autouse=True, scope="module")
def liggghts_installed() -> None:
    """Both engines are what these tests compare: a missing LIGGGHTS is a failure, not a skip."""
    if shutil.which("liggghts") is None:
        pytest.fail("LIGGGHTS is not installed: run scripts/install.sh (the two-grain test needs the real binary)")


@pytest.fixture(scope="module")
def result(liggghts_installed: None, tmp_path_factory: pytest.TempPathFactory) -> dict:
    config = load_config(REPO / "config" / "config.yaml")
    return bench.measure(config, tmp_path_factory.mktemp("two_grain"))


def test_both_engines_move_the_grains_alike(result: dict) -> None:
    """The same state and the same fix move formulas: positions, velocities and spins agree exactly,
    and so does the normal force (the Hertz law and its damping, to round-off)."""
    for damping in (True, False):
        assert result["kinematics", damping] == 0.0
        assert result["normal", damping] < 1e-12


def test_damping_off_the_engines_agree_within_the_law_bound_at_every_step(result: dict) -> None:
    sc = result["scenario"]
    off = result["runs"]["liggghts", False]
    mask = bench.contact_mask(off)
    diff, bound = result["diff", False], result["bound"]
    worst = np.argmax(np.where(mask, diff - bound, -np.inf))
    assert np.all(diff[mask] <= bound[mask]), (int(off["step"][worst]), diff[worst], bound[worst])
    phase = sc.phase_of(off["step"])
    # Nothing spins before the turn: only term 4 (the normal's slow turn on the circle) and round-off.
    assert diff[mask & (phase < 4)].max() < 1e-7
    # In the turn the difference is term 5 (LAMMPS's lever arm r), as large as its bound says.
    turn = mask & (phase == 4)
    assert diff[turn].max() > 0.5 and diff[turn].max() >= 0.99 * (bound[turn].max() - bench.ROUND_OFF)


def test_damping_on_the_sliding_phase_differs_beyond_the_damping_off_tolerance(result: dict) -> None:
    sc = result["scenario"]
    off = result["runs"]["liggghts", False]
    sliding = sc.phase_of(off["step"]) == bench.PHASES.index("sliding")
    tolerance = result["bound"][sliding].max()
    assert result["phase_max", True][bench.PHASES.index("sliding")] > 1e5 * tolerance
    assert result["phase_max", True][bench.PHASES.index("sliding")] > 0.3


def test_each_engine_runs_the_law_read_from_its_source(result: dict) -> None:
    for (name, damping), errors in result["replay_check"].items():
        assert max(errors) < 1e-12, (name, damping, errors)


def test_report_prints_the_table(result: dict) -> None:
    text = bench.report(result)
    assert "largest |F_t difference| / (mu F_n)" in text
    for phase in bench.PHASES:
        assert phase in text
