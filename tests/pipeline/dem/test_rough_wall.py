"""Rough wall layers: no two grains overlap, and the layer is jammed (no hole lets a grain through)."""
from __future__ import annotations

import numpy as np

from pipeline.dem.rough_wall import PLUG_FRACTION, layer_include, random_layer

SIZES = [0.0016, 0.0018, 0.002, 0.0022, 0.0024]


def periodic_gaps(layer, lx: float, ly: float) -> np.ndarray:
    pos = np.stack([layer.x, layer.y], axis=1)
    delta = pos[:, None, :] - pos[None, :, :]
    delta -= np.array([lx, ly]) * np.round(delta / np.array([lx, ly]))
    gap = np.hypot(delta[..., 0], delta[..., 1]) - 0.5 * (layer.diameter[:, None] + layer.diameter[None, :])
    return gap[~np.eye(len(layer), dtype=bool)]


def test_layer_grains_do_not_overlap_across_periodic_faces(rng: np.random.Generator) -> None:
    layer = random_layer(0.016, 0.012, SIZES, rng)
    assert periodic_gaps(layer, 0.016, 0.012).min() >= 0.0


def test_layer_is_jammed_for_the_smallest_grain(rng: np.random.Generator) -> None:
    lx = ly = 0.016
    layer = random_layer(lx, ly, SIZES, rng)
    # Random sequential addition jams near 55 % coverage (Feder 1980: 0.547 for equal disks).
    assert 0.45 < layer.coverage(lx, ly) < 0.65
    trial = rng.random((20000, 2)) * [lx, ly]
    delta = trial[:, None, :] - np.stack([layer.x, layer.y], axis=1)[None, :, :]
    delta -= np.array([lx, ly]) * np.round(delta / np.array([lx, ly]))
    plug = PLUG_FRACTION * min(SIZES)
    gap = np.hypot(delta[..., 0], delta[..., 1]) - 0.5 * (layer.diameter[None, :] + plug)
    # No random position has room for a disk of 85 % of the smallest grain (holes are plugged on
    # a grid of plug/20: a hole missed between grid points is narrower by at most that spacing).
    assert np.all(gap.min(axis=1) < 0.05 * plug)


def test_include_sets_size_and_density_by_id(rng: np.random.Generator) -> None:
    layer = random_layer(0.01, 0.01, SIZES, rng)
    text = layer_include(layer, 3, 0.05, 2500.0, first_id=101)
    assert text.count("create_atoms 3 single") == len(layer)
    assert f"set atom {100 + len(layer)} density 2500.0" in text
