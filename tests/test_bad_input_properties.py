"""Property-based bad input (issue 9, item 3): whatever a dataset file, a sidecar, a --set value
or a plugin attribute holds, the result is the valid object or one clear InputError: never
another exception, never a value outside the documented limits."""
from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibrofriction.rigs import rig as rig_module
from vibrofriction.data.datasets import COLUMN_LIMITS, read_dataset
from vibrofriction.errors import InputError
from vibrofriction.params import LIMITS, RigParameters, apply_overrides, default_friction

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
# cells a broken export or a hand edit produces
CELL = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10 ** 30, 10 ** 30).map(str),
    st.sampled_from(["", " ", "nan", "inf", "-inf", "1e400", "1e-400", "0x10", "1,5", "abc",
                     "1e308", "-0", "+.5", "5.", "1e6", "2e9"]),
)
HEADER = st.lists(st.sampled_from(["time_s", "position_m", "velocity_m_per_s",
                                   "drive_force_N", "friction_force_N", "normal_force_N",
                                   "support_velocity_m_per_s", "bogus"]),
                  min_size=1, max_size=5, unique=True)


@SETTINGS
@given(header=HEADER, rows=st.lists(st.lists(CELL, min_size=1, max_size=6), max_size=8),
       sidecar=st.one_of(st.none(), st.dictionaries(
           st.sampled_from(["mass_kg", "normal_force_N", "model", "sample_rate_Hz", "x"]),
           st.one_of(st.floats(allow_nan=True), st.text(max_size=5), st.booleans(),
                     st.none()))))
def test_any_dataset_file_reads_or_is_one_clear_error(header, rows, sidecar):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "r.csv"
        path.write_text(",".join(header) + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
        if sidecar is not None:
            path.with_suffix(".json").write_text(json.dumps(sidecar))
        try:
            dataset = read_dataset(path)
        except InputError as exc:
            assert str(exc) and "\n" not in str(exc).strip()
            return
        for name, values in dataset.columns.items():
            assert all(math.isfinite(v) for v in values), name
            if name in COLUMN_LIMITS:
                assert max(abs(v) for v in values) <= COLUMN_LIMITS[name], name


@SETTINGS
@given(name=st.sampled_from(sorted(LIMITS) + ["law", "unknown_name"]),
       value=st.one_of(CELL, st.sampled_from(["dahl", "lugre", "Dahl", ""])))
def test_any_set_value_is_a_valid_parameter_or_one_clear_error(name, value):
    try:
        rig, friction = apply_overrides(RigParameters(), default_friction("dahl"),
                                        {name: value})
    except InputError as exc:
        assert str(exc) and name.split("_")[0] in str(exc) or "unknown" in str(exc)
        return
    for params in (rig, friction):
        for field, (smallest, largest) in LIMITS.items():
            if hasattr(params, field):
                value = getattr(params, field)
                for x in value if isinstance(value, tuple) else (value,):  # (gms: a list)
                    assert math.isfinite(x) and abs(x) <= largest
                    assert x == 0 or abs(x) >= smallest


@SETTINGS
@given(attribute=st.sampled_from(["mu", "stiffness", "alpha", "sigma1", "viscous",
                                  "force_offset", "sensor_lag", "normal"]),
       value=CELL)
def test_any_plugin_attribute_compiles_to_a_plain_number_or_is_named(attribute, value):
    spec = rig_module.build_spec(RigParameters(), default_friction("dahl"), 1e-5)
    friction = next(p for p in spec.plugins if p.name == "friction")
    friction.config = {**dict(friction.config), attribute: value}
    try:
        spec.compile()
    except ValueError as exc:
        assert f"'{attribute}'" in str(exc)
        return
    text = value.strip()
    if text:  # (an empty value is MuJoCo's absent key: the default)
        number = float(text)
        assert math.isfinite(number) and abs(number) <= 1e18
        assert number == 0 or abs(number) >= 2.2e-308
        assert "x" not in text.lower()
