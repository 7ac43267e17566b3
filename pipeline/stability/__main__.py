"""``python -m pipeline.stability``: where the models and their solvers fail."""
from pipeline.common.cli import dispatch

COMMANDS = {
    "well-posedness": ("pipeline.stability.well_posedness", "linear stability of every model about simple shear"),
    "mesh-convergence": ("pipeline.stability.mesh_convergence", "band width and u_x against grid spacing"),
    "failure-catalogue": ("pipeline.stability.failure_catalogue", "solver ranges and DEM settings that fail"),
}

raise SystemExit(dispatch("stability", COMMANDS))
