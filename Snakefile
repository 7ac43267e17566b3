# granular-validate: DEM rheometer and planar shear -> coarse-grained fields -> calibration ->
# continuum models -> scores -> report. Wiring only: every rule calls a module of `pipeline`.
# Paths follow ../shared/contract.md; the output root comes from the config.
import sys

from snakemake.utils import min_version, validate

from pipeline import targets

min_version("9.0")


configfile: "config/config.yaml"


validate(config, "config/schema.yaml")
targets.checked(config)

ROOT = config["output_root"]
PY = sys.executable
CONFIG_JSON = targets.effective_config_file(config)


wildcard_constraints:
    case="[a-z_]+",
    run="[A-Za-z0-9.\-]+",


rule all:
    input:
        f"{ROOT}/report.html",


# ----------------------------------------------------------------------------------- DEM
rule dem:
    message:
        "LIGGGHTS run {wildcards.case}/{wildcards.run}"
    input:
        CONFIG_JSON,
    output:
        f"{ROOT}/dem/{{case}}/{{run}}/run.json",
    log:
        f"{ROOT}/logs/dem/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dem/{{case}}/{{run}}.tsv"
    params:
        run_dir=f"{ROOT}/dem/{{case}}/{{run}}",
    threads: targets.mpi_ranks(config)
    resources:
        tasks=targets.mpi_ranks(config),
        mpi=targets.mpi_launcher(config),
    shell:
        "{PY} -m pipeline.dem_run --config {input} --case {wildcards.case} --run {wildcards.run} "
        "--out {params.run_dir} --mpi-launcher '{resources.mpi}' --mpi-ranks {resources.tasks} "
        "> {log} 2>&1"


# ------------------------------------------------------------------------------- report
rule report:
    message:
        "Comparison report"
    input:
        config=CONFIG_JSON,
        runs=targets.run_json_paths(config),
    output:
        f"{ROOT}/report.html",
    log:
        f"{ROOT}/logs/report.log",
    benchmark:
        f"{ROOT}/benchmarks/report.tsv"
    shell:
        "{PY} -m pipeline.report --config {input.config} --out {output} > {log} 2>&1"
