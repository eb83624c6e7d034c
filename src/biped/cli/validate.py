"""``biped validate``: the human balance experiments on the biped, ideal and young nervous
systems side by side, thresholds against people's (:mod:`biped.analysis.validate`;
docs/validate.md). Writes validation.json, validation.md, figures/<experiment>.png and
trials.parquet."""

from __future__ import annotations

import sys
import time
from typing import Any

from biped.cli._common import add_folder_options, keeps_mujoco_log, run_dir

#: Bisection halvings after the bracket: --quick, full.
QUICK_ITERATIONS, FULL_ITERATIONS = 3, 9


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "validate",
        help="run the human balance experiments (lean releases, platform, waist pull) and compare",
        description="Run the human balance experiments of docs/validate.md with neuromotor = ideal "
        "and young, find each threshold by bisection and compare it with the human mean +/- 2 SD.",
    )
    p.add_argument(
        "--quick", action="store_true", help=f"coarse: {QUICK_ITERATIONS} bisection steps (<= 60 s)"
    )
    p.add_argument(
        "--neuromotor",
        action="append",
        choices=("ideal", "young", "older"),
        help="the presets to run (repeatable; default: ideal and young)",
    )
    p.add_argument(
        "--experiment",
        action="append",
        metavar="NAME",
        help="run only these experiments (repeatable): ankle_release, platform_backward, step_release, waist_pull",
    )
    add_folder_options(p, "a new runs/validate-<date>-<time>")
    p.set_defaults(func=run, _parser=p)


@keeps_mujoco_log
def run(args) -> int:

    from biped.analysis.validate import EXPERIMENTS, run_experiment
    from biped.errors import ScenarioError, unknown_name
    from biped.outputs.validate import write_validation

    names = args.experiment or list(EXPERIMENTS)
    for n in names:
        if n not in EXPERIMENTS:
            raise ScenarioError(unknown_name("experiment", n, EXPERIMENTS))
    presets = list(dict.fromkeys(args.neuromotor or ["ideal", "young"]))
    out = run_dir(args.out, "validate", overwrite=args.overwrite)
    from biped.sim.mjlog import count_warnings, route_to, summary

    route_to(out / "mujoco.log")  # MuJoCo's warnings (a diverging trial's), as biped push does
    warned_before = count_warnings(out / "mujoco.log")
    iterations = QUICK_ITERATIONS if args.quick else FULL_ITERATIONS
    t0 = time.perf_counter()
    results: dict = {}
    n = 0
    interrupted = False
    running: _Running | None = None
    try:
        for name in names:
            per: dict = {}
            results[name] = per
            for preset in presets:
                running = _Running(name, preset, EXPERIMENTS[name].unit)
                th = run_experiment(
                    EXPERIMENTS[name],
                    preset,
                    iterations,
                    progress=_said(name, preset, running),
                    running=running,
                    quick=args.quick,
                )
                per[preset] = th
                n += len(th.trials)
                print(
                    f"  {name:<18} {preset:<6} threshold {th.bound}{th.value:.4g} {th.unit} ({len(th.trials)} trials)"
                )
    except KeyboardInterrupt:  # Ctrl-C / SIGTERM: write the finished thresholds, then stop
        if running is not None:
            running.close()
        interrupted = True
        results = {k: v for k, v in results.items() if v}
    wall = time.perf_counter() - t0
    note = (
        "Each threshold is the largest magnitude the biped survived (bisection on a log scale; '<' "
        "below the searched range, '>' above it); the one-step lean's, the largest lean recovered (at "
        "rest over the final feet at the end of a 7 s run) with every lean below it recovered (raised "
        "1 deg at a time from 2 deg until one failed, then bisected). Presets: biped.control.neuromotor, "
        "docs/validate.md."
    )
    meta = {"mode": "quick" if args.quick else "full", "iterations": iterations, "presets": presets,
            "trials": n, "wall_time_s": wall, "note": note, "interrupted": interrupted}  # fmt: skip
    if results:
        write_validation(out, results, meta)
    said = summary(out / "mujoco.log", warned_before)
    if said:
        print(said, file=sys.stderr)
    if interrupted:
        raise KeyboardInterrupt
    print(
        f"  wrote {out}/validation.md, validation.json, trials.parquet, figures/ ({n} trials, {wall:.1f} s)"
    )
    return 0


#: A running trial says nothing for its first second, then its simulated time every second.
RUNNING_DELAY_S = 1.0


class _Running:
    """A running trial's simulated time on stderr (a young trial may run 10-25 s): a tqdm bar on a
    terminal, gone when the trial ends, else a line a second (``biped._progress``); nothing for a
    trial that ends within :data:`RUNNING_DELAY_S`."""

    def __init__(self, name: str, preset: str, unit: str):
        self.name, self.preset, self.unit = name, preset, unit
        self.bar: Any = None

    def __call__(self, magnitude: float, t: float, duration: float) -> None:
        if self.bar is None:
            from biped._progress import progress_bar

            self.bar = progress_bar(
                total=duration,
                desc=f"    {self.name} {self.preset}: {magnitude:.4g} {self.unit}",
                unit="s simulated",
                line_format="{:.2f}",
                line_at_close=False,
                delay=RUNNING_DELAY_S,
                leave=False,
                bar_format="{desc}: {n:.2f}/{total:.2f} s simulated [{elapsed}]",
            )
        self.bar.update(t - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _said(name: str, preset: str, running: _Running | None = None):
    """Each trial's line on stderr as it ends (a trial may take seconds: the user sees it work)."""
    from biped.analysis.validate import EXPERIMENTS, RECOVERED

    def said(t) -> None:
        if running is not None:
            running.close()
        what = "survived" if t.survived else "fell"
        if t.survived and EXPERIMENTS[t.experiment].criterion == RECOVERED:
            what = "recovered" if t.recovered else "stood, not recovered"
        print(
            f"    {name} {preset}: {t.magnitude:.4g} {t.unit} {what} ({t.wall_time_s:.1f} s)", file=sys.stderr
        )

    return said
