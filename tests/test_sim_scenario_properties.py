"""Every scenario, from a dict or a TOML file of any bytes, is a valid Scenario or a one-line
ScenarioError naming the key; an accepted one compiles in MuJoCo (its numbers are within the
physical ranges the scene can hold). Hypothesis draws the inputs."""

from __future__ import annotations

import math

import mujoco
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from biped.errors import BipedError
from biped.sim.scenario import RANGES, Scenario, keys, toml_values
from biped.sim.scene import build_scene

_SCALAR = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-2, max_value=2),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.booleans(),
    st.text(max_size=6),
    st.sampled_from(
        [
            "none",
            "workspace",
            "joint-pd",
            "fast",
            "faithful",
            "-x",
            "-y",
            "qp",
            "sensed",
            "wendlandt",
            "",
            "1e300",
        ]
    ),
)
_VALUE = st.one_of(
    _SCALAR,
    st.lists(_SCALAR, max_size=13),
    st.lists(st.floats(min_value=-1, max_value=1.5), min_size=3, max_size=3),
    st.dictionaries(st.text(max_size=3), _SCALAR, max_size=2),
)
# every key's default (to_dict leaves out keys added later while they are at their default)
_DEFAULTS = {**{k: getattr(Scenario(), k) for k in keys()}, **Scenario().to_dict()}


def _near_default(key):
    """A value close to W's (so that many drawn scenarios are valid and reach MuJoCo)."""
    d = _DEFAULTS[key]
    if isinstance(d, float):
        return st.floats(min_value=0.0, max_value=3 * d if d > 0 else 1.0)
    if isinstance(d, (list, tuple)) and d and isinstance(d[0], float):
        return st.lists(st.floats(min_value=-1.5, max_value=1.5), min_size=len(d), max_size=len(d)).map(
            lambda v, d=d: [a + b for a, b in zip(d, v, strict=True)]
        )
    return st.just(d)


_NOT_MODEL = [k for k in keys() if k != "model"]
_SCENARIO = st.one_of(
    st.dictionaries(st.sampled_from(keys()), _VALUE, max_size=4),
    st.sets(st.sampled_from(_NOT_MODEL), max_size=4).flatmap(
        lambda ks: st.fixed_dictionaries({k: _near_default(k) for k in sorted(ks)})
    ),
)


def _one_line_naming_a_key(exc: BaseException, values: dict) -> None:
    msg = str(exc)
    assert "\n" not in msg, msg
    assert any(k in msg for k in values) or "unknown scenario key" in msg, (values, msg)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_SCENARIO)
def test_any_scenario_is_valid_or_a_one_line_error_naming_the_key(values):
    try:
        s = Scenario.from_dict(values)
    except BipedError as exc:
        _one_line_naming_a_key(exc, values)
        event("rejected")
        return
    event("accepted")
    # accepted: every number finite and within its physical range; MuJoCo compiles the scene
    for k, v in s.to_dict().items():
        for x in v if isinstance(v, list) else [v]:
            if isinstance(x, float):
                assert math.isfinite(x), (k, v)
    lo, hi, _ = RANGES["duration_s"]
    assert lo < s.duration_s <= hi
    assert math.dist(s.block_velocity_m_s, (0, 0, 0)) <= RANGES["block_speed_m_s"][1]
    try:
        scene = build_scene(s)
    except BipedError as exc:  # a model name that is no shipped model and no file
        assert "model" in values and "model" in str(exc), (values, exc)
        return
    data = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, data)
    assert all(math.isfinite(a) for a in data.qacc)


@settings(
    max_examples=200,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    st.one_of(
        st.binary(max_size=60),
        st.lists(
            st.tuples(
                st.sampled_from([*keys(), "x", "[t]", "a.b"]),
                st.sampled_from(
                    [
                        "1",
                        "-1e300",
                        "nan",
                        "inf",
                        '"a"',
                        "[1,2,3]",
                        "true",
                        "{a=1}",
                        "'\\xff'",
                        "[",
                        "1979-05-27",
                    ]
                ),
            ),
            max_size=4,
        ).map(lambda kv: "\n".join(f"{k} = {v}" for k, v in kv).encode()),
        st.binary(max_size=20).map(lambda b: b"duration_s = 1.0\n# " + b + b"\n"),
    )
)
def test_any_scenario_file_is_values_or_a_one_line_error(tmp_path, data):
    path = tmp_path / "s.toml"
    path.write_bytes(data)
    try:
        values = toml_values(path)
        s = Scenario.from_dict(values)
    except BipedError as exc:
        assert "\n" not in str(exc), str(exc)
        return
    assert set(values) <= set(keys())
    assert s.duration_s > 0
