"""Rough walls made of grains: a random monolayer of polydisperse spheres with centres in one plane.

A flat layer (all centres at one height) cannot trap a flowing grain in a pocket deeper than a
grain: an earlier choice, the lowest and highest grains of the settled packing, left flowing
grains wedged between rigidly held wall grains, where overlaps grew without bound.
The layer is built by random sequential addition in the periodic plane, then every hole that
still fits a disk of 85 % of the smallest grain (found on a fine grid) is plugged with such a
disk: a jammed layer, about 55 % area coverage, with no hole a grain can squeeze through.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


#: Holes that fit a disk of this fraction of the smallest grain are plugged (see random_layer).
PLUG_FRACTION = 0.85


@dataclass(frozen=True)
class WallLayer:
    """Grains of one rough wall: in-plane positions (m) and diameters (m)."""

    x: np.ndarray
    y: np.ndarray
    diameter: np.ndarray

    def __len__(self) -> int:
        return int(self.x.size)

    def coverage(self, lx: float, ly: float) -> float:
        """Fraction of the wall area covered by the grains' equatorial disks."""
        return float(np.sum(np.pi * self.diameter**2 / 4.0) / (lx * ly))


def random_layer(lx: float, ly: float, sizes: list[float], rng: np.random.Generator,
                 attempts_per_grain: int = 2000) -> WallLayer:
    """Random sequential addition of disks (diameters drawn from ``sizes``) in a periodic lx x ly cell.

    Sizes are drawn uniformly from the classes; once ``attempts_per_grain`` consecutive attempts
    fail for a size, the layer is finished with the smallest size until it too stops fitting.
    """
    xs: list[float] = []
    ys: list[float] = []
    ds: list[float] = []
    box = np.array([lx, ly])

    def fits(p: np.ndarray, dia: float) -> bool:
        if not xs:
            return True
        delta = np.stack([np.asarray(xs) - p[0], np.asarray(ys) - p[1]], axis=1)
        delta -= box * np.round(delta / box)
        gap = np.hypot(delta[:, 0], delta[:, 1]) - 0.5 * (np.asarray(ds) + dia)
        return bool(np.all(gap >= 0.0))

    smallest = min(sizes)
    for phase in ("mixed", "smallest"):
        failures = 0
        while failures < attempts_per_grain:
            dia = float(rng.choice(sizes)) if phase == "mixed" else smallest
            p = rng.random(2) * box
            if fits(p, dia):
                xs.append(float(p[0]))
                ys.append(float(p[1]))
                ds.append(dia)
                failures = 0
            else:
                failures += 1
    # Random attempts miss rare holes: scan a fine grid and plug every hole that still fits a disk
    # of PLUG_FRACTION of the smallest grain. Soft contacts let a grain squeeze through a hole a
    # little narrower than itself (seen: 1.5 % narrower), so holes are plugged with a margin.
    plug = PLUG_FRACTION * smallest
    step = 0.05 * plug
    gx, gy = np.meshgrid(np.arange(0.0, lx, step), np.arange(0.0, ly, step), indexing="ij")
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    while True:
        delta = grid[:, None, :] - np.stack([xs, ys], axis=1)[None, :, :]
        delta -= box * np.round(delta / box)
        gap = np.hypot(delta[..., 0], delta[..., 1]) - 0.5 * (np.asarray(ds)[None, :] + plug)
        free = np.nonzero(gap.min(axis=1) >= 0.0)[0]
        if free.size == 0:
            break
        p = grid[free[0]]
        xs.append(float(p[0]))
        ys.append(float(p[1]))
        ds.append(plug)
    return WallLayer(np.array(xs), np.array(ys), np.array(ds))


def layer_include(layer: WallLayer, atom_type: int, z: float | str, rho_s: float, first_id: int) -> str:
    """LIGGGHTS commands creating the layer's grains with centres at height ``z``.

    ``z`` is a height in m or LIGGGHTS text evaluated when the file is included (``"${z_top}"``).
    ``first_id`` is the id LIGGGHTS gives the first created grain (one more than the largest id
    present): diameters and densities are set per grain by id.
    """
    z_text = repr(float(z)) if not isinstance(z, str) else z
    return single_grains_include(atom_type, layer.x, layer.y, [z_text] * len(layer.x), layer.diameter, rho_s, first_id)


def single_grains_include(atom_type: int, x: Sequence[float], y: Sequence[float], z: Sequence[float | str],
                          diameters: Sequence[float], rho_s: float, first_id: int) -> str:
    """Engine commands (LIGGGHTS and LAMMPS read them alike) creating one grain of ``atom_type`` at
    each centre (m; a ``z`` may be engine text evaluated on inclusion), then setting each one's
    diameter (m) and density ``rho_s`` (kg/m^3) by id, from ``first_id`` (one more than the largest
    id present) in the order given."""
    z_texts = [v if isinstance(v, str) else repr(float(v)) for v in z]
    lines = [f"create_atoms {atom_type} single {float(xi)!r} {float(yi)!r} {zi} units box" for xi, yi, zi in zip(x, y, z_texts)]
    for k, dia in enumerate(diameters):
        lines.append(f"set atom {first_id + k} diameter {float(dia)!r}")
        lines.append(f"set atom {first_id + k} density {float(rho_s)!r}")
    return "\n".join(lines) + "\n"
