"""``python -m pipeline.workflow check-config FILE``: validate a config before Snakemake reads it.

Snakemake parses ``--configfile`` itself and reports a YAML syntax error or an empty file without
naming the file or the line; this check names both (``file:line: ...``), then every schema and
cross-key error, and exits 1. ``scripts/run_workflow.sh`` runs it first.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.common.config import load_config


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Validate a workflow config (YAML) and name what is wrong.")
    parser.add_argument("config", type=Path)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    print(f"{args.config}: valid ({len(config['cases'])} cases)")
    return 0
