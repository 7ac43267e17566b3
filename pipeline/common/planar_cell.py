"""The continuum model's planar cell for a DEM case: where its walls are and what loads them.

Every stage that puts a model on a DEM case (calibration of the non-local lengths, the model
solves, the cost and mesh sweeps) builds the cell here, so all of them see the same geometry.

Wall planes (``planes``):
- ``"contact"`` (the workflow's choice): the heights where the wall grains take the bed's load,
  the normal-force-weighted mean height of the bed-wall contact points
  (``z_bottom_contact_plane``, ``z_top_contact_plane`` of the fields file, from
  :func:`pipeline.coarse_graining.field_checks.contact_planes`). Between these planes the bed's
  weight is that of the grains that are there, and the stress at each plane is the wall force
  per area.
- ``"grain_centres"``: the mean heights of the wall grains' centres (``z_bottom_wall``,
  ``z_top_wall``), about a grain radius outside the contact planes; kept to show what the
  choice changes.

``normal_stress_ratio`` is sigma_zz / p measured on the rheometer (``params.json``
``normal_stresses.sigma_zz_over_p``): the models' p is sigma_zz over it. ``slip_length`` is the
walls' Navier slip length b (m, ``params.json`` ``wall.slip_length``,
pipeline/calibration/wall_slip.py): the rough DEM wall's grains lag it at the contact plane, and
the models' walls slip as they do (issue 54). Every caller states it: 0 is a choice, not a default.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from continuum.geometry import PlanarShear

WALL_PLANES = ("contact", "grain_centres")
_ATTRS = {"contact": ("z_bottom_contact_plane", "z_top_contact_plane"), "grain_centres": ("z_bottom_wall", "z_top_wall")}


class CellError(ValueError):
    """The fields files cannot place the model's walls; the message names the file and attribute."""


def wall_planes(ds: xr.Dataset, planes: str) -> tuple[float, float]:
    """Bottom and top wall planes (m, DEM frame) of one fields file."""
    if planes not in _ATTRS:
        raise CellError(f"wall planes {planes!r}: choose one of {', '.join(WALL_PLANES)}")
    lo, hi = _ATTRS[planes]
    if lo not in ds.attrs or hi not in ds.attrs:
        source = ds.encoding.get("source", "fields file")
        raise CellError(f"{source}: no attributes {lo}/{hi} for wall planes {planes!r} "
                        "(contact planes need the contact dump at coarse-graining)")
    return float(ds.attrs[lo]), float(ds.attrs[hi])


def planar_cell(fields: Sequence[xr.Dataset], normal_stress_ratio: float, planes: str = "contact", *,
                slip_length: float) -> tuple[PlanarShear, float]:
    """Mean planar cell of the replicas' fields and the height (m, DEM frame) of its bottom plane."""
    def mean(key: str) -> float:
        return float(np.mean([float(ds.attrs[key]) for ds in fields]))

    bounds = np.array([wall_planes(ds, planes) for ds in fields])
    z0, z1 = float(bounds[:, 0].mean()), float(bounds[:, 1].mean())
    geometry = PlanarShear(depth=z1 - z0, wall_speed=mean("wall_speed"), wall_pressure=mean("wall_pressure"),
                           gravity=mean("gravity"), d=mean("d"), rho_s=mean("rho_s"),
                           normal_stress_ratio=float(normal_stress_ratio), slip_length=float(slip_length))
    return geometry, z0
