# Stability: where the models and their solvers fail (pipeline.stability).


rule well_posedness:
    priority: targets.AFTER_DEM_PRIORITY
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
        "python -m pipeline.stability well-posedness --params {input} --out {output} > {log} 2>&1"


rule mesh_convergence:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Mesh dependence of every model (shear_gravity and a weak-plane localisation case)"
    conda:
        ENV
    input:
        params=f"{ROOT}/calibration/params.json",
        fields=layout.fields_paths(config, "shear_gravity"),
    output:
        f"{ROOT}/stability/mesh_convergence.csv",
    log:
        f"{ROOT}/logs/mesh_convergence.log",
    benchmark:
        f"{ROOT}/benchmarks/mesh_convergence.tsv"
    shell:
        "python -m pipeline.stability mesh-convergence --params {input.params} --fields {input.fields} --out {output} > {log} 2>&1"


rule failure_catalogue:
    priority: targets.AFTER_DEM_PRIORITY
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
        "python -m pipeline.stability failure-catalogue --config {input.config} --params {input.params} "
        "--work {params.work} --out {output} > {log} 2>&1"
