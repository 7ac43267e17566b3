# DEM: one engine run (LIGGGHTS, or LAMMPS with dem.engine) per case and run id (pipeline.dem), and the fills several runs start from
# (a rheometer replica's states, an intruder run and its control: pipeline/dem/shared_fill.py).


rule dem_fill:
    message:
        f"Shared fill ({config['dem'].get('engine', 'liggghts')}) {{wildcards.case}}/{{wildcards.fill}}"
    conda:
        ENV
    input:
        shared_fill_config,
    output:
        f"{ROOT}/dem/{{case}}/{{fill}}/fill.json",
    log:
        f"{ROOT}/logs/dem/{{case}}/{{fill}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dem/{{case}}/{{fill}}.tsv"
    wildcard_constraints:
        fill="fill-[A-Za-z0-9.\\-]+",
    params:
        run_dir=targets.output_folder,
    # The longest chain to the report first (pipeline/workflow/priorities.py).
    priority: dem_fill_priority
    threads: targets.mpi_ranks(config)
    resources:
        tasks=targets.mpi_ranks(config),
        mpi=targets.mpi_launcher(config),
    shell:
        "python -m pipeline.dem --config {input} --case {wildcards.case} --run {wildcards.fill} --fill-only "
        "--out {params.run_dir} --mpi-launcher '{resources.mpi}' --mpi-ranks {resources.tasks} "
        "> {log} 2>&1"


rule dem:
    message:
        f"DEM run ({config['dem'].get('engine', 'liggghts')}) {{wildcards.case}}/{{wildcards.run}}"
    conda:
        ENV
    input:
        config=dem_case_config,
        fill=shared_fill_record,
        start=predecessor_record,
    output:
        f"{ROOT}/dem/{{case}}/{{run}}/run.json",
    log:
        f"{ROOT}/logs/dem/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/dem/{{case}}/{{run}}.tsv"
    params:
        run_dir=targets.output_folder,
        fill_from=targets.fill_from_option,
        start_from=targets.start_from_option,
    priority: dem_run_priority
    threads: targets.mpi_ranks(config)
    resources:
        tasks=targets.mpi_ranks(config),
        mpi=targets.mpi_launcher(config),
    shell:
        "python -m pipeline.dem --config {input.config} --case {wildcards.case} --run {wildcards.run} {params.fill_from} {params.start_from} "
        "--out {params.run_dir} --mpi-launcher '{resources.mpi}' --mpi-ranks {resources.tasks} "
        "> {log} 2>&1"
