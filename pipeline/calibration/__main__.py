"""``python -m pipeline.calibration``: local laws from the rheometer, non-local lengths from the named run."""
from pipeline.common.cli import dispatch

COMMANDS = {"fit": ("pipeline.calibration.calibrate", "fit the continuum parameters (the default)")}

raise SystemExit(dispatch("calibration", COMMANDS, default="fit"))
