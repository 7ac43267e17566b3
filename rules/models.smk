# Continuum models on each case's geometry (pipeline.models).


rule model:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Model {wildcards.model} on {wildcards.case}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        draws=f"{ROOT}/calibration/draws.json",
        fields=case_fields,
    output:
        solution=f"{ROOT}/models/{{case}}/{{model}}.nc",
        draws=f"{ROOT}/model_draws/{{case}}/{{model}}.nc",
    wildcard_constraints:
        case="|".join(layout.scored_cases(config)) or "no_planar_case",
    log:
        f"{ROOT}/logs/models/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/models/{{case}}/{{model}}.tsv"
    shell:
        "python -m pipeline.models planar --config {input.config} --params {input.params} "
        "--case {wildcards.case} --model {wildcards.model} --fields {input.fields} --out {output.solution} "
        "--draws {input.draws} --draws-out {output.draws} > {log} 2>&1"


rule intruder_model:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Model {wildcards.model}: intruder speed at the DEM depths of {wildcards.case}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        draws=f"{ROOT}/calibration/draws.json",
        runs=intruder_runs,
        fields=case_fields,
    output:
        solution=f"{ROOT}/models/{{case}}/{{model}}.nc",
        draws=f"{ROOT}/model_draws/{{case}}/{{model}}.nc",
    wildcard_constraints:
        case="|".join(layout.intruder_cases(config)) or "no_intruder_case",
        model="|".join(layout.INTRUDER_MODELS),
    log:
        f"{ROOT}/logs/models/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/models/{{case}}/{{model}}.tsv"
    shell:
        "python -m pipeline.models intruder --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --out {output.solution} "
        "--draws {input.draws} --draws-out {output.draws} > {log} 2>&1"
