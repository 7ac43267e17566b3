"""A planar run's flowing grains placed where another root's run of the same case settled them.

``cases.<case>.packing_from: <root>`` (a study switch, issue 56): the fill does not pour; it creates
the flowing grains of ``<root>/dem/<case>/<run>/settled.dump`` (the other run's packing at rest,
its top wall not yet laid; for runs sharing a fill, the rheometer's states of one replica, that of
``<root>/dem/<case>/fill-r<k>/``) at their positions with their diameters and densities, at rest, then
settles, lays the top wall and shears exactly as a poured fill does. With the two roots in two
engines, each engine shears the packing the other poured: whether a difference between the
engines' beds is made by the pour or by the shear.

Both runs must share the bottom wall (the same seed, cell and sizes make the same monolayer):
it is checked grain by grain, as is the count of flowing grains. The source file's SHA-256 goes
into the fill's record. Positions come with the dump's 6 significant digits (1e-8 m at the
cell's 2 cm, 5e-6 d: the overlaps of the design, 2e-3 d, keep 0.3 % of their size).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.rough_wall import single_grains_include

#: The atom types of the planar fill (liggghts_inputs/planar_shear/fill.in): flowing grains, bottom wall.
FLOWING_TYPE, BOTTOM_WALL_TYPE = 1, 2
#: How far (m) a bottom-wall grain of the source may sit from this run's (the dump's rounding, 1e-8 m).
WALL_MATCH_TOLERANCE = 1e-7
#: LIGGGHTS' pour (liggghts_inputs/planar_shear/fill.in): the commands the adopted packing removes,
#: by their first two words.
LIGGGHTS_POUR_LINES = (("fix", "ins"), ("unfix", "ins"))


def source_path(root: str | Path, case_name: str, packing: str) -> Path:
    """Where the other root keeps the settled packing ``packing``: a run's own fill (its run id) or
    a shared fill (``fill-r<k>``, the rheometer's states of replica k)."""
    return Path(root) / "dem" / case_name / packing / "settled.dump"


def packing_include(settled: pd.DataFrame, first_id: int, rho_s: float) -> str:
    """Engine text (LIGGGHTS and LAMMPS read it alike) creating ``settled``'s flowing grains as
    type 1 at their positions (m), ids from ``first_id`` in the source's id order, with their
    diameters (m) and density ``rho_s`` (kg/m^3), then adding them to group ``flow`` (a group
    defined before the grains existed does not hold them)."""
    grains = settled[settled["type"] == FLOWING_TYPE].sort_values("id")
    return (single_grains_include(FLOWING_TYPE, grains["x"], grains["y"], grains["z"].tolist(),
                                  2.0 * grains["radius"], rho_s, first_id)
            + f"group flow type {FLOWING_TYPE}\n")


def check_source(settled: pd.DataFrame, path: Path, n_grains: int, bottom_x: np.ndarray,
                 bottom_y: np.ndarray) -> None:
    """Refuse a source whose flowing-grain count or bottom wall is not this run's."""
    flowing = int((settled["type"] == FLOWING_TYPE).sum())
    if flowing != n_grains:
        raise DEMRunError(f"{path}: {flowing} flowing grains, the case asks for {n_grains} (packing_from)")
    wall = settled[settled["type"] == BOTTOM_WALL_TYPE].sort_values("id")
    if len(wall) != len(bottom_x):
        raise DEMRunError(f"{path}: its bottom wall has {len(wall)} grains, this run's {len(bottom_x)}: "
                          "not the same seed, cell or sizes (packing_from)")
    dx = np.hypot(wall["x"].to_numpy() - bottom_x, wall["y"].to_numpy() - bottom_y)
    if dx.max() > WALL_MATCH_TOLERANCE:
        raise DEMRunError(f"{path}: its bottom wall's grain {int(np.argmax(dx)) + 1} sits {dx.max():.3g} m from "
                          "this run's: not the same seed, cell or sizes (packing_from)")


def sha256(path: Path) -> str:
    """The source file's digest, for the fill's record."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def without_pour(fill_template: str, engine: str, path: Path) -> str:
    """The fill template with its own pour removed: LIGGGHTS' ``insert/pack`` lines (LAMMPS places
    its grains in ``grains.in`` alone, which the adopted packing replaces, so its template stays)."""
    if engine != "liggghts":
        return fill_template
    out, removed = [], 0
    for line in fill_template.splitlines(keepends=True):
        if tuple(line.split()[:2]) in LIGGGHTS_POUR_LINES:
            out.append("# (packing_from: the grains are created by grains.in, not poured) " + line)
            removed += 1
        else:
            out.append(line)
    if removed != len(LIGGGHTS_POUR_LINES):
        raise DEMRunError(f"{path}: expected one command each of {' and '.join(' '.join(c) for c in LIGGGHTS_POUR_LINES)}, "
                          f"found {removed} in all: the template changed (packing_from)")
    return "".join(out)
