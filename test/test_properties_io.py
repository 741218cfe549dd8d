"""Hostile input thrown at the CSV table reader and the parameter-set YAML loader.

Either a table/parameter set that holds only finite, physically possible values, or the
project's own error with a one-line message; never another exception.
"""

from __future__ import annotations

import math

import numpy as np
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.errors import JointwearError
from jointwear_ros.io.tables import ABSOLUTE_ZERO, read_table
from jointwear_ros.model import load_parameter_set_info, paper_wear_model

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

COLUMNS = ["speed", "tau_f", "tau_f_std", "load_torque", "temperature", "position", "cycle", "time", "lube_hours",
           "note", "", "speed ", "é", "tau_f"]
CELLS = st.one_of(
    st.sampled_from(["nan", "NaN", "inf", "-inf", "Infinity", "", " ", "-0", "1e309", "-1e309", "1e-320", "-5",
                     "-300", "0x10", "1_000", "10,5", '"', "\x00", "∞", "١٢", "40", "0.1", "47.0", "0.0728"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=6),
)


GOOD = {"speed": st.floats(0, 280), "tau_f": st.floats(0.02, 0.3), "tau_f_std": st.floats(1e-4, 5e-3),
        "load_torque": st.floats(0, 1), "temperature": st.floats(20, 60), "position": st.floats(-3, 3),
        "cycle": st.integers(0, 9), "time": st.floats(0, 1e6), "lube_hours": st.floats(0, 1e4)}


@st.composite
def csv_texts(draw):
    """Mostly well-formed tables with a few hostile cells, headers or row lengths."""
    if draw(st.integers(0, 4)) == 0:  # a hostile header
        header = draw(st.lists(st.sampled_from(COLUMNS), min_size=1, max_size=6))
        if draw(st.booleans()):
            header = ["speed", "tau_f", *header]
    else:
        extra = draw(st.lists(st.sampled_from(["tau_f_std", "load_torque", "temperature", "position", "cycle",
                                               "time", "lube_hours"]), unique=True, max_size=4))
        header = ["speed", "tau_f", *extra]
    n = draw(st.integers(0 if draw(st.integers(0, 9)) == 0 else 1, 5))
    rows = []
    for _ in range(n):
        row = [repr(draw(GOOD[h])) if h in GOOD else draw(CELLS) for h in header]
        for j in draw(st.lists(st.integers(0, len(header) - 1), max_size=1)):
            row[j] = draw(CELLS)
        if draw(st.integers(0, 19)) == 0:
            row = row[:-1] if draw(st.booleans()) else [*row, "1"]
        rows.append(row)
    lines = [",".join(header)] + [",".join(r) for r in rows]
    if draw(st.booleans()):
        lines.insert(0, "# a comment")
    return "\n".join(lines) + draw(st.sampled_from(["\n", "", "\r\n"]))


def _check_table(t):
    assert len(t) >= 1
    assert "speed" in t and "tau_f" in t
    for name in t.names:
        assert np.all(np.isfinite(t[name])), f"non-finite value in column {name!r} accepted"
    assert np.all(t.speed >= 0), "negative speed accepted"
    if "tau_f_std" in t:
        assert np.all(t["tau_f_std"] >= 0), "negative tau_f_std accepted"
    if "temperature" in t:
        assert np.all(t["temperature"] >= ABSOLUTE_ZERO), "temperature below absolute zero accepted"


@SETTINGS
@given(text=csv_texts())
def test_csv_reader_gives_a_clean_table_or_one_line_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("csv") / "obs.csv"
    path.write_text(text, encoding="utf-8")
    try:
        t = read_table(path)
    except JointwearError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(path)), str(exc)
        return
    _check_table(t)


@SETTINGS
@given(data=st.binary(max_size=200))
def test_csv_reader_on_arbitrary_bytes(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("bin") / "obs.csv"
    path.write_bytes(data)
    try:
        t = read_table(path)
    except JointwearError as exc:
        assert "\n" not in str(exc)
        return
    _check_table(t)


def test_nan_in_every_optional_csv_column_is_refused_with_the_column_named(tmp_path):
    for column in ("tau_f_std", "load_torque", "temperature", "position", "cycle", "time", "lube_hours"):
        path = tmp_path / f"{column}.csv"
        path.write_text(f"speed,tau_f,{column}\n10,0.1,1.0\n20,0.1,nan\n")
        try:
            read_table(path)
        except JointwearError as exc:
            assert f"column {column!r}, row 2 (line 3): 'nan' is not a finite number" in str(exc)
        else:
            raise AssertionError(f"NaN in optional column {column!r} was accepted")


# -- parameter sets -------------------------------------------------------------------
VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([".nan", ".inf", "-.inf", "1e400", "yes", "null", "[1, 2]", "{a: 1}", "0", "-1", "~", "'0.04'"]),
    st.text(max_size=5),
    st.integers(-10**30, 10**30),
    st.booleans(),
    st.none(),
)
NAMES = st.sampled_from(["Fc0", "Fctm", "Fstm", "vstm", "Fs0", "FsT", "vs0", "vsT", "Fv0", "FvT", "Tv0", "Fsw",
                         "Fvw", "vsw", "extra", "", "ü"])


def _scalar(v):
    return yaml.safe_dump(v).replace("\n...\n", "").strip() if not isinstance(v, str) else v


@st.composite
def paramset_texts(draw):
    base = yaml.safe_load((load_parameter_set_info("ref-2011r").path).read_text())
    doc = draw(st.sampled_from(["mapping", "junk"]))
    if doc == "junk":
        return draw(st.one_of(st.text(max_size=40), st.sampled_from(["[]", "3", "parameters: 3", "---\n- a"])))
    lines = [f"name: {draw(st.text(max_size=8).map(repr))}"]
    if draw(st.booleans()):
        lo, hi = draw(VALUES), draw(VALUES)
        lines.append(f"valid:\n  temperature: [{_scalar(lo)}, {_scalar(hi)}]")
    lines.append("parameters:")
    params = dict(base["parameters"])
    for _ in range(draw(st.integers(0, 3))):
        params[draw(NAMES)] = draw(VALUES)
    for k, v in params.items():
        lines.append(f"  {k!r}: {_scalar(v)}")
    return "\n".join(lines) + "\n"


@SETTINGS
@given(text=paramset_texts())
def test_parameter_set_loader_gives_finite_in_bounds_values_or_its_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("ps") / "set.yaml"
    path.write_text(text, encoding="utf-8")
    try:
        info = load_parameter_set_info(str(path))
    except JointwearError as exc:
        assert "\n" not in str(exc), str(exc)
        return
    params = info.parameters()
    for p in params.values():
        assert math.isfinite(p.value), p
        assert p.min <= p.value <= p.max, f"{p.name} = {p.value} outside its bounds [{p.min}, {p.max}]"
    lo, hi = info.valid.get("temperature", (20.0, 60.0))
    assert ABSOLUTE_ZERO <= lo <= hi, info.valid
    # a loaded set evaluates to finite friction inside its own valid range
    m = paper_wear_model()
    t = min(max(40.0, lo), hi) if math.isfinite(hi) else max(40.0, lo)
    tau = m.evaluate(m.make_params(params), speed=np.array([0.0, 47.0, 280.0]), load_torque=0.1,
                     temperature=t, wear=35.0)
    assert np.isfinite(tau).all() or abs(t) > 1e3, (params, t, tau)


@SETTINGS
@given(data=st.binary(max_size=120))
def test_parameter_set_loader_on_arbitrary_bytes(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("psb") / "set.yaml"
    path.write_bytes(data)
    try:
        load_parameter_set_info(str(path))
    except JointwearError as exc:
        assert "\n" not in str(exc)
