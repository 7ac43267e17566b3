# Scoring: models against the DEM and against cost; the DEM's noise against cost (pipeline.scoring).


rule scores:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Scores of every model against the DEM, with their uncertainty, and which models can be told apart"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        fields=[f for case in layout.scored_cases(config) for f in layout.fields_paths(config, case)],
        models=layout.model_paths(config),
        model_draws=layout.model_draw_paths(config),
        intruder_runs=layout.all_intruder_run_jsons(config),
        intruder_models=layout.intruder_model_paths(config),
        intruder_model_draws=layout.intruder_model_draw_paths(config),
        intruder_fields_xz=layout.intruder_plane_paths(config),
        intruder_bed_fields=[f for case in layout.intruder_cases(config) for f in layout.fields_paths(config, case)],
        intruder_model_fields=layout.intruder_model_fields_dirs(config),
        params=f"{ROOT}/calibration/params.json",
    output:
        scores=report(f"{ROOT}/scores.csv", caption="../docs/report/scores.rst", category="Scoring"),
        verdict=f"{ROOT}/validation/verdict.csv",
        differences=f"{ROOT}/validation/model_differences.csv",
        scene_needs=f"{ROOT}/validation/scene_needs.csv",
        force_sweep=f"{ROOT}/validation/force_sweep.csv",
        wall=f"{ROOT}/validation/wall.csv",
        intruder_fields=f"{ROOT}/validation/intruder_fields.csv",
        intruder_bed=f"{ROOT}/validation/intruder_bed.csv",
    log:
        f"{ROOT}/logs/scores.log",
    benchmark:
        f"{ROOT}/benchmarks/scores.tsv"
    shell:
        "python -m pipeline.scoring scores --config {input.config} --fields {input.fields} --models {input.models} "
        "--model-draws {input.model_draws} {input.intruder_model_draws} "
        "--intruder-runs {input.intruder_runs} --intruder-models {input.intruder_models} --params {input.params} "
        "--out {output.scores} --verdict-out {output.verdict} --differences-out {output.differences} "
        "--scene-needs-out {output.scene_needs} --force-sweep-out {output.force_sweep} --wall-out {output.wall} "
        "--intruder-fields-xz {input.intruder_fields_xz} --intruder-model-fields {input.intruder_model_fields} "
        "--intruder-fields-out {output.intruder_fields} "
        "--intruder-fields {input.intruder_bed_fields} --intruder-bed-out {output.intruder_bed} "
        "> {log} 2>&1"


rule rod_steadiness:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Is each rod steady? Its travel over the production and the production's halves"
    conda:
        ENV
    input:
        intruder_runs=layout.all_intruder_run_jsons(config),
    output:
        f"{ROOT}/validation/rod_steadiness.csv",
    log:
        f"{ROOT}/logs/rod_steadiness.log",
    benchmark:
        f"{ROOT}/benchmarks/rod_steadiness.tsv"
    shell:
        "python -m pipeline.scoring rod-steadiness --intruder-runs {input.intruder_runs} --out {output} > {log} 2>&1"


rule claims_cost:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "The verdict's claims with less DEM: prefixes of every production and fewer replicas, against core-hours"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        differences=f"{ROOT}/validation/model_differences.csv",
        verdict=f"{ROOT}/validation/verdict.csv",
        scores=f"{ROOT}/scores.csv",
    output:
        table=f"{ROOT}/validation/claims_cost.csv",
        pairs=f"{ROOT}/validation/claims_cost_pairs.csv",
    params:
        root=targets.output_root_of_scores,
    log:
        f"{ROOT}/logs/claims_cost.log",
    benchmark:
        f"{ROOT}/benchmarks/claims_cost.tsv"
    shell:
        "python -m pipeline.scoring claims-cost --root {params.root} --out {output.table} --pairs-out {output.pairs} > {log} 2>&1"


rule claims_across_roots:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "The verdict's claims in the other roots of scoring.compare_roots (another contact law, another seed)"
    conda:
        ENV
    input:
        differences=f"{ROOT}/validation/model_differences.csv",
        verdict=f"{ROOT}/validation/verdict.csv",
        scores=f"{ROOT}/scores.csv",
        # scored by their own configs: a root not scored yet is a missing input, named by Snakemake
        others=[f"{c['root']}/validation/{name}" for c in layout.compared_roots(config)
                for name in ("model_differences.csv", "verdict.csv")],
    output:
        f"{ROOT}/validation/claims_across_roots.csv",
    params:
        root=targets.output_root_of_scores,
        others=[f"'{c['label']}={c['root']}'" for c in layout.compared_roots(config)],
    log:
        f"{ROOT}/logs/claims_across_roots.log",
    benchmark:
        f"{ROOT}/benchmarks/claims_across_roots.tsv"
    shell:
        "python -m pipeline.scoring claims-across --root {params.root} --other {params.others} --out {output} > {log} 2>&1"


rule cost_accuracy:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Accuracy against cost: each model over a sweep of grid resolution"
    conda:
        ENV
    input:
        params=f"{ROOT}/calibration/params.json",
        fields=[f for case in layout.scored_cases(config) for f in layout.fields_paths(config, case)],
    output:
        f"{ROOT}/cost_accuracy.csv",
    params:
        models=layout.model_names(config),
    log:
        f"{ROOT}/logs/cost_accuracy.log",
    benchmark:
        f"{ROOT}/benchmarks/cost_accuracy.tsv"
    shell:
        "python -m pipeline.scoring cost-accuracy --params {input.params} --fields {input.fields} "
        "--models {params.models} --out {output} > {log} 2>&1"


rule dem_convergence:
    priority: targets.AFTER_DEM_PRIORITY
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
        "python -m pipeline.scoring dem-convergence --config {input.config} --case {wildcards.case} "
        "--runs {input.runs} --fields {input.fields} --out {output} > {log} 2>&1"


rule decay_length:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Creep decay length against the stress ratio, every planar case, DEM and models"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        fields=[f for case in layout.scored_cases(config) for f in layout.fields_paths(config, case)],
        models=layout.model_paths(config),
    output:
        table=f"{ROOT}/validation/decay_length.csv",
        models=f"{ROOT}/validation/decay_length_models.csv",
        fits=f"{ROOT}/validation/decay_length_fit.csv",
        settings=f"{ROOT}/validation/decay_length.json",
    log:
        f"{ROOT}/logs/decay_length.log",
    benchmark:
        f"{ROOT}/benchmarks/decay_length.tsv"
    shell:
        "python -m pipeline.scoring decay-length --config {input.config} --params {input.params} "
        "--fields {input.fields} --models {input.models} --out {output.table} > {log} 2>&1"


rule error_check:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Replica scatter against the stated error bars: profiles, scalars, rods; creep in the production's halves"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        fields=[f for case in layout.scored_cases(config) for f in layout.fields_paths(config, case)],
        rheometer=layout.fields_paths(config, "rheometer"),
        intruder_runs=layout.all_intruder_run_jsons(config),
    output:
        table=f"{ROOT}/validation/error_check.csv",
        resolution=f"{ROOT}/validation/creep_resolution.csv",
        halves=f"{ROOT}/validation/creep_halves.csv",
    log:
        f"{ROOT}/logs/error_check.log",
    benchmark:
        f"{ROOT}/benchmarks/error_check.tsv"
    shell:
        "python -m pipeline.scoring error-check --config {input.config} --fields {input.fields} --rheometer {input.rheometer} "
        "--intruder-runs {input.intruder_runs} --out {output.table} --resolution-out {output.resolution} "
        "--halves-out {output.halves} > {log} 2>&1"
