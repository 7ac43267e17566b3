# Input functions shared by the stages' rules: each hands the config to pipeline.workflow.targets.


def dem_case_config(wildcards):
    return targets.effective_config_file(config, dem_run=(wildcards.case, wildcards.run))


def shared_fill_config(wildcards):
    return targets.shared_fill_config_file(config, wildcards.case, wildcards.fill)


def shared_fill_record(wildcards):
    return targets.shared_fill_record(wildcards, config)


def predecessor_record(wildcards):
    return targets.predecessor_record(wildcards, config)


def case_fields(wildcards):
    return targets.case_fields(wildcards, config)


def intruder_runs(wildcards):
    return targets.intruder_run_jsons(wildcards, config)


def convergence_run_jsons(wildcards):
    return targets.convergence_run_jsons(wildcards, config)


def convergence_stores(wildcards):
    return targets.convergence_stores(wildcards, config)


def convergence_fields(wildcards):
    return targets.convergence_fields(wildcards, config)


def dem_run_priority(wildcards):
    return targets.dem_job_priority(config, wildcards.case, wildcards.run)


def dem_fill_priority(wildcards):
    return targets.dem_job_priority(config, wildcards.case, wildcards.fill)


def intruder_model_priority(wildcards):
    return targets.intruder_model_priority(wildcards.model)
