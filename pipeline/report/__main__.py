"""``python -m pipeline.report --config C --out report.html --figures DIR``: the comparison report."""
from pipeline.common.cli import dispatch

COMMANDS = {"html": ("pipeline.report.build", "the self-contained HTML report (the default)")}

raise SystemExit(dispatch("report", COMMANDS, default="html"))
