# granular-validate: DEM rheometer and planar shear -> coarse-grained fields -> calibration ->
# continuum models -> stability -> report. Wiring only: every rule calls a module of `pipeline`.
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
CONFIG_DEM_JSON = targets.effective_config_file(config, dem_only=True)


wildcard_constraints:
    case="[a-z_]+",
    run="[A-Za-z0-9.\\-]+",
    model="[a-z_]+",


def case_fields(wildcards):
    return targets.case_fields(wildcards, config)


rule all:
    input:
        f"{ROOT}/report.html",


# ----------------------------------------------------------------------------------- DEM
rule dem:
    message:
        "LIGGGHTS run {wildcards.case}/{wildcards.run}"
    input:
        CONFIG_DEM_JSON,
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


rule dump_store:
    message:
        "Dumps of {wildcards.case}/{wildcards.run} into one compact store"
    input:
        f"{ROOT}/dem/{{case}}/{{run}}/run.json",
    output:
        f"{ROOT}/dem/{{case}}/{{run}}/dumps.nc",
    log:
        f"{ROOT}/logs/dump_store/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dump_store/{{case}}/{{run}}.tsv"
    params:
        run_dir=f"{ROOT}/dem/{{case}}/{{run}}",
    shell:
        "{PY} -m pipeline.dump_store {params.run_dir} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------ coarse-graining
rule fields:
    message:
        "Coarse-grained fields of {wildcards.case}/{wildcards.run}"
    input:
        config=CONFIG_JSON,
        run=f"{ROOT}/dem/{{case}}/{{run}}/run.json",
        store=f"{ROOT}/dem/{{case}}/{{run}}/dumps.nc",
    output:
        f"{ROOT}/fields/{{case}}/{{run}}.nc",
    log:
        f"{ROOT}/logs/fields/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/fields/{{case}}/{{run}}.tsv"
    params:
        run_dir=f"{ROOT}/dem/{{case}}/{{run}}",
    shell:
        "{PY} -m pipeline.fields --config {input.config} --run-dir {params.run_dir} --out {output} > {log} 2>&1"


# ---------------------------------------------------------------------------- calibration
rule calibrate:
    message:
        "Calibration of the local laws (rheometer) and the non-local lengths"
    input:
        config=CONFIG_JSON,
        rheometer=targets.fields_paths(config, "rheometer"),
        nonlocal_fields=targets.nonlocal_calibration_fields(config),
    output:
        f"{ROOT}/calibration/params.json",
    log:
        f"{ROOT}/logs/calibrate.log",
    benchmark:
        f"{ROOT}/benchmarks/calibrate.tsv"
    shell:
        "{PY} -m pipeline.calibrate --config {input.config} --rheometer {input.rheometer} "
        "--nonlocal {input.nonlocal_fields} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------ continuum models
rule model:
    message:
        "Model {wildcards.model} on {wildcards.case}"
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        fields=case_fields,
    output:
        f"{ROOT}/models/{{case}}/{{model}}.nc",
    log:
        f"{ROOT}/logs/models/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/models/{{case}}/{{model}}.tsv"
    shell:
        "{PY} -m pipeline.solve_models --config {input.config} --params {input.params} "
        "--case {wildcards.case} --model {wildcards.model} --fields {input.fields} --out {output} > {log} 2>&1"


# --------------------------------------------------------------------------------- scores
rule scores:
    message:
        "Scores of every model against the DEM, with the replica noise floor"
    input:
        fields=[f for case in targets.scored_cases(config) for f in targets.fields_paths(config, case)],
        models=targets.model_paths(config),
    output:
        f"{ROOT}/scores.csv",
    log:
        f"{ROOT}/logs/scores.log",
    benchmark:
        f"{ROOT}/benchmarks/scores.tsv"
    shell:
        "{PY} -m pipeline.scores --fields {input.fields} --models {input.models} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------------ stability
rule well_posedness:
    message:
        "Linear stability of every model about simple shear"
    input:
        f"{ROOT}/calibration/params.json",
    output:
        f"{ROOT}/stability/well_posedness.csv",
    log:
        f"{ROOT}/logs/well_posedness.log",
    benchmark:
        f"{ROOT}/benchmarks/well_posedness.tsv"
    shell:
        "{PY} -m pipeline.stability --params {input} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------------- report
rule report:
    message:
        "Comparison report"
    input:
        config=CONFIG_JSON,
        runs=targets.run_json_paths(config),
        fields=targets.fields_paths(config),
        params=f"{ROOT}/calibration/params.json",
        models=targets.model_paths(config),
        well_posedness=f"{ROOT}/stability/well_posedness.csv",
        scores=f"{ROOT}/scores.csv",
    output:
        f"{ROOT}/report.html",
    log:
        f"{ROOT}/logs/report.log",
    benchmark:
        f"{ROOT}/benchmarks/report.tsv"
    shell:
        "{PY} -m pipeline.report --config {input.config} --out {output} > {log} 2>&1"
