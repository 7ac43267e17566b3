"""``python -m pipeline.models planar|intruder|intruder-draws|intruder-sensitivities|intruder-fields|predict``: continuum solutions on a DEM case's geometry."""
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError

COMMANDS = {
    "planar": ("pipeline.models.planar", "one model on a planar case (1D profile)"),
    "intruder": ("pipeline.models.intruder", "one model's intruder speed at the DEM depths"),
    "intruder-draws": ("pipeline.models.intruder_draws", "an intruder model's parameter draws and grid study, in parts"),
    "intruder-sensitivities": ("pipeline.models.intruder_sensitivities", "an intruder model's u_input from its speed's parameter sensitivities"),
    "intruder-fields": ("pipeline.models.intruder_fields", "an intruder model's 2D fields per scene (CF NetCDF and VTK)"),
    "predict": ("pipeline.models.predict", "every model on candidate planar cases from the config alone, before any DEM"),
}

# A bad config or an input that is not there is the user's to mend: one line, no traceback.
raise SystemExit(dispatch("models", COMMANDS, user_errors=(ConfigError, FileNotFoundError)))
