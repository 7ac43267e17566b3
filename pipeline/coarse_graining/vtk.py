"""Fields and grains as VTK files for ParaView: what a researcher opens to look at a run.

- :func:`write_fields_vtk`: x-z fields on a structured grid (``.vts``, one cell thick in y) with
  every scalar field, the velocity as a 3-vector array ``velocity`` (u_x, 0, u_z) and the stress as
  a 9-component tensor array ``stress`` (row-major xx xy xz yx yy yz zx zy zz; compressive
  positive; sigma_xy = sigma_yz = 0 are not measured and written as 0, sigma_zx = sigma_xz).
- :func:`write_profile_vtk`: a z profile as a polyline (``.vtp``) with the same arrays, so a run's
  profile sits in the same scene as its grains.
- :func:`write_collection`: a ``.pvd`` collection of files (the runs of a case, or the snapshots of
  one run), which ParaView opens as one time series.
- :func:`write_particles_vtu`: the grains of chosen snapshots as points (``.vtu``) with radius,
  velocity (vector) and type.
Every file is written under a temporary name and renamed when complete.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from pipeline.common import atomic
from pipeline.dumps.reader import Dump


def _save(mesh, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = atomic.temporary(path)  # keeps the suffix: it picks the VTK writer
    mesh.save(tmp)
    tmp.replace(path)
    return path


def _vector_and_tensor(ds: xr.Dataset, flat) -> dict[str, np.ndarray]:
    """The velocity and stress arrays of a dataset, each point flattened by ``flat``."""
    out = {}
    zeros = np.zeros_like(flat(ds["u_x"].values))
    if "u_x" in ds and "u_z" in ds:
        out["velocity"] = np.column_stack([flat(ds["u_x"].values), zeros, flat(ds["u_z"].values)])
    if all(f"sigma_{c}" in ds for c in ("xx", "yy", "zz", "xz")):
        xx, yy, zz, xz = (flat(ds[f"sigma_{c}"].values) for c in ("xx", "yy", "zz", "xz"))
        out["stress"] = np.column_stack([xx, zeros, xz, zeros, yy, zeros, xz, zeros, zz])
    return out


def write_fields_vtk(ds: xr.Dataset, path: Path) -> Path:
    """x-z fields as a VTK structured grid (module docstring)."""
    import pyvista as pv

    x, z = ds["x"].values, ds["z"].values
    xx, yy, zz = np.meshgrid(x, [0.0], z, indexing="ij")
    grid = pv.StructuredGrid(xx, yy, zz)

    def flat(values: np.ndarray) -> np.ndarray:
        # VTK points run x fastest: Fortran order of the (x, y, z) array.
        return np.asarray(values)[:, None, :].ravel(order="F")

    for name in ds.data_vars:
        if ds[name].dims == ("x", "z"):
            grid.point_data[name] = flat(ds[name].values)
    for name, array in _vector_and_tensor(ds, flat).items():
        grid.point_data[name] = array
    return _save(grid, path)


def write_profile_vtk(ds: xr.Dataset, path: Path, x: float = 0.0) -> Path:
    """A z profile as a VTK polyline at ``x`` (module docstring)."""
    import pyvista as pv

    z = ds["z"].values
    points = np.column_stack([np.full_like(z, x), np.zeros_like(z), z])
    line = pv.lines_from_points(points)
    for name in ds.data_vars:
        if ds[name].dims == ("z",):
            line.point_data[name] = np.asarray(ds[name].values, dtype=float)
    for name, array in _vector_and_tensor(ds, np.asarray).items():
        line.point_data[name] = array
    return _save(line, path)


def write_collection(entries: Sequence[tuple[float, Path]], path: Path) -> Path:
    """A ParaView ``.pvd`` collection of (time or index, file) entries, paths relative to it."""
    path = Path(path)
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    for k, (time, file) in enumerate(entries):
        rel = Path(file).resolve().relative_to(path.parent.resolve()) if Path(file).is_absolute() else Path(file)
        ET.SubElement(collection, "DataSet", timestep=f"{time:.9g}", group="", file=str(rel))
    tmp = path.with_name(f".{path.name}.tmp")
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")
    tmp.replace(path)
    return path


def write_particles_vtu(particles: Dump, snapshots: Sequence[int], folder: Path, time_step: float | None = None,
                        stem: str = "particles") -> Path:
    """The grains of each snapshot as a ``.vtu`` point cloud and a ``.pvd`` time series of them."""
    import pyvista as pv

    folder = Path(folder)
    cols = {c: particles.index(c) for c in ("x", "y", "z", "vx", "vy", "vz", "radius", "type")}
    entries = []
    for s in snapshots:
        rows = particles.rows(int(s))
        cloud = pv.PolyData(rows[:, [cols["x"], cols["y"], cols["z"]]].copy())
        cloud.point_data["radius"] = rows[:, cols["radius"]]
        cloud.point_data["velocity"] = rows[:, [cols["vx"], cols["vy"], cols["vz"]]].copy()
        cloud.point_data["type"] = rows[:, cols["type"]].astype(np.int32)
        mesh = cloud.cast_to_unstructured_grid()
        step = int(particles.timesteps[int(s)])
        file = _save(mesh, folder / f"{stem}_{step:012d}.vtu")
        entries.append((step * time_step if time_step else float(step), file))
    return write_collection(entries, folder / f"{stem}.pvd")


def main(argv: list[str] | None = None) -> int:
    """``python -m pipeline.coarse_graining paraview``: a case's fields as one ParaView collection."""
    import argparse

    parser = argparse.ArgumentParser(description="The fields files of a case's runs as VTK files and one .pvd collection.")
    parser.add_argument("--fields", nargs="+", required=True, type=Path, help="fields/CASE/RUN.nc of one case")
    parser.add_argument("--out", required=True, type=Path, help="paraview/CASE.pvd (the VTK files go to paraview/CASE/)")
    args = parser.parse_args(argv)
    folder = args.out.with_suffix("")
    entries = []
    for k, path in enumerate(args.fields):
        with xr.open_dataset(path) as ds:
            write = write_fields_vtk if "x" in ds.dims else write_profile_vtk
            # runs side by side along x, one cell length apart, so they can be seen together
            file = write(ds, folder / (path.stem + (".vts" if "x" in ds.dims else ".vtp")), **(
                {} if "x" in ds.dims else {"x": k * float(np.atleast_1d(ds.attrs.get("cell", [0.0]))[0])}))
        entries.append((float(k), file))
    print(write_collection(entries, args.out))
    return 0
