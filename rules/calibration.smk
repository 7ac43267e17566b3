# Calibration: local laws from the rheometer, non-local lengths from the named case's replicas, and
# the parameter draws of the calibration's uncertainty (pipeline.calibration).


rule calibrate:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Calibration of the local laws (rheometer) and the non-local lengths"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        rheometer=targets.rheometer_calibration_fields(config),
        nonlocal_fields=targets.nonlocal_calibration_fields(config),
    output:
        f"{ROOT}/calibration/params.json",
    log:
        f"{ROOT}/logs/calibrate.log",
    benchmark:
        f"{ROOT}/benchmarks/calibrate.tsv"
    shell:
        "python -m pipeline.calibration --config {input.config} --rheometer {input.rheometer} "
        "--nonlocal {input.nonlocal_fields} --out {output} > {log} 2>&1"


rule calibration_draws:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Parameter draws from the calibration's uncertainty"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        params=f"{ROOT}/calibration/params.json",
        nonlocal_fields=targets.nonlocal_calibration_fields(config),
    output:
        f"{ROOT}/calibration/draws.json",
    log:
        f"{ROOT}/logs/calibration_draws.log",
    benchmark:
        f"{ROOT}/benchmarks/calibration_draws.tsv"
    shell:
        "python -m pipeline.calibration draws --config {input.config} --params {input.params} "
        "--nonlocal {input.nonlocal_fields} --out {output} > {log} 2>&1"
