"""``python -m pipeline.models planar|intruder``: continuum solutions on a DEM case's geometry."""
from pipeline.common.cli import dispatch

COMMANDS = {
    "planar": ("pipeline.models.planar", "one model on a planar case (1D profile)"),
    "intruder": ("pipeline.models.intruder", "one model's intruder speed at the DEM depths"),
}

raise SystemExit(dispatch("models", COMMANDS))
