# granular-validate. Wiring only: the config, the final target and one rules file per stage
# (rules/<stage>.smk), each calling `python -m pipeline.<stage>`.
# Paths follow ../shared/contract.md; the output root comes from the config.
from snakemake.utils import min_version, validate

from pipeline.common import layout
from pipeline.common.config import dem_runs
from pipeline.workflow import targets

min_version("9.0")


report: "docs/report/workflow.rst"


# The default config only when none is given: --configfile replaces it rather than being
# merged into it (a merge would leak default keys into the reduced config).
if not workflow.overwrite_configfiles:

    configfile: "config/config.yaml"


# A bad config stops here with one message naming the file and key, without stack frames.
targets.checked(config, workflow.configfiles)
validate(config, "config/schema.yaml")

ROOT = config["output_root"]
# Conda paths resolve against the file holding the rule, and every rule is in rules/.
ENV = "../envs/granular-validate.yaml"
# Rules run `python` from the environment Snakemake itself runs in (the project's .venv).
shell.prefix(targets.python_path_prefix())
CONFIG_JSON = targets.effective_config_file(config)
# Per-run DEM configs are written here, at parse time: a file an input function creates while
# the DAG is built is missed by Snakemake's file cache on a fresh output root (MissingInputException).
for _run in dem_runs(config):
    targets.effective_config_file(config, dem_run=_run)


wildcard_constraints:
    case="[a-z_]+",
    run="[A-Za-z0-9.\\-]+",
    model="[a-z_]+",


rule all:
    input:
        f"{ROOT}/report.html",
        layout.intruder_plane_paths(config),
        [f"{ROOT}/paraview/{case}.pvd" for case in layout.scored_cases(config)],


# The stages, in the order the data flows through them.
include: "rules/common.smk"
include: "rules/dem.smk"
include: "rules/dumps.smk"
include: "rules/coarse_graining.smk"
include: "rules/calibration.smk"
include: "rules/models.smk"
include: "rules/scoring.smk"
include: "rules/stability.smk"
include: "rules/report.smk"
