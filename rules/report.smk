# Report: the self-contained HTML comparison (pipeline.report).


rule report:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Comparison report"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        runs=layout.run_json_paths(config),
        fills=layout.shared_fill_paths(config),
        fields=layout.fields_paths(config, size_study=True),
        params=f"{ROOT}/calibration/params.json",
        models=layout.model_paths(config),
        well_posedness=f"{ROOT}/stability/well_posedness.csv",
        scores=f"{ROOT}/scores.csv",
        verdict=f"{ROOT}/validation/verdict.csv",
        differences=f"{ROOT}/validation/model_differences.csv",
        scene_needs=f"{ROOT}/validation/scene_needs.csv",
        wall=f"{ROOT}/validation/wall.csv",
        claims_cost=f"{ROOT}/validation/claims_cost.csv",
        claims_across=layout.claims_across_paths(config),
        rod_steadiness=[f"{ROOT}/validation/rod_steadiness.csv"] if layout.intruder_cases(config) else [],
        decay_length=f"{ROOT}/validation/decay_length.csv",
        error_check=f"{ROOT}/validation/error_check.csv",
        creep_resolution=f"{ROOT}/validation/creep_resolution.csv",
        creep_halves=f"{ROOT}/validation/creep_halves.csv",
        cost=f"{ROOT}/cost_accuracy.csv",
        intruder_models=layout.intruder_model_paths(config),
        mesh=f"{ROOT}/stability/mesh_convergence.csv",
        failures=f"{ROOT}/stability/failure_catalogue.csv",
        dem_convergence=layout.convergence_paths(config),
        intruder_fields=layout.intruder_plane_paths(config),
        intruder_model_fields=layout.intruder_model_fields_dirs(config),
        intruder_field_scores=f"{ROOT}/validation/intruder_fields.csv",
    output:
        html=f"{ROOT}/report.html",
        figures=[
            report(
                f"{ROOT}/figures/{name}.png",
                caption=f"../docs/report/{name}.rst",
                category=layout.REPORT_CATEGORIES[name],
            )
            for name in layout.report_figures(config)
        ],
    log:
        f"{ROOT}/logs/report.log",
    benchmark:
        f"{ROOT}/benchmarks/report.tsv"
    params:
        figures=targets.figure_folder,
    shell:
        "python -m pipeline.report --config {input.config} --out {output.html} --figures {params.figures} > {log} 2>&1"
