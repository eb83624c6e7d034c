"""Every command line of `biped push`, `biped walk` and `biped posture` ends in the start of the
work or a one-line error naming the parameter, before any work, never a traceback or a hang; a
rejected line leaves no folder behind. Hypothesis draws the lines; the work itself (simulation,
output writing, gain design) is replaced by a sentinel so that each example takes milliseconds:
reaching the sentinel means every check passed. (`biped sweep`'s spaces: test_sweep_inputs.py.)
"""

from __future__ import annotations

import itertools
import time
import types

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import biped.outputs.posture
import biped.outputs.walk
import biped.sim.push
from biped.cli import main
from biped.sim.scenario import keys


class _WorkStarted(Exception):
    """Raised in place of the work: every check before it passed."""


def _sentinel(*args, **kwargs):
    raise _WorkStarted


_counter = itertools.count()


def _examples(n: int):
    """Hypothesis settings of these properties: ``n`` lines, no deadline (the first line imports
    the command), the fixtures shared by the lines of one test (each line makes its own folder)."""
    return settings(
        max_examples=n,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


# numbers as the shell would pass them: floats in every syntax, huge, tiny, non-finite, signs
_NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(min_value=-10, max_value=10).map(lambda x: f"{x:.3g}"),
    st.integers(min_value=-(10**20), max_value=10**20).map(str),
    st.sampled_from(
        [
            "0",
            "-0",
            "1e300",
            "-1e300",
            "1e-300",
            "-1e6",
            "nan",
            "-inf",
            "inf",
            "x",
            "",
            "1,5",
            "0x10",
            "1e",
            "--",
            "-.5",
            "+3",
        ]
    ),
)


def _run(capsys, argv):
    """(status, last stderr line, whether the work started) of one command line."""
    t0 = time.perf_counter()
    try:
        rc = main(argv)
        started = False
    except SystemExit as exc:  # argparse: unknown option, wrong count or type of values
        rc, started = exc.code, False
    except _WorkStarted:
        rc, started = None, True
    err = capsys.readouterr().err
    assert time.perf_counter() - t0 < 20.0, argv  # no hang: the checks take milliseconds
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    return rc, (lines[-1] if lines else ""), started


def _check(capsys, tmp_path, command, argv, names):
    """Run ``command argv --out NEW``; a rejection is status 2 with one line naming one of
    ``names`` (or one of its option words), and leaves no folder behind."""
    out = tmp_path / f"run-{next(_counter)}" / "deep"
    rc, last, started = _run(capsys, [*command, *argv, "--out", str(out)])
    if not started:
        prog = "biped " + " ".join(command)
        assert rc == 2, (argv, rc, last)
        assert last.startswith(f"{prog}: error: "), (argv, last)
        assert any(n in last for n in names), (argv, last)
    assert not out.parent.exists(), "a rejected or failed run left its (empty) folder behind"
    return started


# ---------------------------------------------------------------------------------------------
# biped push

_PUSH_SINGLE = {  # option -> the words its error may name
    "--duration": ("duration_s",),
    "--block-mass": ("block_mass_kg",),
    "--timestep": ("physics_timestep_s", "control_rate_hz", "contact_timeconst_s"),
    "--seed": ("seed",),
}
_PUSH_TRIPLE = {"--block-position": ("block_position_m",), "--block-velocity": ("block_velocity_m_s",)}
_PUSH_CHOICE = {
    "--controller": ["workspace", "joint-pd", "pd", ""],
    "--physics": ["faithful", "fast", "slow"],
    "--distribution": ["statics", "printed", "qp", "x"],
}
_SET_VALUE = st.one_of(
    _NUMBER,
    st.sampled_from(
        ["[1, 2, 3]", "[1, 2]", "'a'", '"-x"', "none", "[nan, 0, 0]", "{a = 1}", "true", "[]", "[[1]]"]
    ),
)


@st.composite
def _push_line(draw):
    argv, names = [], []
    for opt in draw(st.sets(st.sampled_from(sorted(_PUSH_SINGLE)), max_size=3)):
        argv += [opt, draw(_NUMBER)]
        names += [opt, *_PUSH_SINGLE[opt]]
    for opt in draw(st.sets(st.sampled_from(sorted(_PUSH_TRIPLE)), max_size=2)):
        argv += [opt, *draw(st.lists(_NUMBER, min_size=2, max_size=4))]
        names += [opt, *_PUSH_TRIPLE[opt]]
    for opt in draw(st.sets(st.sampled_from(sorted(_PUSH_CHOICE)), max_size=2)):
        argv += [opt, draw(st.sampled_from(_PUSH_CHOICE[opt]))]
        names.append(opt)
    for _ in range(draw(st.integers(0, 2))):
        key = draw(st.one_of(st.sampled_from(keys()), st.sampled_from(["", "speed", "x y"])))
        argv += ["--set", f"{key}={draw(_SET_VALUE)}"]
        names += ["--set", key or "KEY=VALUE"]
    if draw(st.booleans()):
        argv += ["--model", draw(st.sampled_from(["wendlandt", "", "nope", "/dev/null", "/nonexistent.xml"]))]
        names += ["--model", "model"]
    return argv, names or ["--"]


@_examples(150)
@given(_push_line())
def test_any_push_line_starts_the_simulation_or_is_a_one_line_error(tmp_path, capsys, monkeypatch, line):
    monkeypatch.setattr(biped.sim.push, "simulate", _sentinel)
    argv, names = line
    _check(capsys, tmp_path, ["push"], [*argv, "--quiet", "--no-video"], names)


# ---------------------------------------------------------------------------------------------
# biped walk


@st.composite
def _walk_line(draw):
    argv, names = [], []
    gait = draw(st.sampled_from(["forward", "upstairs", "jump", "demo", "run"]))
    argv += ["--gait", gait]
    names.append("--gait")
    options = {
        "--steps": st.one_of(st.integers(-5, 10**7).map(str), _NUMBER),
        "--speed": _NUMBER,
        "--stair-rise": _NUMBER,
        "--stair-run": _NUMBER,
        "--rate": _NUMBER,
    }
    for opt in draw(st.sets(st.sampled_from(sorted(options)), max_size=3)):
        argv += [opt, draw(options[opt])]
        names.append(opt)
    if "--steps" in argv or "--speed" in argv:
        names.append("the motion lasts")  # a bound on steps x pace, naming both options
    if draw(st.booleans()):
        argv.append("--no-somersault")
    return argv, names


@_examples(120)
@given(_walk_line())
def test_any_walk_line_starts_the_motion_or_is_a_one_line_error(tmp_path, capsys, monkeypatch, line):
    monkeypatch.setattr(biped.outputs.walk, "write_walk", _sentinel)
    argv, names = line
    _check(capsys, tmp_path, ["walk"], [*argv, "--quiet"], names)


# ---------------------------------------------------------------------------------------------
# biped posture: pendulum and body-leg run for real (short runs, figures stubbed out), so the
# library's own checks of gains, x0 and set points are part of the property; gains' design
# (~12 s) is the sentinel.


class _Figure:
    def savefig(self, *args, **kwargs):
        pass


_STUB_VIZ = types.SimpleNamespace(
    pendulum_attitude_figure=lambda *a, **k: _Figure(),
    body_leg_figure=lambda *a, **k: _Figure(),
    comparison_figure=lambda *a, **k: _Figure(),
    animate=lambda *a, **k: None,
)

# time steps and durations whose valid pairs stay under ~500 steps (fast), plus the invalid ones
_DT = st.one_of(
    st.sampled_from(["0.02", "0.01", "0.05", "1e-9", "0", "-0.01", "nan", "inf", "1.5", "x", "1e300"]),
    _NUMBER,
)
_DURATION = st.sampled_from(["0.5", "2", "0", "-1", "nan", "inf", "1e6", "1e300", "x"])


@st.composite
def _posture_line(draw):
    model = draw(st.sampled_from(["pendulum", "body-leg"]))
    n = 2 if model == "pendulum" else 4
    argv = ["--dt", draw(_DT), "--duration", draw(_DURATION)]
    names = ["--dt", "--duration"]
    vectors = {"--gains": n, "--x0": n, "--alpha": n // 2}
    for opt in draw(st.sets(st.sampled_from(sorted(vectors)), max_size=2)):
        count = draw(st.sampled_from([vectors[opt], vectors[opt], vectors[opt] + 1]))
        argv += [opt, *draw(st.lists(_NUMBER, min_size=count, max_size=count))]
        names += [opt, opt.lstrip("-"), "gains" if opt == "--gains" else "state", "alpha", "x0"]
    for _ in range(draw(st.integers(0, 2))):
        name = draw(st.sampled_from(["m", "l", "g", "I", "m1", "m2", "l1", "l2", "L", "x", ""]))
        argv += ["--param", f"{name}={draw(_NUMBER)}"]
        names += ["--param", "parameter", name or "NAME=VALUE"]
    if draw(st.booleans()):
        argv += ["--integrator", draw(st.sampled_from(["euler", "heun", "rk4", "adaptive", "x"]))]
        names.append("--integrator")
    names += ["diverged", "non-finite"]  # a closed loop that blows up: said as such, exit 2
    return [model], argv, names


@_examples(150)
@given(_posture_line())
def test_any_posture_line_is_a_run_or_a_one_line_error(tmp_path, capsys, monkeypatch, line):
    monkeypatch.setattr(biped.outputs.posture, "viz", _STUB_VIZ)
    model, argv, names = line
    out = tmp_path / f"run-{next(_counter)}"
    rc, last, _ = _run(capsys, ["posture", *model, *argv, "--no-animation", "--out", str(out)])
    if rc == 0:
        assert (out / "summary.json").is_file() and (out / "trajectory.csv").is_file()
    else:
        assert rc == 2, (argv, rc, last)
        assert last.startswith(f"biped posture {model[0]}: error: "), (argv, last)
        assert any(n in last for n in names), (argv, last)
        assert not out.exists(), "a rejected or failed run left its folder behind"


@_examples(120)
@given(
    st.dictionaries(
        st.sampled_from(["--grid", "--k1-max", "--k2-max", "--rate-gains", "--poles", "--param"]),
        st.lists(
            st.one_of(_NUMBER, st.sampled_from(["-1", "-2", "-3", "-1", "401", "402", "2"])),
            min_size=1,
            max_size=5,
        ),
        min_size=1,
        max_size=3,
    )
)
def test_any_gains_line_starts_the_design_or_is_a_one_line_error(tmp_path, capsys, monkeypatch, options):
    monkeypatch.setattr(biped.outputs.posture, "run_gains", _sentinel)
    argv, names = [], []
    for opt, values in options.items():
        argv += [opt, *(values if opt != "--param" else [f"m1={values[0]}"])]
        names += [opt, "parameter"]
    _check(capsys, tmp_path, ["posture", "gains"], argv, names)


# ---------------------------------------------------------------------------------------------
# the reported cases, each named


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["push", "--block-velocity", "-1e6", "0", "0"], "at most 100 m/s"),  # a number, not an option
        (["push", "--duration", "1e6"], "duration_s must be in (0, 60]"),
        (["push", "--set", "duration_s=1e300"], "duration_s must be in (0, 60]"),
        (["walk", "--gait", "forward", "--steps", "1000000"], "--steps must be in [1, 100]"),
        (["walk", "--speed", "1e6"], "--speed must be in [0.1, 2.5]"),
        (["walk", "--gait", "upstairs", "--steps", "100", "--speed", "0.1"], "more than the limit of 300 s"),
        (["posture", "pendulum", "--dt", "1e-9"], "more than the limit of 1,000,000"),
        (["posture", "gains", "--grid", "100000"], "--grid must be in [2, 401]"),
        (["posture", "gains", "--poles", "-1", "-1", "-1", "-1"], "-1 is given 4 times"),
        (["posture", "gains", "--grid", "0", "--"], "the bare '--' after --grid ends the options"),
        (
            ["posture", "pendulum", "--poles", "1", "2"],
            "biped posture pendulum: error: unrecognized arguments: --poles",
        ),
    ],
)
def test_reported_inputs_are_one_line_errors(tmp_path, capsys, argv, says):
    out = tmp_path / "new"
    rc, last, started = _run(capsys, [*argv, "--out", str(out)])
    assert not started and rc == 2 and says in last, last
    assert last.startswith(f"biped {argv[0]}"), last
    assert not out.exists()
