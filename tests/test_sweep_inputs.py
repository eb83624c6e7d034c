"""Every input of `biped sweep` ends in a result or a one-line error naming the parameter, before
any work: the reported cases, then hypothesis over the grid file's and the command line's spaces
(``--dry-run``: validate only, so the property tests stay fast)."""

from __future__ import annotations

import os
import time

import pytest
from _helpers import one_line_error, tiny_sweep_argv
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from biped.cli import main
from biped.errors import BipedError
from biped.sim.scenario import keys as scenario_keys
from biped.sim.sweep import MAX_TRIALS, SweepSpec


def _sweep(capsys, *args):
    rc = main(["sweep", *args])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _status(capsys, argv) -> tuple[int, str]:
    """(exit status, last stderr line) of ``biped argv``: 0 or 2, never a traceback."""
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse: a value of the wrong type for an int/float option
        rc = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert rc in (0, 2), err
    return rc, (err.strip().splitlines()[-1] if rc == 2 else "")


def _one_line_error(err: str) -> str:
    return one_line_error(err, "sweep")


# ---------------------------------------------------------------------------------------------
# the reported cases


@pytest.mark.parametrize(
    ("toml", "names"),
    [
        (b"[grid]\nspeed_m_s = [1.0]\n# caf\xe9\n", "not UTF-8"),
        (b'launch_distance_m = "x"\n', "launch_distance_m"),
        (b'[grid]\nspeed_m_s = {start = "a", stop = 2, num = 3}\n', "speed_m_s: start"),
        (b'[grid]\nspeed_m_s = {start = "a"}\n', "speed_m_s"),
        (b"[grid]\nspeed_m_s = {start = 1, stop = 2, num = 100000000}\n", f"{MAX_TRIALS}"),
        (
            b"[grid]\nspeed_m_s = {start = 1, stop = 2, num = 1000}\n"
            b"direction_deg = {start = 0, stop = 359, num = 1000}\n"
            b"height_m = {start = 1, stop = 1.5, num = 10}\n",
            f"more than {MAX_TRIALS}",
        ),
        (b"seed = -1\n", "seed"),
        (b"samples = 2.5\n", "samples"),
        (b"torque_limits = 3\n", "torque_limits"),
        (b"model = 3\n", "model"),
    ],
)
def test_bad_grid_files_are_one_line_errors_before_any_work(tmp_path, capsys, toml, names):
    grid = tmp_path / "g.toml"
    grid.write_bytes(toml)
    out = tmp_path / "runs" / "s.parquet"
    t0 = time.perf_counter()
    rc, _, err = _sweep(capsys, "--grid", str(grid), "--out", str(out), "--quiet")
    assert time.perf_counter() - t0 < 5.0
    assert rc == 2 and names in _one_line_error(err)
    assert not (tmp_path / "runs").exists()


def test_speed_zero_says_it_must_be_positive(tmp_path, capsys):
    rc, _, err = _sweep(capsys, "--speed", "0", "--out", str(tmp_path / "s.parquet"))
    assert rc == 2 and "speed_m_s" in (line := _one_line_error(err)) and "must be > 0" in line


def test_more_workers_than_twice_the_cores_is_refused_before_any_process_starts(tmp_path, capsys):
    # --workers 100000 used to be accepted (one process per chunk of trials, ~0.2 GB each)
    limit = max(4, 2 * (os.cpu_count() or 1))
    out = tmp_path / "runs" / "s.parquet"
    rc, _, err = _sweep(capsys, *tiny_sweep_argv(out, "--workers", "100000")[1:])
    line = _one_line_error(err)
    assert rc == 2 and "workers" in line and f"from 1 to {limit}" in line and "100000" in line
    assert not (tmp_path / "runs").exists()
    rc, _, _ = _sweep(capsys, *tiny_sweep_argv(out, "--workers", str(limit), "--dry-run")[1:])
    assert rc == 0


@pytest.mark.parametrize("option", ["--mass", "--direction", "--speed", "--duration"])
def test_an_option_given_a_bare_double_dash_names_the_option(tmp_path, capsys, option):
    # hypothesis found '--direction=--': argparse passed [] on and the axis parser raised AttributeError
    rc, line = _status(capsys, ["sweep", "--dry-run", f"{option}=--", "--out", str(tmp_path / "s.parquet")])
    assert rc == 2 and option in line and "needs a value" in line


def test_an_aim_below_half_the_block_is_refused_before_any_trial(tmp_path, capsys):
    # the block starts at the aim height: 0.02 m put a 10 cm cube 30 mm into the floor, and the
    # sweep stopped at its first trial with the scenario's error
    rc, _, err = _sweep(capsys, "--height", "0.02,1", "--out", str(tmp_path / "runs" / "s.parquet"))
    line = _one_line_error(err)
    assert rc == 2 and "height_m must be >= 0.05 m" in line and "got 0.02" in line
    assert not (tmp_path / "runs").exists()


def test_an_unknown_plot_type_is_refused_before_the_sweep(tmp_path, capsys):
    out = tmp_path / "runs" / "s.parquet"
    rc, _, err = _sweep(capsys, *tiny_sweep_argv(out, "--plot", str(tmp_path / "x.xyz"))[1:])
    line = _one_line_error(err)
    assert rc == 2 and "--plot" in line and "'.png'" not in line and ".png" in line
    assert not (tmp_path / "runs").exists()


def test_an_unreachable_scheduler_fails_fast_and_leaves_nothing(tmp_path, capsys):
    out = tmp_path / "runs" / "s.parquet"
    t0 = time.perf_counter()
    rc, _, err = _sweep(
        capsys,
        "--speed",
        "3",
        "--direction",
        "0",
        "--quiet",
        "--out",
        str(out),
        "--scheduler",
        "tcp://127.0.0.1:1",
    )
    assert time.perf_counter() - t0 < 10.0
    line = _one_line_error(err)
    assert rc == 2 and "scheduler" in line and "tcp://127.0.0.1:1" in line
    assert not (tmp_path / "runs").exists()


def test_dry_run_checks_and_counts_without_running(tmp_path, capsys):
    out = tmp_path / "s.parquet"
    rc, stdout, _ = _sweep(
        capsys, "--speed", "1:9:10", "--direction", "0:315:8", "--dry-run", "--out", str(out)
    )
    assert rc == 0 and "80 trials" in stdout and not out.exists()


# ---------------------------------------------------------------------------------------------
# property: the grid file's space

_numbers = st.one_of(
    st.integers(-10, 10**9),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=3),
    st.booleans(),
)
_axis_value = st.one_of(
    _numbers,
    st.lists(_numbers, max_size=4),
    st.dictionaries(st.sampled_from(["start", "stop", "num", "step"]), _numbers, max_size=4),
)
_grid = st.dictionaries(
    st.sampled_from(["speed_m_s", "direction_deg", "block_mass_kg", "height_m", "gain_scale", "speed"]),
    _axis_value,
    max_size=4,
)
_top = st.fixed_dictionaries(
    {},
    optional={
        "grid": _grid,
        "samples": _numbers,
        "seed": _numbers,
        "launch_distance_m": _numbers,
        "model": st.one_of(st.just("wendlandt"), _numbers),
        "torque_limits": st.one_of(st.sampled_from(["none", "human"]), _numbers),
        "scenario": st.dictionaries(
            st.sampled_from(["duration_s", "friction", "controller"]), _numbers, max_size=2
        ),
    },
)
_KEYS = (
    "grid",
    "samples",
    "seed",
    "launch_distance_m",
    "model",
    "torque_limits",
    "scenario",
    "speed_m_s",
    "direction_deg",
    "block_mass_kg",
    "height_m",
    "gain_scale",
    "speed",
    "duration_s",
    "friction",
    "controller",
    "start",
    "stop",
    "num",
)


@settings(max_examples=150, deadline=2000, suppress_health_check=[HealthCheck.too_slow])
@given(_top)
def test_any_grid_file_is_a_sweep_or_a_one_line_error_naming_a_key(values):
    try:
        spec = SweepSpec.from_dict(values)
    except BipedError as exc:
        msg = str(exc)
        assert "\n" not in msg and any(k in msg for k in _KEYS), msg
    else:
        assert 1 <= spec.n_trials <= MAX_TRIALS


# ---------------------------------------------------------------------------------------------
# property: the command line's space

_TEXT = st.one_of(
    st.text(alphabet="0123456789.:,-e xa", max_size=8),
    st.sampled_from(
        ["0", "-1", "1e300", "nan", "inf", "1:2", "1:5:0", "1:5:1e9", "2", "0:315:8", "1,2,3", ""]
    ),
)
_OPTIONS = {  # option -> words one of which the error must contain
    "--speed": ("speed_m_s",),
    "--direction": ("direction_deg",),
    "--mass": ("block_mass_kg",),
    "--height": ("height_m",),
    "--gain-scale": ("gain_scale",),
    "--samples": ("samples",),
    "--seed": ("seed",),
    "--duration": ("duration_s", "--duration"),
    "--workers": ("workers",),
    "--batch": ("batch",),
    "--plot": ("--plot",),
}


@settings(
    max_examples=200,
    deadline=3000,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(st.dictionaries(st.sampled_from(sorted(_OPTIONS)), _TEXT, min_size=1, max_size=4))
def test_any_command_line_is_a_dry_run_or_a_one_line_error_naming_the_option(tmp_path, capsys, opts):
    argv = ["sweep", "--dry-run", "--quiet", "--out", str(tmp_path / "s.parquet")]
    for k, v in opts.items():
        argv.append(f"{k}={v}")
    rc, last = _status(capsys, argv)
    if rc == 2:
        words = [w for k in opts for w in (*_OPTIONS[k], k)]
        assert any(w in last for w in words), (opts, last)


_SET = st.tuples(
    st.sampled_from([*scenario_keys(), "x"]),
    st.sampled_from(
        [
            "1e300",
            "0",
            "-1",
            "nan",
            "[]",
            "[1, 2, 3]",
            '"a"',
            "none",
            "joint-pd",
            "fast",
            "{a = 1}",
            "1",
            "0.5",
        ]
    ),
)
_CHOICES = {
    "--controller": ["workspace", "joint-pd", "pd"],
    "--task": ["hold", "wendlandt", "x"],
    "--torque-limits": ["none", "human", "x"],
    "--physics": ["fast", "faithful", "x"],
    "--distribution": ["statics", "printed", "qp", "x"],
    "--model": ["wendlandt", "", "/nonexistent.xml", "/dev/null"],
    "--compare": ["/nonexistent.parquet", "x.csv"],
}


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    st.lists(_SET, max_size=2),
    st.dictionaries(st.sampled_from(sorted(_CHOICES)), st.integers(0, 3), max_size=3),
)
def test_any_set_and_choice_line_is_a_dry_run_or_a_one_line_error_naming_it(tmp_path, capsys, sets, choices):
    argv = [
        "sweep",
        "--dry-run",
        "--quiet",
        "--speed",
        "2",
        "--direction",
        "0",
        "--out",
        str(tmp_path / "s.parquet"),
    ]
    names = []
    for key, value in sets:
        argv += ["--set", f"{key}={value}"]
        names += [key, "--set"]
    for opt, i in choices.items():
        values = _CHOICES[opt]
        argv += [opt, values[i % len(values)]]
        names += [opt, opt.lstrip("-").replace("-", "_"), "model", "--plot"]
    rc, last = _status(capsys, argv)
    if rc == 2:
        assert last.startswith("biped sweep: error: ") and any(w in last for w in names), (argv, last)


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ([], "sweep-workspace-none.parquet"),
        (["--distribution", "qp"], "sweep-workspace-qp-none.parquet"),
        (["--stepping", "--distribution", "qp"], "sweep-workspace-qp-stepping-none.parquet"),
        (["--controller", "joint-pd", "--torque-limits", "human"], "sweep-joint-pd-human.parquet"),
    ],
)
def test_default_file_names_tell_stepping_sweeps_apart(tmp_path, capsys, monkeypatch, options, name):
    """Without --out a stepping sweep went to the file of the same sweep without stepping (refused
    as a different sweep, or replaced with --overwrite)."""
    monkeypatch.chdir(tmp_path)
    rc, stdout, _ = _sweep(capsys, "--speed", "3", "--direction", "0", "--dry-run", *options)
    assert rc == 0 and stdout.rstrip().endswith(f"-> runs/{name}"), stdout
