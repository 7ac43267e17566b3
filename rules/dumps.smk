# Dumps: a run's text dumps into one compact store (pipeline.dumps).


rule dump_store:
    priority: targets.AFTER_DEM_PRIORITY
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
        "python -m pipeline.dumps {params.run_dir} --out {output} > {log} 2>&1"
