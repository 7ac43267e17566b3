# granular-validate: DEM rheometer and planar shear -> coarse-grained fields -> calibration ->
# continuum models -> stability -> report. Wiring only: every rule calls a module of `pipeline`.
# Paths follow ../shared/contract.md; the output root comes from the config.
from snakemake.utils import min_version, validate

from pipeline import targets

min_version("9.0")


# The default config only when none is given: --configfile replaces it rather than being
# merged into it (a merge would leak default keys into the reduced config).
if not workflow.overwrite_configfiles:

    configfile: "config/config.yaml"


validate(config, "config/schema.yaml")
targets.checked(config)

ROOT = config["output_root"]
ENV = "envs/granular-validate.yaml"
# Rules run `python` from the environment Snakemake itself runs in (the project's .venv).
shell.prefix(targets.python_path_prefix())
CONFIG_JSON = targets.effective_config_file(config)
# Per-case DEM configs are written here, at parse time: a file an input function creates while
# the DAG is built is missed by Snakemake's file cache on a fresh output root (MissingInputException).
for _case in config["cases"]:
    targets.effective_config_file(config, dem_case=_case)


wildcard_constraints:
    case="[a-z_]+",
    run="[A-Za-z0-9.\\-]+",
    model="[a-z_]+",


def case_fields(wildcards):
    return targets.case_fields(wildcards, config)


def intruder_runs(wildcards):
    return targets.intruder_run_jsons(wildcards, config)


def convergence_run_jsons(wildcards):
    return targets.convergence_run_jsons(wildcards, config)


def convergence_stores(wildcards):
    return targets.convergence_stores(wildcards, config)


def convergence_fields(wildcards):
    return targets.convergence_fields(wildcards, config)


def dem_case_config(wildcards):
    return targets.effective_config_file(config, dem_case=wildcards.case)


rule all:
    input:
        f"{ROOT}/report.html",
        targets.intruder_plane_paths(config),


# ----------------------------------------------------------------------------------- DEM
rule dem:
    message:
        "LIGGGHTS run {wildcards.case}/{wildcards.run}"
    conda:
        ENV
    input:
        dem_case_config,
    output:
        f"{ROOT}/dem/{{case}}/{{run}}/run.json",
    log:
        f"{ROOT}/logs/dem/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dem/{{case}}/{{run}}.tsv"
    params:
        run_dir=targets.output_folder,
    threads: targets.mpi_ranks(config)
    resources:
        tasks=targets.mpi_ranks(config),
        mpi=targets.mpi_launcher(config),
    shell:
        "python -m pipeline.dem_run --config {input} --case {wildcards.case} --run {wildcards.run} "
        "--out {params.run_dir} --mpi-launcher '{resources.mpi}' --mpi-ranks {resources.tasks} "
        "> {log} 2>&1"


rule dump_store:
    message:
        "Dumps of {wildcards.case}/{wildcards.run} into one compact store"
    conda:
        ENV
    input:
        f"{ROOT}/dem/{{case}}/{{run}}/run.json",
    output:
        f"{ROOT}/dem/{{case}}/{{run}}/dumps.nc",
    log:
        f"{ROOT}/logs/dump_store/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dump_store/{{case}}/{{run}}.tsv"
    params:
        run_dir=targets.output_folder,
    shell:
        "python -m pipeline.dump_store {params.run_dir} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------ coarse-graining
rule fields:
    message:
        "Coarse-grained fields of {wildcards.case}/{wildcards.run}"
    conda:
        ENV
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
        run_dir=targets.run_folder_of_input,
    shell:
        "python -m pipeline.fields --config {input.config} --run-dir {params.run_dir} --out {output} > {log} 2>&1"


rule intruder_fields:
    message:
        "x-z fields around the rod of {wildcards.case}/{wildcards.run}, in its frame"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        run=f"{ROOT}/dem/{{case}}/{{run}}/run.json",
        store=f"{ROOT}/dem/{{case}}/{{run}}/dumps.nc",
    output:
        nc=f"{ROOT}/fields_xz/{{case}}/{{run}}.nc",
        vtk=f"{ROOT}/fields_xz/{{case}}/{{run}}.vts",
    log:
        f"{ROOT}/logs/fields_xz/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/fields_xz/{{case}}/{{run}}.tsv"
    params:
        run_dir=targets.run_folder_of_input,
    shell:
        "python -m pipeline.intruder_fields --config {input.config} --run-dir {params.run_dir} --out {output.nc} > {log} 2>&1"


# ---------------------------------------------------------------------------- calibration
rule calibrate:
    message:
        "Calibration of the local laws (rheometer) and the non-local lengths"
    conda:
        ENV
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
        "python -m pipeline.calibrate --config {input.config} --rheometer {input.rheometer} "
        "--nonlocal {input.nonlocal_fields} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------ continuum models
rule model:
    message:
        "Model {wildcards.model} on {wildcards.case}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        fields=case_fields,
    output:
        f"{ROOT}/models/{{case}}/{{model}}.nc",
    wildcard_constraints:
        case="|".join(targets.scored_cases(config)) or "no_planar_case",
    log:
        f"{ROOT}/logs/models/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/models/{{case}}/{{model}}.tsv"
    shell:
        "python -m pipeline.solve_models --config {input.config} --params {input.params} "
        "--case {wildcards.case} --model {wildcards.model} --fields {input.fields} --out {output} > {log} 2>&1"


rule intruder_model:
    message:
        "Model {wildcards.model}: intruder speed at the DEM depths of {wildcards.case}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        runs=intruder_runs,
        fields=case_fields,
    output:
        f"{ROOT}/models/{{case}}/{{model}}.nc",
    wildcard_constraints:
        case="|".join(targets.intruder_cases(config)) or "no_intruder_case",
        model="|".join(targets.INTRUDER_MODELS),
    log:
        f"{ROOT}/logs/models/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/models/{{case}}/{{model}}.tsv"
    shell:
        "python -m pipeline.intruder_models --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --out {output} > {log} 2>&1"


# --------------------------------------------------------------------------------- scores
rule scores:
    message:
        "Scores of every model against the DEM, with the replica noise floor"
    conda:
        ENV
    input:
        fields=[f for case in targets.scored_cases(config) for f in targets.fields_paths(config, case)],
        models=targets.model_paths(config),
        intruder_runs=targets.all_intruder_run_jsons(config),
        intruder_models=targets.intruder_model_paths(config),
    output:
        f"{ROOT}/scores.csv",
    log:
        f"{ROOT}/logs/scores.log",
    benchmark:
        f"{ROOT}/benchmarks/scores.tsv"
    shell:
        "python -m pipeline.scores --fields {input.fields} --models {input.models} "
        "--intruder-runs {input.intruder_runs} --intruder-models {input.intruder_models} --out {output} > {log} 2>&1"


rule cost_accuracy:
    message:
        "Accuracy against cost: each model over a sweep of grid resolution"
    conda:
        ENV
    input:
        params=f"{ROOT}/calibration/params.json",
        fields=[f for case in targets.scored_cases(config) for f in targets.fields_paths(config, case)],
    output:
        f"{ROOT}/cost_accuracy.csv",
    params:
        models=targets.model_names(config),
    log:
        f"{ROOT}/logs/cost_accuracy.log",
    benchmark:
        f"{ROOT}/benchmarks/cost_accuracy.tsv"
    shell:
        "python -m pipeline.cost_accuracy --params {input.params} --fields {input.fields} "
        "--models {params.models} --out {output} > {log} 2>&1"


rule dem_convergence:
    message:
        "DEM field noise against core-seconds of {wildcards.case}: averaging time and system size"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        runs=convergence_run_jsons,
        stores=convergence_stores,
        fields=convergence_fields,
    output:
        f"{ROOT}/dem_convergence/{{case}}.csv",
    log:
        f"{ROOT}/logs/dem_convergence/{{case}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dem_convergence/{{case}}.tsv"
    shell:
        "python -m pipeline.dem_convergence --config {input.config} --case {wildcards.case} "
        "--runs {input.runs} --fields {input.fields} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------------ stability
rule well_posedness:
    message:
        "Linear stability of every model about simple shear"
    conda:
        ENV
    input:
        f"{ROOT}/calibration/params.json",
    output:
        f"{ROOT}/stability/well_posedness.csv",
    log:
        f"{ROOT}/logs/well_posedness.log",
    benchmark:
        f"{ROOT}/benchmarks/well_posedness.tsv"
    shell:
        "python -m pipeline.stability --params {input} --out {output} > {log} 2>&1"


rule mesh_convergence:
    message:
        "Mesh dependence of every model (shear_gravity and a weak-plane localisation case)"
    conda:
        ENV
    input:
        params=f"{ROOT}/calibration/params.json",
        fields=targets.fields_paths(config, "shear_gravity"),
    output:
        f"{ROOT}/stability/mesh_convergence.csv",
    log:
        f"{ROOT}/logs/mesh_convergence.log",
    benchmark:
        f"{ROOT}/benchmarks/mesh_convergence.tsv"
    shell:
        "python -m pipeline.mesh_convergence --params {input.params} --fields {input.fields} --out {output} > {log} 2>&1"


rule failure_catalogue:
    message:
        "Failure catalogue: solver ranges that do not converge, DEM settings that fail"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
    output:
        f"{ROOT}/stability/failure_catalogue.csv",
    log:
        f"{ROOT}/logs/failure_catalogue.log",
    benchmark:
        f"{ROOT}/benchmarks/failure_catalogue.tsv"
    params:
        work=f"{ROOT}/stability/failure_runs",
    shell:
        "python -m pipeline.failure_catalogue --config {input.config} --params {input.params} "
        "--work {params.work} --out {output} > {log} 2>&1"


# ------------------------------------------------------------------------------- report
rule report:
    message:
        "Comparison report"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        runs=targets.run_json_paths(config),
        fields=targets.fields_paths(config, size_study=True),
        params=f"{ROOT}/calibration/params.json",
        models=targets.model_paths(config),
        well_posedness=f"{ROOT}/stability/well_posedness.csv",
        scores=f"{ROOT}/scores.csv",
        cost=f"{ROOT}/cost_accuracy.csv",
        intruder_models=targets.intruder_model_paths(config),
        mesh=f"{ROOT}/stability/mesh_convergence.csv",
        failures=f"{ROOT}/stability/failure_catalogue.csv",
        dem_convergence=targets.convergence_paths(config),
        intruder_fields=targets.intruder_plane_paths(config),
    output:
        html=f"{ROOT}/report.html",
        figures=[
            report(f"{ROOT}/figures/{name}.png", category="granular-validate")
            for name in targets.report_figures(config)
        ],
    log:
        f"{ROOT}/logs/report.log",
    benchmark:
        f"{ROOT}/benchmarks/report.tsv"
    params:
        figures=targets.figure_folder,
    shell:
        "python -m pipeline.report --config {input.config} --out {output.html} --figures {params.figures} > {log} 2>&1"
