"""``python -m pipeline.calibration``: local laws from the rheometer, non-local lengths from the named run."""
from pipeline.calibration.calibrate import CalibrationError
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError

COMMANDS = {"fit": ("pipeline.calibration.calibrate", "fit the continuum parameters (the default)")}

raise SystemExit(dispatch("calibration", COMMANDS, default="fit", user_errors=(CalibrationError, ConfigError)))
