"""``python -m pipeline.dumps RUN_DIR [--out F]``: a DEM run's text dumps into one compact store."""
from pipeline.common.cli import dispatch

COMMANDS = {"store": ("pipeline.dumps.store", "dumps of a DEM run folder into RUN_DIR/dumps.nc (the default)")}

raise SystemExit(dispatch("dumps", COMMANDS, default="store"))
