"""``python -m pipeline.scoring``: model against DEM, against cost, and the DEM's own noise against cost."""
from pipeline.common.cli import dispatch
from pipeline.common.config import ConfigError

COMMANDS = {
    "scores": ("pipeline.scoring.scores", "scores.csv: every model against the DEM, with the replica noise floor"),
    "cost-accuracy": ("pipeline.scoring.cost_accuracy", "error against solve time over grid and tolerance sweeps"),
    "dem-convergence": ("pipeline.scoring.dem_convergence", "DEM field noise against core-seconds"),
    "error-check": ("pipeline.scoring.error_check", "validation/error_check.csv: replica scatter against the stated errors"),
    "decay-length": ("pipeline.scoring.decay_length", "validation/decay_length.csv: creep decay length against mu, DEM and models"),
    "intruder-field-scores": ("pipeline.scoring.intruder_field_scores", "the intruder models' 2D fields against the DEM's x-z fields"),
    "rod-steadiness": ("pipeline.scoring.rod_steadiness", "validation/rod_steadiness.csv: each rod's travel and whether its speed is steady"),
    "claims-cost": ("pipeline.scoring.claims_cost", "validation/claims_cost.csv: the verdict's claims with less DEM, against its core-hours"),
    "claims-across": ("pipeline.scoring.claims_across_roots", "validation/claims_across_roots.csv: each claim in other roots (another contact law, seed)"),
}

# A bad config or an input that is not there is the user's to mend: one line, no traceback.
raise SystemExit(dispatch("scoring", COMMANDS, user_errors=(ConfigError, FileNotFoundError)))
