"""The verdict's claims in another root (pipeline.scoring.claims_across_roots): each pair's status
from two roots' verdict files, and the CLI's table."""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from pipeline.scoring import claims_across_roots as across

DIFF_COLUMNS = ["case", "metric", "model_a", "model_b", "claim"]


def write_root(root: Path, claims: list[tuple[str, str, str, str, str]]) -> Path:
    """A scored root's two verdict files: the pairs' claims, every model scored finitely."""
    (root / "validation").mkdir(parents=True)
    pd.DataFrame(claims, columns=DIFF_COLUMNS).to_csv(root / "validation" / "model_differences.csv", index=False)
    models = sorted({(c, m, x) for c, m, a, b, _ in claims for x in (a, b)})
    pd.DataFrame([{"case": c, "metric": m, "model": x, "value": 0.1, "verdict": "cannot_tell_apart"} for c, m, x in models]
                 ).to_csv(root / "validation" / "verdict.csv", index=False)
    return root


def test_each_claim_gets_what_the_other_root_says(tmp_path: Path):
    here = write_root(tmp_path / "a", [("c", "m", "ngf", "volume_averaged", "a_better"),
                                       ("c", "m", "cosserat", "ngf", "b_better"),
                                       ("c", "m", "cosserat", "volume_averaged", "a_better"),
                                       ("c", "m", "local_mu_i", "ngf", "cannot_tell_apart")])
    other = write_root(tmp_path / "b", [("c", "m", "ngf", "volume_averaged", "a_better"),       # the same
                                        ("c", "m", "cosserat", "ngf", "a_better"),               # the opposite
                                        ("c", "m", "cosserat", "volume_averaged", "cannot_tell_apart"),
                                        ("c", "m", "local_mu_i", "ngf", "b_better")])            # only there
    table = across.claims_across(across.read_claims(here), across.read_claims(other), "law B", "b")
    status = {(r.model_a, r.model_b): r.status for r in table.itertuples()}
    assert status == {("ngf", "volume_averaged"): "confirmed", ("cosserat", "ngf"): "contradicted",
                      ("cosserat", "volume_averaged"): "lost", ("local_mu_i", "ngf"): "new"}
    assert table.holds_in_both.sum() == 1
    counts = across.summary(table).iloc[0]
    assert (counts.claims_here, counts.confirmed, counts.lost, counts.contradicted, counts.new) == (3, 1, 1, 1, 1)


def test_a_root_against_itself_confirms_every_claim(tmp_path: Path):
    root = write_root(tmp_path / "a", [("c", "m", "ngf", "volume_averaged", "b_better"),
                                       ("c", "m2", "cosserat", "ngf", "a_better"),
                                       ("c", "m2", "ngf", "volume_averaged", "cannot_tell_apart")])
    out = tmp_path / "across.csv"
    assert across.main(["--root", str(root), "--other", f"self={root}", "--out", str(out)]) == 0
    table = pd.read_csv(out)
    assert len(table) == 2 and table.holds_in_both.all() and set(table.status) == {"confirmed"}


def test_an_unscored_root_is_named(tmp_path: Path):
    root = write_root(tmp_path / "a", [("c", "m", "ngf", "volume_averaged", "b_better")])
    try:
        across.main(["--root", str(root), "--other", f"x={tmp_path / 'missing'}", "--out", str(tmp_path / 'o.csv')])
    except FileNotFoundError as error:
        assert "missing/validation/model_differences.csv" in str(error)
    else:
        raise AssertionError("an unscored root was read")
    assert not (tmp_path / "o.csv").exists()


def test_a_label_the_shell_would_split_is_refused_by_the_schema(tmp_path: Path):
    import pytest
    import yaml

    from pipeline.common.config import ConfigError, load_config

    config = yaml.safe_load((Path(__file__).resolve().parents[3] / "config" / "config.yaml").read_text())
    config["scoring"]["compare_roots"] = [{"label": "damping off", "root": "results-damping-off"}]
    good = tmp_path / "good.yaml"
    good.write_text(yaml.safe_dump(config))
    assert load_config(good)["scoring"]["compare_roots"][0]["root"] == "results-damping-off"
    config["scoring"]["compare_roots"] = [{"label": "it's=off", "root": "x"}]
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(config))
    with pytest.raises(ConfigError, match="scoring.compare_roots.0.label"):
        load_config(bad)
