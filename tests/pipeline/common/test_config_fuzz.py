"""Fuzz every numeric key of the config at the schema's edges: each value validates or is refused
with the key named (never a traceback of another kind, never a silent default)."""
from __future__ import annotations

import copy
import math
from pathlib import Path

import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.common.config import ConfigError, validate_config

CI = Path(__file__).resolve().parents[3] / "config" / "ci.yaml"
BASE = yaml.safe_load(CI.read_text())


def numeric_keys(value, path=()):
    if isinstance(value, dict):
        for k, v in value.items():
            yield from numeric_keys(v, path + (k,))
    elif isinstance(value, list):
        for k, v in enumerate(value):
            yield from numeric_keys(v, path + (k,))
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path


KEYS = sorted(numeric_keys(BASE), key=str)
EDGES = st.sampled_from([math.nan, math.inf, -math.inf, 0, 0.0, -1, -1e-300, 1e300, 10**12, 0.5, 2.5, "text", None,
                         True, [], {}])


def test_every_numeric_key_is_fuzzed() -> None:
    assert len(KEYS) > 60  # material, dem, every case's numbers, calibration, models


@settings(max_examples=400, deadline=None)
@given(key=st.sampled_from(KEYS), value=EDGES)
def test_edge_value_validates_or_names_its_key(key: tuple, value) -> None:
    config = copy.deepcopy(BASE)
    node = config
    for part in key[:-1]:
        node = node[part]
    node[key[-1]] = value
    try:
        validate_config(config, "fuzz.yaml")
    except ConfigError as exc:
        message = str(exc)
        dotted = ".".join(str(p) for p in key)
        parent = ".".join(str(p) for p in key[:-1])
        # The key itself, or (for cross-key checks) the case or section it belongs to, is named.
        assert dotted in message or (parent and parent in message) or key[0] in message, (key, value, message)
        assert message.count("fuzz.yaml") >= 1
    else:
        assert not (isinstance(value, float) and not math.isfinite(value)), (key, value)
