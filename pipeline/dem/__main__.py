"""``python -m pipeline.dem --config C --case CASE --run RUN [--out DIR]``: one DEM run."""
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError
from pipeline.dem.liggghts_log import DEMRunError

raise SystemExit(dispatch("dem", {"run": ("pipeline.dem.cli", "one LIGGGHTS run of a case (the default)")},
                          default="run", user_errors=(DEMRunError, ConfigError),
                          out_is_folder=True))
