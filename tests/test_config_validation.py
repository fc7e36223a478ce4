"""Config validation at load: declared ranges and choices, cross-field rules, property-based round trips.

Every numeric field declares its allowed range beside its unit and paper symbol (``_p(..., ge=/gt=/le=/lt=)``),
every closed vocabulary its ``choices``. Hypothesis draws values inside the declared ranges (they must load and
round-trip through YAML) and outside them (they must be rejected with the key, the value and the file named).
"""

from __future__ import annotations

import math
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any, get_type_hints

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from sdovon_mj import config as C


def leaf_fields(cls: type = C.RunConfig, prefix: str = "") -> list[tuple[str, Any, Any]]:
    """Return (dotted key, type, field metadata) of every non-section field of a config class."""
    out = []
    hints = get_type_hints(cls)
    for f in fields(cls):
        typ = hints[f.name]
        if is_dataclass(typ):
            out += leaf_fields(typ, f"{prefix}{f.name}.")
        else:
            out.append((prefix + f.name, typ, f.metadata))
    return out


def _elem_type(typ: Any) -> Any:
    """Return the element type of a tuple field (the type itself for scalars)."""
    return typ.__args__[0] if getattr(typ, "__origin__", None) is tuple else typ


LEAVES = leaf_fields()
BOUNDED = [(k, t, m) for k, t, m in LEAVES if m.get("limits") or m.get("choices") is not None]


def test_defaults_are_valid_and_every_number_declares_its_range() -> None:
    """The defaults pass validation; every int/float field (scalar or tuple) declares bounds or choices."""
    C.validate(C.RunConfig())
    missing = [k for k, t, m in LEAVES if _elem_type(t) in (int, float) and not m.get("limits") and m.get("choices") is None]
    assert not missing, f"numeric config fields without a declared range: {missing}"
    rows = {k: (unit, meaning) for k, _d, unit, _s, meaning in C.describe()}
    for key, _t, _meta in BOUNDED:  # the range sits beside the unit and meaning of the same declaration
        assert rows[key][0] and rows[key][1], key


def _inside(typ: Any, meta: Any) -> st.SearchStrategy:
    """Return a strategy of values allowed by a field's declaration (scalar or tuple)."""
    elem = _elem_type(typ)
    if meta.get("choices") is not None:
        one = st.sampled_from(meta["choices"])
    else:
        lim = meta.get("limits", {})
        lo = lim.get("ge", lim.get("gt"))
        hi = lim.get("le", lim.get("lt"))
        if elem is int:
            lo_i = -10**6 if lo is None else int(math.floor(lo)) + (1 if "gt" in lim and float(lo).is_integer() else 0)
            lo_i = max(lo_i, math.ceil(lo)) if lo is not None else lo_i
            hi_i = 10**6 if hi is None else int(math.ceil(hi)) - (1 if "lt" in lim and float(hi).is_integer() else 0)
            one = st.integers(lo_i, min(hi_i, lo_i + 10**6))
        else:
            one = st.floats(min_value=lo if lo is not None else -1e6, max_value=hi if hi is not None else (lo or 0) + 1e6,
                            exclude_min="gt" in lim, exclude_max="lt" in lim, allow_nan=False, allow_infinity=False)
    if getattr(typ, "__origin__", None) is tuple:
        n_lo, n_hi = meta.get("min_len") or 0, meta.get("max_len") or 3
        return st.lists(one, min_size=n_lo, max_size=max(n_lo, n_hi)).map(tuple)
    return one


def _outside(typ: Any, meta: Any) -> st.SearchStrategy:
    """Return a strategy of values a field's declaration rejects."""
    elem = _elem_type(typ)
    if meta.get("choices") is not None:
        bad = st.sampled_from(["no-such-choice", "", "X"]) if elem is str else st.integers(-50, 50)
        one = bad.filter(lambda v: v not in meta["choices"])
    else:
        lim = meta["limits"]
        options = []
        if "ge" in lim or "gt" in lim:
            lo = lim.get("ge", lim.get("gt"))
            below = st.floats(lo - 1e6, lo, exclude_max="ge" in lim, allow_nan=False)
            options.append(below.map(math.floor) if elem is int else below)
        if "le" in lim or "lt" in lim:
            hi = lim.get("le", lim.get("lt"))
            above = st.floats(hi, hi + 1e6, exclude_min="le" in lim, allow_nan=False)
            options.append(above.map(math.ceil) if elem is int else above)
        one = st.one_of(options)
        if elem is int:  # rounding toward the range must still leave it outside
            one = one.filter(lambda v: not _allowed_number(v, lim))
    if getattr(typ, "__origin__", None) is tuple:
        return st.lists(one, min_size=1, max_size=3).map(tuple)
    return one


def _allowed_number(v: float, lim: dict[str, float]) -> bool:
    """Return whether a number satisfies declared limits."""
    return (("ge" not in lim or v >= lim["ge"]) and ("gt" not in lim or v > lim["gt"])
            and ("le" not in lim or v <= lim["le"]) and ("lt" not in lim or v < lim["lt"]))


def _set_in(data: dict[str, Any], key: str, value: Any) -> None:
    """Set a dotted key in nested plain data."""
    *path, last = key.split(".")
    for p in path:
        data = data.setdefault(p, {})
    data[last] = list(value) if isinstance(value, tuple) else value


@st.composite
def valid_configs(draw: st.DrawFn) -> dict[str, Any]:
    """Draw YAML data setting 1-6 declared fields to allowed values."""
    picks = draw(st.lists(st.sampled_from(BOUNDED), min_size=1, max_size=6, unique_by=lambda r: r[0]))
    data: dict[str, Any] = {}
    for key, typ, meta in picks:
        _set_in(data, key, draw(_inside(typ, meta)))
    return data


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=valid_configs())
def test_random_valid_configs_load_and_round_trip(tmp_path: Path, data: dict[str, Any]) -> None:
    """Values inside every declared range load (unless a cross-field rule names the pair) and round-trip via YAML."""
    p = tmp_path / "cfg.yaml"
    p.write_text(yaml.safe_dump(data), encoding="utf-8")
    try:
        cfg = C.load_config(p)
    except C.ConfigError as e:
        assume("config keys" not in str(e))  # a cross-field rule (e.g. r_min < r_max): names both keys
        raise
    back = tmp_path / "back.yaml"
    C.save_config(cfg, back)
    assert C.load_config(back) == cfg
    assert C.dump_yaml(C.load_config(back)) == back.read_text(encoding="utf-8")


@st.composite
def invalid_value(draw: st.DrawFn) -> tuple[str, Any]:
    """Draw (key, a value outside the key's declared range or choices)."""
    key, typ, meta = draw(st.sampled_from(BOUNDED))
    if meta.get("choices") is None and not meta.get("limits"):
        assume(False)
    return key, draw(_outside(typ, meta))


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bad=invalid_value())
def test_random_invalid_values_are_rejected_naming_key_value_and_file(tmp_path: Path, bad: tuple[str, Any]) -> None:
    """A value outside its declared range is rejected from a YAML file (key + file named) and from --set (key named)."""
    key, value = bad
    data: dict[str, Any] = {}
    _set_in(data, key, value)
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(C.ConfigError) as e:
        C.load_config(p)
    assert f"'{key}'" in str(e.value) and str(p) in str(e.value), str(e.value)
    shown = yaml.safe_dump(list(value) if isinstance(value, tuple) else value, default_flow_style=True).strip()
    shown = shown.removesuffix("...").strip()
    with pytest.raises(C.ConfigError) as e:
        C.load_config(None, [f"{key}={shown}"])
    assert f"'{key}'" in str(e.value), str(e.value)


@pytest.mark.parametrize("override, words", [
    ("place.k_v=-3", ["'place.k_v'", "-3", ">= 1"]),
    ("observe.width=0", ["'observe.width'", ">= 1"]),
    ("perceive.score_threshold=1.5", ["'perceive.score_threshold'", "<= 1"]),
    ("semantics.region_labels=[]", ["'semantics.region_labels'", "at least 1"]),
    ("world.scene_mode=photo", ["'world.scene_mode'", "clean, scan"]),
    ("observe.targeted_distance=[1.0]", ["'observe.targeted_distance'", "at least 2"]),
    ("agent.hfov=.nan", ["'agent.hfov'", "finite"]),
    ("convert.units=furlong", ["'convert.units'", "furlong"]),
    ("convert.up=sideways", ["'convert.up'", "+Z"]),
])
def test_out_of_range_overrides_name_key_value_and_range(override: str, words: list[str]) -> None:
    """The issue's examples: each bad --set names the key, the value and what is allowed."""
    with pytest.raises(C.ConfigError) as e:
        C.load_config(None, [override])
    for w in words:
        assert w in str(e.value), (w, str(e.value))


@pytest.mark.parametrize("overrides, keys", [
    (["observe.r_min=2.0"], ["observe.r_min", "observe.r_max"]),
    (["observe.depth_min=12"], ["observe.depth_min", "observe.depth_max"]),
    (["nav.depth_max=0.2"], ["nav.depth_min", "nav.depth_max"]),
    (["observe.targeted_distance=[2.0, 0.5]"], ["observe.targeted_distance"]),
    (["agent.camera_height=0.05"], ["agent.camera_height", "observe.obstacle_min_height"]),
    (["observe.camera_heights=[0.05]"], ["observe.camera_heights", "observe.obstacle_min_height"]),
    (["observe.obstacle_max_height=0.05"], ["observe.obstacle_max_height"]),
    (["observe.nav_slice=plane", "observe.h_map=1.2"], ["observe.h_map", "agent.height"]),
])
def test_cross_field_rules(overrides: list[str], keys: list[str], tmp_path: Path) -> None:
    """Values that contradict each other are rejected naming both keys; from a file, the file is named too."""
    with pytest.raises(C.ConfigError) as e:
        C.load_config(None, overrides)
    for k in keys:
        assert k in str(e.value), str(e.value)
    data: dict[str, Any] = {}
    for o in overrides:
        k, v = o.split("=", 1)
        _set_in(data, k, yaml.safe_load(v))
    p = tmp_path / "cross.yaml"
    p.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(C.ConfigError, match=str(p).replace(".", r"\.")):
        C.load_config(p)


def test_unreadable_config_files_are_named(tmp_path: Path) -> None:
    """A config that is not UTF-8 text or is a folder is named with the cause (not a traceback)."""
    p = tmp_path / "latin1.yaml"
    p.write_bytes("name: caf\xe9\n".encode("latin-1"))
    with pytest.raises(C.ConfigError, match="latin1.yaml.*not UTF-8"):
        C.load_config(p)
    with pytest.raises(C.ConfigError, match="cannot be read"):
        C.load_config(tmp_path)
