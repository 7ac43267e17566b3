"""``python -m pipeline.coarse_graining``: particle (and contact) dumps into continuum fields.

    python -m pipeline.coarse_graining PARTICLE_DUMP --contacts CONTACT_DUMP --out F.nc
    python -m pipeline.coarse_graining run --config C --run-dir RUN_DIR --out F.nc
    python -m pipeline.coarse_graining rod-frame --config C --run-dir RUN_DIR --out F.nc
"""
from pipeline.common.cli import dispatch

COMMANDS = {
    "dumps": ("pipeline.coarse_graining.dumps_cli", "any LIGGGHTS/LAMMPS dump files into fields (the default)"),
    "run": ("pipeline.coarse_graining.fields", "a workflow DEM run into its fields file (steady window, checks)"),
    "rod-frame": ("pipeline.coarse_graining.rod_frame", "x-z fields of an intruder run in the rod's frame"),
    "paraview": ("pipeline.coarse_graining.vtk", "a case's fields files as VTK (velocity vector, stress tensor) and one .pvd"),
}

raise SystemExit(dispatch("coarse_graining", COMMANDS, default="dumps"))
