# Calibration: local laws from the rheometer, non-local lengths from the named run (pipeline.calibration).


rule calibrate:
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
