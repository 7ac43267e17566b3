# DEM: one LIGGGHTS run per case and run id (pipeline.dem).


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
        "python -m pipeline.dem --config {input} --case {wildcards.case} --run {wildcards.run} "
        "--out {params.run_dir} --mpi-launcher '{resources.mpi}' --mpi-ranks {resources.tasks} "
        "> {log} 2>&1"
