# Coarse-graining: dumps into velocity, stress and solid-fraction fields (pipeline.coarse_graining).


rule fields:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "Coarse-grained fields of {wildcards.case}/{wildcards.run}"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        run=f"{ROOT}/dem/{{case}}/{{run}}/run.json",
        store=f"{ROOT}/dem/{{case}}/{{run}}/dumps.nc",
    output:
        f"{ROOT}/fields/{{case}}/{{run}}.nc",
    log:
        f"{ROOT}/logs/fields/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/fields/{{case}}/{{run}}.tsv"
    params:
        run_dir=targets.run_folder_of_input,
    shell:
        "python -m pipeline.coarse_graining run --config {input.config} --run-dir {params.run_dir} --out {output} > {log} 2>&1"


rule intruder_fields:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "x-z fields around the rod of {wildcards.case}/{wildcards.run}, in its frame"
    conda:
        ENV
    input:
        config=CONFIG_JSON,
        run=f"{ROOT}/dem/{{case}}/{{run}}/run.json",
        store=f"{ROOT}/dem/{{case}}/{{run}}/dumps.nc",
    output:
        nc=f"{ROOT}/fields_xz/{{case}}/{{run}}.nc",
        vtk=f"{ROOT}/fields_xz/{{case}}/{{run}}.vts",
    log:
        f"{ROOT}/logs/fields_xz/{{case}}/{{run}}.log",
    benchmark:
        f"{ROOT}/benchmarks/fields_xz/{{case}}/{{run}}.tsv"
    params:
        run_dir=targets.run_folder_of_input,
    shell:
        "python -m pipeline.coarse_graining rod-frame --config {input.config} --run-dir {params.run_dir} --out {output.nc} > {log} 2>&1"


rule paraview:
    priority: targets.AFTER_DEM_PRIORITY
    message:
        "The fields of {wildcards.case} as one ParaView collection"
    conda:
        ENV
    input:
        case_fields,
    output:
        f"{ROOT}/paraview/{{case}}.pvd",
    log:
        f"{ROOT}/logs/paraview/{{case}}.log",
    benchmark:
        f"{ROOT}/benchmarks/paraview/{{case}}.tsv"
    shell:
        "python -m pipeline.coarse_graining paraview --fields {input} --out {output} > {log} 2>&1"
