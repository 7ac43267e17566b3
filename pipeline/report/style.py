"""Colours and line styles of the models, shared by every figure of the report."""

MODEL_STYLE = {
    "local_mu_i": ("tab:blue", "-"),
    "critical_state": ("tab:orange", "--"),
    "cosserat": ("tab:green", "-."),
    "ngf": ("tab:red", "-"),
    "volume_averaged": ("tab:purple", ":"),
}
