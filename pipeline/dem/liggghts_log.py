"""Read what a LIGGGHTS (or LAMMPS: the same log format) run printed and decide whether it failed.

A run fails loudly when the binary exits non-zero, when its log holds an ``ERROR`` line (this is
how ``thermo_modify lost error`` reports lost grains), or when the log ends before the run's
``Loop time`` line (a killed or crashed process).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd


class DEMRunError(RuntimeError):
    """A DEM run failed; the message names the run and the cause."""


_ERROR = re.compile(r"^(ERROR.*)$", re.MULTILINE)


def check_run(label: str, log_path: Path, returncode: int, stderr: str = "", engine: str = "LIGGGHTS") -> None:
    """Raise :class:`DEMRunError` if the ``engine`` call behind ``log_path`` failed."""
    text = log_path.read_text(errors="replace") if log_path.exists() else ""
    errors = _ERROR.findall(text) + _ERROR.findall(stderr)
    if errors:
        lost = [e for e in errors if "Lost atoms" in e or "lost atoms" in e.lower()]
        cause = "lost grains: " + lost[0] if lost else errors[0]
        raise DEMRunError(f"{label}: {engine} reported {cause} (log: {log_path})")
    if returncode != 0:
        tail = "\n".join((text or stderr).strip().splitlines()[-5:])
        raise DEMRunError(f"{label}: {engine} exited with code {returncode} (log: {log_path}); last lines:\n{tail}")
    if not text:
        raise DEMRunError(f"{label}: {engine} wrote no log at {log_path}")
    if "Loop time of" not in text:
        raise DEMRunError(f"{label}: log {log_path} ends before any run finished (killed or crashed?)")


def read_thermo(log_path: Path) -> pd.DataFrame:
    """All thermo rows of a log (every ``run`` block concatenated), columns named by the header."""
    frames = []
    header: list[str] | None = None
    rows: list[list[float]] = []
    for line in log_path.read_text(errors="replace").splitlines():
        words = line.split()
        if words and words[0] == "Step":
            header, rows = words, []
            continue
        if header is None:
            continue
        if line.startswith("Loop time"):
            frames.append(pd.DataFrame(rows, columns=header))
            header = None
            continue
        if len(words) == len(header):
            try:
                rows.append([float(w) for w in words])
            except ValueError:
                continue
    if header is not None and rows:
        frames.append(pd.DataFrame(rows, columns=header))
    if not frames:
        raise DEMRunError(f"{log_path}: no thermo output found")
    return pd.concat(frames, ignore_index=True)


def printed_value(log_path: Path, key: str) -> float:
    """The number after the last ``key`` printed by a ``print`` command in the log."""
    matches = re.findall(rf"^{re.escape(key)}\s+(\S+)", log_path.read_text(errors="replace"), re.MULTILINE)
    if not matches:
        raise DEMRunError(f"{log_path}: the log does not report {key}")
    value = float(matches[-1])
    if not np.isfinite(value):
        raise DEMRunError(f"{log_path}: {key} is {value}")
    return value
