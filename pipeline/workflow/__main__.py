"""``python -m pipeline.workflow check-config FILE``: the workflow's own commands."""
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError

COMMANDS = {"check-config": ("pipeline.workflow.check_config", "validate a config file before Snakemake reads it")}

raise SystemExit(dispatch("workflow", COMMANDS, user_errors=(ConfigError,)))
