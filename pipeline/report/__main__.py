"""``python -m pipeline.report --config C --out report.html --figures DIR``: the comparison report."""
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError

COMMANDS = {"html": ("pipeline.report.build", "the self-contained HTML report (the default)")}

# A result the report reads that is not there is the user's to produce (the workflow's earlier rules).
raise SystemExit(dispatch("report", COMMANDS, default="html", user_errors=(ConfigError, FileNotFoundError)))
