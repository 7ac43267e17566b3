"""``python -m pipeline.calibration``: local laws from the rheometer, non-local lengths from the named run."""
from pipeline.calibration.parameter_sets import CalibrationError
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError

COMMANDS = {"fit": ("pipeline.calibration.calibrate", "fit the continuum parameters (the default)"),
            "draws": ("pipeline.calibration.draws", "draw parameter sets from the calibration's uncertainty")}

raise SystemExit(dispatch("calibration", COMMANDS, default="fit", user_errors=(CalibrationError, ConfigError)))
