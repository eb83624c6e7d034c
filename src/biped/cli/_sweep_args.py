"""The parts of the command line that ``biped sweep`` and ``biped envelope`` share: the
:class:`~biped.sim.sweep.SweepSpec` their options make (:func:`build_spec`), the default file's
name, the polar plot's options and drawing, and the kernels compiled before workers start.
Light at import (the CLI's start-up): everything heavy is imported where it is used.
"""

from __future__ import annotations

import sys
from pathlib import Path

from biped.cli._common import check_file_writable
from biped.errors import ScenarioError

_AXIS_OPTIONS = (
    ("speed", "speed_m_s", "block speed [m/s]"),
    ("direction", "direction_deg", "direction of travel [deg], 0 = +x, 90 = +y"),
    ("mass", "block_mass_kg", "block mass [kg]"),
    ("height", "height_m", "aim height [m]"),
    ("gain_scale", "gain_scale", "gain factor (kp * s, kv * sqrt(s))"),
    ("magnitude", "magnitude", "the perturbation's size: force N (peak), platform m, release deg"),
)

#: the polar plot's radii (``--by``): what a paradigm's rows hold is checked by the command
PLOT_RADII = ("speed_m_s", "impulse_n_s", "magnitude", "horizontal_impulse_n_s")


_PHYSICS_KEYS = ("physics_timestep_s", "contact_timeconst_s")


def _grid_scenario_keys(path) -> set:
    """The keys of a sweep file's [scenario] table (empty without a file)."""
    if not path:
        return set()
    from biped.sim.scenario import read_toml

    return set(read_toml(path, "sweep").get("scenario", {}))


def build_spec(args):
    """The sweep from ``--grid``, then the task, --set and the named options (last wins)."""
    from biped.sim.scenario import Scenario, parse_assignment
    from biped.sim.sweep import SweepSpec, hold_scenario, parse_axis

    spec = SweepSpec.from_toml(args.grid) if args.grid else None
    base = spec.base if spec else Scenario()
    overrides = dict(parse_assignment(a) for a in args.set)
    model = (
        getattr(args, "model", None)
        or overrides.pop("model", None)
        or (base.model if base.model != "wendlandt" else None)
    )
    overrides.pop("model", None)
    if model is not None and not isinstance(model, str):  # --set model=1e300: a number, no name
        raise ScenarioError(
            "model must be a shipped model's name ('wendlandt'), a robot's name or the path of an "
            f"MJCF or robot TOML file; got {model!r}"
        )
    from biped import models
    from biped.models.robot import robot_for

    robot = robot_for(model) if model else None  # a robot's own MJCF (docs/robots.md)
    if robot is not None:
        _check_robot_args(args)
        overrides.setdefault("distribution", "qp")
    elif model:  # W's scenario moved onto the model, then the grid file's [scenario] keys
        base = Scenario.for_model(model, **_grid_file(args.grid)[0])
    task = args.task or (None if spec else "hold")
    if task == "hold":
        base = hold_scenario(base)
    if args.controller:
        overrides["controller"] = args.controller
    if getattr(args, "distribution", None):
        overrides["distribution"] = args.distribution
    if getattr(args, "stepping", None):
        overrides["stepping"] = True
    if getattr(args, "perturbation", None):
        overrides["perturbation"] = args.perturbation
    if args.duration is not None:
        overrides["duration_s"] = args.duration
    if args.physics:
        overrides["physics"] = args.physics
    elif robot is not None:
        pass  # the robot's own physics (its file's step, at most 2 ms): no preset
    elif not ({"physics", *_PHYSICS_KEYS} & (set(overrides) | _grid_scenario_keys(args.grid))):
        overrides["physics"] = "fast"  # the sweep's default preset (docs/sweep.md)
    if robot is not None and "block_mass_kg" not in overrides and args.mass is None:
        from biped.sim.robot_trial import robot_block_defaults

        mass, height = robot_block_defaults(robot.spec, models.total_mass_kg())
        overrides["block_mass_kg"] = mass  # W's block scaled with the robot's mass
    if "early_stop" not in overrides and "early_stop" not in _grid_scenario_keys(args.grid):
        overrides["early_stop"] = True  # end each trial once its outcome is decided (docs/sweep.md)
    if overrides:
        base = base.with_overrides(**overrides)
    axes = dict(spec.axes) if spec else {}
    for opt, name, _ in _AXIS_OPTIONS:
        text = getattr(args, opt)
        if text is not None:
            axes[name] = parse_axis(name, text)
    if not spec and not any(getattr(args, opt) for opt, _, _ in _AXIS_OPTIONS):
        axes.update(direction_deg=tuple(range(0, 360, 45)))
        if base.perturbation == "block":
            axes.update(speed_m_s=(2.0, 4.0, 6.0))
    if robot is not None and base.perturbation == "block" and not args.height:
        from biped.sim.robot_trial import robot_block_defaults

        # W's aim height at the same fraction of the robot's central-body COM height
        axes["height_m"] = (robot_block_defaults(robot.spec, models.total_mass_kg())[1],)
    elif model and not args.height and "height_m" not in _grid_file(args.grid)[1]:
        axes["height_m"] = (base.block_position_m[2],)  # W's aim height moved onto the model
    samples = args.samples if args.samples is not None else (spec.samples if spec else None)
    seed = args.seed if args.seed is not None else (spec.seed if spec else 0)
    limits = args.torque_limits or (spec.torque_limits if spec else "model" if robot else "none")
    if robot is not None:
        from biped.sim.robot_trial import check_robot_scenario

        check_robot_scenario(base)
    elif limits == "model":
        raise ScenarioError(
            "--torque-limits model is a robot's own limits (--model g1 etc., docs/robots.md); "
            "W's structure takes none or human"
        )
    return SweepSpec(
        axes=axes,
        base=base,
        samples=samples,
        seed=seed,
        torque_limits=limits,
        launch_distance_m=spec.launch_distance_m if spec else 0.5,
        robot=robot.spec if robot is not None else "",
    )


def _check_robot_args(args) -> None:
    """Options a robot's sweep or envelope does not take (before any work)."""
    given = [
        opt
        for opt, v in (
            ("--physics", args.physics),
            ("--task wendlandt", args.task == "wendlandt"),
            ("--grid", getattr(args, "grid", None)),
        )
        if v
    ]
    if given:
        raise ScenarioError(
            f"--model {args.model}: {', '.join(given)} not available on robots (their own physics, the "
            f"hold task; axes on the command line); docs/robots.md"
        )


def _variant_suffix(base) -> str:
    """What sets the default file apart beyond controller and limits: the workspace controller's
    distribution when it is not W's, and stepping (else a stepping sweep would land on the file of
    the same sweep without it, and be refused or, with --overwrite, replace it)."""
    dist = (
        f"-{base.distribution}" if base.controller == "workspace" and base.distribution != "statics" else ""
    )
    pert = f"-{base.perturbation}" if base.perturbation != "block" else ""
    return pert + dist + ("-stepping" if base.stepping else "")


def robot_suffix(spec) -> str:
    """The robot's file stem in a default output name ("-g1"), else ""."""
    return f"-{Path(spec.robot).stem}" if spec.robot else ""


def _grid_file(grid) -> tuple[dict, dict]:
    """The [scenario] keys and [grid] axes the sweep file sets (validated by SweepSpec.from_toml)."""
    if not grid:
        return {}, {}
    from biped.sim.scenario import read_toml

    values = read_toml(grid, "sweep")
    scenario = dict(values.get("scenario", {}))
    scenario.pop("model", None)
    return scenario, dict(values.get("grid", {}))


def _check_plot(path: str | None, compare: list[str]) -> None:
    """--plot and --compare, checked before the sweep runs (``path`` "" : the default beside the
    results, a PNG)."""
    if compare and path is None:
        raise ScenarioError("--compare needs --plot (or --plot FILE.png)")
    if not path:
        return
    import matplotlib.figure

    kinds = matplotlib.figure.Figure().canvas.get_supported_filetypes()
    suffix = Path(path).suffix.lstrip(".").lower()
    if suffix not in kinds:
        raise ScenarioError(
            f"--plot {path!r}: unknown image type {suffix or '(none)'!r}; "
            f"valid: {', '.join('.' + k for k in sorted(kinds))}"
        )
    for other in compare:
        if Path(other).suffix != ".parquet" or not Path(other).is_file():
            raise ScenarioError(f"--compare {other!r}: no finished sweep file (.parquet) there")
        from biped.sim.sweep import load

        try:
            load(other)  # readable, and a biped sweep: before the sweep runs, not after
        except ScenarioError as exc:
            raise ScenarioError(f"--compare {other!r}: {exc}") from None
    check_file_writable(path, "--plot")


def add_by_option(p) -> None:
    """``--by``, the polar plot's radius."""
    p.add_argument(
        "--by",
        choices=PLOT_RADII,
        default=None,
        help="radius of the polar plot (default: speed_m_s for the block, else magnitude, the "
        "paradigm's own unit)",
    )


def draw_envelope(files: list, by: str | None, perturbation: str, plot) -> None:
    """The polar envelope of sweep ``files`` side by side into ``plot``, radius ``by`` (default:
    the block's speed, another paradigm's magnitude)."""
    from biped.viz.envelope import plot_comparison

    by = by or ("speed_m_s" if perturbation == "block" else "magnitude")
    plot_comparison(files, by=by, out=plot)
    print(f"envelope plot: {plot}")


def warm_up_kernels(spec, **kwargs) -> None:
    """Compile (or load from numba's cache) the kernels ``spec``'s trials run, before the local
    workers start: they then load the cache (``kwargs``: :func:`biped.sim.jit.warm_up`'s)."""
    from biped.sim.jit import kernels_for, warm_up

    warm_up(
        kernels_for(
            spec.base.controller,
            spec.base.distribution,
            sweep=True,
            robot=bool(spec.robot),
            stepping=bool(spec.base.stepping),
        ),
        log=lambda line: print(line, file=sys.stderr),
        **kwargs,
    )
