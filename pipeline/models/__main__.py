"""``python -m pipeline.models planar|intruder``: continuum solutions on a DEM case's geometry."""
from pipeline.common.cli import dispatch

COMMANDS = {
    "planar": ("pipeline.models.planar", "one model on a planar case (1D profile)"),
    "intruder": ("pipeline.models.intruder", "one model's intruder speed at the DEM depths"),
    "predict": ("pipeline.models.predict", "every model on candidate planar cases from the config alone, before any DEM"),
}

raise SystemExit(dispatch("models", COMMANDS))
