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
    priority: intruder_model_priority
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
        solution=f"{ROOT}/models/{{case}}/{{model}}.nc",
        states=f"{ROOT}/models/{{case}}/{{model}}.states.npz",
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
        "--states-out {output.states} > {log} 2>&1"


# The draws and the grid study start from the nominal states, so they run as jobs of their own
# (models.intruder_draw_jobs parts of the draws, and the finer grid), merged into one file.
rule intruder_model_draws:
    priority: intruder_model_priority
    message:
        "Model {wildcards.model}: intruder draws, part {wildcards.k} of {wildcards.n}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        draws=f"{ROOT}/calibration/draws.json",
        runs=intruder_runs,
        fields=case_fields,
        states=f"{ROOT}/models/{{case}}/{{model}}.states.npz",
    output:
        f"{ROOT}/model_draws/{{case}}/parts/{{model}}/draws-{{k}}-of-{{n}}.nc",
    wildcard_constraints:
        case="|".join(layout.intruder_cases(config)) or "no_intruder_case",
        model="|".join(layout.INTRUDER_MODELS),
        k="[0-9]+",
        n="[0-9]+",
    log:
        f"{ROOT}/logs/model_draws/{{case}}/{{model}}/draws-{{k}}-of-{{n}}.log",
    benchmark:
        f"{ROOT}/benchmarks/model_draws/{{case}}/{{model}}/draws-{{k}}-of-{{n}}.tsv"
    shell:
        "python -m pipeline.models intruder-draws draws --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --states {input.states} "
        "--draws {input.draws} --part {wildcards.k}/{wildcards.n} --out {output} > {log} 2>&1"


# An intruder model's u_input propagated through the speed's sensitivities
# (models.intruder_plastic_u_input, models.intruder_ngf_u_input: sensitivities): one job in place of
# the draws' parts.
rule intruder_model_sensitivities:
    priority: intruder_model_priority
    message:
        "Model {wildcards.model}: intruder u_input from the speed's parameter sensitivities"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        draws=f"{ROOT}/calibration/draws.json",
        runs=intruder_runs,
        fields=case_fields,
        states=f"{ROOT}/models/{{case}}/{{model}}.states.npz",
    output:
        f"{ROOT}/model_draws/{{case}}/parts/{{model}}/sensitivities.nc",
    wildcard_constraints:
        case="|".join(layout.intruder_cases(config)) or "no_intruder_case",
        model="|".join(layout.INTRUDER_MODELS),
    log:
        f"{ROOT}/logs/model_draws/{{case}}/{{model}}/sensitivities.log",
    benchmark:
        f"{ROOT}/benchmarks/model_draws/{{case}}/{{model}}/sensitivities.tsv"
    shell:
        "python -m pipeline.models intruder-sensitivities --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --states {input.states} "
        "--draws {input.draws} --out {output} > {log} 2>&1"


rule intruder_model_refined:
    priority: intruder_model_priority
    message:
        "Model {wildcards.model}: intruder grid study"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        runs=intruder_runs,
        fields=case_fields,
        states=f"{ROOT}/models/{{case}}/{{model}}.states.npz",
    output:
        f"{ROOT}/model_draws/{{case}}/parts/{{model}}/refined.nc",
    wildcard_constraints:
        case="|".join(layout.intruder_cases(config)) or "no_intruder_case",
        model="|".join(layout.INTRUDER_MODELS),
    log:
        f"{ROOT}/logs/model_draws/{{case}}/{{model}}/refined.log",
    benchmark:
        f"{ROOT}/benchmarks/model_draws/{{case}}/{{model}}/refined.tsv"
    shell:
        "python -m pipeline.models intruder-draws refined --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --states {input.states} "
        "--out {output} > {log} 2>&1"


rule intruder_model_draws_merge:
    priority: intruder_model_priority
    message:
        "Model {wildcards.model}: intruder draws and grid study into one file"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        draws=f"{ROOT}/calibration/draws.json",
        runs=intruder_runs,
        fields=case_fields,
        states=f"{ROOT}/models/{{case}}/{{model}}.states.npz",
        parts=lambda wildcards: layout.intruder_draw_part_paths(config, wildcards.case, wildcards.model),
    output:
        f"{ROOT}/model_draws/{{case}}/{{model}}.nc",
    wildcard_constraints:
        case="|".join(layout.intruder_cases(config)) or "no_intruder_case",
        model="|".join(layout.INTRUDER_MODELS),
    log:
        f"{ROOT}/logs/model_draws/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/model_draws/{{case}}/{{model}}.tsv"
    shell:
        "python -m pipeline.models intruder-draws merge --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --states {input.states} "
        "--draws {input.draws} --parts {input.parts} --out {output} > {log} 2>&1"


rule intruder_model_fields:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Model {wildcards.model}: 2D fields around the rod of {wildcards.case}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        runs=intruder_runs,
        fields=case_fields,
        states=f"{ROOT}/models/{{case}}/{{model}}.states.npz",
    output:
        directory(f"{ROOT}/model_fields/{{case}}/{{model}}"),
    wildcard_constraints:
        case="|".join(layout.intruder_cases(config)) or "no_intruder_case",
        model="|".join(layout.INTRUDER_MODELS),
    log:
        f"{ROOT}/logs/model_fields/{{case}}/{{model}}.log",
    benchmark:
        f"{ROOT}/benchmarks/model_fields/{{case}}/{{model}}.tsv"
    shell:
        "python -m pipeline.models intruder-fields --config {input.config} --params {input.params} "
        "--model {wildcards.model} --runs {input.runs} --fields {input.fields} --states {input.states} "
        "--out-dir {output} > {log} 2>&1"
