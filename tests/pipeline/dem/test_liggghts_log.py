"""Log parsing: every way a LIGGGHTS call can fail gives an error naming the run and the cause."""
from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.dem.liggghts_log import DEMRunError, check_run, printed_value, read_thermo

GOOD = """LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0)
    Step    Atoms         KinEng
       0      350              0
     100      350   1.5e-06
Loop time of 0.5 on 1 procs for 100 steps with 350 atoms
SETTLED_KE 1.5e-06
    Step    Atoms         KinEng
     100      350   1.5e-06
     200      350   1.0e-06
Loop time of 0.5 on 1 procs for 100 steps with 350 atoms
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "log.liggghts"
    path.write_text(text)
    return path


def test_good_log_passes_and_parses(tmp_path: Path) -> None:
    log = write(tmp_path, GOOD)
    check_run("run A", log, 0)
    thermo = read_thermo(log)
    assert list(thermo.columns) == ["Step", "Atoms", "KinEng"]
    assert thermo["Step"].tolist() == [0, 100, 100, 200]
    assert printed_value(log, "SETTLED_KE") == pytest.approx(1.5e-6)


def test_lost_atoms_are_reported(tmp_path: Path) -> None:
    log = write(tmp_path, GOOD + "ERROR: Lost atoms: original 350 current 349 (../thermo.cpp:395)\n")
    with pytest.raises(DEMRunError, match=r"run A: LIGGGHTS reported lost grains: ERROR: Lost atoms"):
        check_run("run A", log, 1)


def test_error_line_fails_even_with_exit_code_zero(tmp_path: Path) -> None:
    log = write(tmp_path, GOOD + "ERROR: Illegal fix wall/gran command\n")
    with pytest.raises(DEMRunError, match="Illegal fix wall/gran"):
        check_run("run A", log, 0)


def test_nonzero_exit_without_error_line(tmp_path: Path) -> None:
    with pytest.raises(DEMRunError, match="exited with code -9"):
        check_run("run A", write(tmp_path, GOOD), -9)


def test_truncated_log_is_detected(tmp_path: Path) -> None:
    log = write(tmp_path, GOOD.split("Loop time")[0])
    with pytest.raises(DEMRunError, match="ends before any run finished"):
        check_run("run A", log, 0)
    with pytest.raises(DEMRunError, match="no log"):
        check_run("run A", tmp_path / "missing.log", 0)


def test_missing_printed_value(tmp_path: Path) -> None:
    with pytest.raises(DEMRunError, match="does not report NOPE"):
        printed_value(write(tmp_path, GOOD), "NOPE")
