"""``biped validate``: the human balance experiments run on the biped, thresholds against people's.

Each experiment follows its paper's protocol with the perturbation paradigms of
:mod:`biped.sim.perturbations`, once with ``neuromotor = "ideal"`` (W's controller) and once with
``"young"`` (:mod:`biped.control.neuromotor`), and finds its threshold, the largest magnitude the
biped survives, by bisection (a trial survives when it has not fallen, diverged or failed by the
end of the run); the one-step lean by its paper's staircase and its paper's success (no fall, at
most one step, standing still at the end: :data:`ONE_STEP`, :mod:`biped.analysis.validate_rule`;
:func:`run_experiment`). The human numbers (:data:`HUMAN`, :mod:`biped.analysis.validate_human`)
are copied with their sources from the project's notes; nothing here reads them at run time from
anywhere else. docs/validate.md.

>>> sorted(EXPERIMENTS)
['ankle_release', 'platform_backward', 'step_release', 'waist_pull']
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, field

import numpy as np

from biped.analysis import validate_search as search
from biped.analysis.validate_human import HUMAN, MEASURES, NOT_RUN, HumanValue, human_for  # noqa: F401
from biped.analysis.validate_measures import (  # noqa: F401 (re-exported: tests and outputs read them here)
    LANDING_S,
    _ankle_measures,
    _step_measures,
    ankle_to_toe_m,
    waist_ahead_of_ankles_m,
)
from biped.analysis.validate_rule import ONE_STEP, one_step_passes, still_at_end
from biped.sim import Scenario, build_scene
from biped.sim.early_stop import AT_REST
from biped.sim.push import simulate

__all__ = [
    "EXPERIMENTS",
    "HUMAN",
    "NOT_RUN",
    "ONE_STEP",
    "OUTCOMES",
    "RECOVERED",
    "SURVIVED",
    "Experiment",
    "HumanValue",
    "Threshold",
    "Trial",
    "outcome",
    "run_experiment",
]


@dataclass(frozen=True)
class Experiment:
    """One experiment: the scenario keys of its protocol, the key its magnitude sets (a
    function of the magnitude), the bracket searched [lo, hi] and the human values it meets."""

    key: str
    title: str
    protocol: str
    base: dict
    magnitude: Callable[[float], dict]
    unit: str
    lo: float
    hi: float
    human: tuple = ()
    preset_keys: dict = field(default_factory=dict)  # preset -> extra scenario keys of its protocol
    #: what a trial must do to count: SURVIVED (no fall, divergence or error to the run's end),
    #: RECOVERED (that, and at rest over the final feet: the run's ``recovered``, below) or
    #: ONE_STEP (Wojcik's: no fall, at most one step, still at the end; validate_rule)
    criterion: str = "survived"
    #: > 0: raise the magnitude from ``lo`` by this step until a trial fails, then bisect between
    #: the last that passed and it (Wojcik's protocol; :func:`run_experiment`); 0: bisect [lo, hi]
    staircase: float = 0.0


#: A trial counts when it has not fallen, diverged or failed by the end of its run.
SURVIVED = "survived"
#: ... and its run is ``recovered`` by the project's rule for the run's controller: with stepping
#: (:func:`biped.sim.stepping.stepping_outcome`, the sweeps' strict rule of issue #23) at its end
#: the COM within ``recovery_com_tol_m`` of the set point over the final feet, slower than 5 cm/s,
#: the trunk within ``recovery_orientation_tol_deg``; ``early_stop`` ends a run once that is
#: decided (:mod:`biped.sim.early_stop`), a fall ends it anyway. (The one-step lean's until
#: 2026-11-28, now :data:`~biped.analysis.validate_rule.ONE_STEP`: its trunk and set-point clauses
#: are the controller's own rule, not Wojcik's success.)
RECOVERED = "recovered"


def _ankle_release(lean: float) -> dict:
    return {"release_lean_deg": float(lean)}


def _platform(d: float) -> dict:
    return {"platform_displacement_m": (float(d), 0.0)}  # +x: the feet go backward


def _pull(d: float) -> dict:
    return {"pull_displacement_m": (-float(d), 0.0)}  # -x: forward, the way the biped faces


#: The waist pull's motor speed [m/s] (chosen in Mille's fast range before any run; docs/validate.md).
PULL_VELOCITY_M_S = 0.5

#: Human quiet stance, the starting pose of every experiment (the lean releases lean it straight
#: about the ankles: Robinovitch's and Wojcik's subjects stood upright): W's initial pose is a deep
#: crouch (hip 40, knee 77, ankle 42 deg) with the whole-body COM 10.3 cm ahead of the ankles,
#: where people stand with the line of gravity 4.7-5.8 cm ahead of the ankle and the hip on it
#: (-0.5 +/- 0.5 cm; Frontiers in Physiology 2019, 10:625, "Attainment of quiet standing in
#: humans", 13 adults: 47 +/- 4 mm early, 58 +/- 5 mm after 7.6 s) and the hip joint
#: 6.2 +/- 1.3 cm ahead of the ankle (Woodhull, Maltrud & Mello 1985, Eur J Appl Physiol
#: 54:109-115). The pose: trunk upright, hip flexion 2, knee 12, ankle dorsiflexion 10 deg (both
#: legs): the whole-body COM 5.9 cm and the hips 5.8 cm ahead of the ankles, 0.89 m above them (the
#: knee stays 12 deg bent: W's controller has no straight-knee singularity handling). Chosen on
#: these alignments alone, before any threshold was run with it.
HUMAN_STANCE = {"initial_joint_angles_deg": (0.0, 2.0, 0.0, -12.0, 0.0, 10.0) * 2, "initial_tilt_deg": 0.0}


_COMMON = {"friction": 0.8, "duration_s": 2.5}
#: Every experiment runs 4 s: from human quiet stance, near its threshold the biped topples slowly
#: over its toes (heels up), and a 2.5 s run counted as survived a 0.149 m platform move that falls
#: at 2.6 s (4 s and 6 s runs agree on 0.148 m), the young's 5.84 deg ankle-only lean (falls at
#: 2.73 s) and its 6.19 deg one-step lean (falls at 2.53 s).
_SLOW_TOPPLE = {"duration_s": 4.0}
#: The one-step lean runs 7 s and must end standing still (ONE_STEP): after its step the young
#: preset sways over the front foot and falls late, 10.5 deg at 4.31 s, 10.54 at 4.89 and
#: validate's 4 s threshold trial, 10.72 deg, at 5.03 s (docs/validate.md, "Above the ideal's
#: 20.5 deg"); ``early_stop`` ends a trial once it is at rest over its final feet (then it passes
#: the rule's "still"), a fall ends it anyway.
_AT_REST = {"duration_s": 7.0, "early_stop": True}

EXPERIMENTS = {
    "ankle_release": Experiment(
        "ankle_release",
        "forward lean and release, ankles only (Robinovitch et al. 2002)",
        "from human quiet stance (HUMAN_STANCE), leaning forward straight about the ankles, held by a "
        "horizontal tether at the pelvis, released without warning at 0.1 s; hips and knees held "
        "(ankle_only), the QP distribution; the largest lean recovered with the feet in place",
        {
            **_COMMON,
            **HUMAN_STANCE,
            **_SLOW_TOPPLE,
            "perturbation": "release",
            "release_time_s": 0.1,
            "ankle_only": True,
            # the QP: W's min-norm split ignores the sole's edges; from 4.02 deg the ideal preset's
            # ankle torque tipped both feet 25-30 deg onto their heels after the recovery, and the
            # controller's torques then grew x4-30 a control period until MuJoCo diverged
            # (docs/validate.md, "The ideal's ankle-only divergence")
            "distribution": "qp",
        },  # fmt: skip
        _ankle_release,
        "deg",
        0.25,
        16.0,
        ("ankle_release.lean_deg", "ankle_release.peak_ankle_torque_n_m", "ankle_release.onset_ms"),
    ),
    "platform_backward": Experiment(
        "platform_backward",
        "backward support-surface translation (Horak & Nashner 1986)",
        "the floor under both feet moves backward by the displacement in a 0.3 s ramp "
        "(perturbations' ramp-and-hold) from human quiet stance (HUMAN_STANCE), the QP distribution; "
        "the largest displacement recovered without a step (no stepping controller)",
        {
            **_COMMON,
            **HUMAN_STANCE,
            **_SLOW_TOPPLE,
            "perturbation": "platform",
            "platform_start_s": 0.1,
            "platform_duration_s": 0.3,
            # the QP: with W's min-norm split the ideal preset's trials end in MuJoCo divergences
            # once the heels rise (from 0.083 m), not falls; the young preset's threshold is the
            # same with either (docs/validate.md, "What limits the biped on the platform")
            "distribution": "qp",
        },
        _platform,
        "m",
        0.005,
        0.6,
        ("platform_backward.displacement_m",),
    ),
    "step_release": Experiment(
        "step_release",
        "forward lean and release, one step (Wojcik et al. 1999)",
        "from human quiet stance (HUMAN_STANCE), leaning forward straight about the ankles, held by a "
        "horizontal tether at the pelvis, released without warning at 0.1 s, with capture-point "
        "stepping (stepping = true, at most one step, the QP distribution; the young and older "
        "presets with the step program) on a floor of "
        "friction 1.0 (a shod foot on a dry floor; the tether needs about tan(lean) of the weight in "
        "friction); the largest lean recovered with at most one step (Wojcik's success: no fall in a 7 s "
        "run, at most one step, a closing step counted, and standing still at the end, the central body "
        "slower than 5 cm/s over the last 0.5 s) with every lean below it recovered (raised 1 deg at a "
        "time from 2 deg until one fails, then bisected)",
        {
            **HUMAN_STANCE,
            **_AT_REST,
            "friction": 1.0,
            "perturbation": "release",
            "release_time_s": 0.1,
            "stepping": True,
            "max_steps": 1,
            "distribution": "qp",
            # the longest step the legs reach (0.884 m), not the sweeps' fixed 0.5 m: a person
            # falling takes as long a step as the fall asks (docs/validate.md, "The step program")
            "step_reach": "leg",
            # the trigger this experiment was built and measured with (the sweeps' default is "qp")
            "step_trigger": "capture",
        },  # fmt: skip
        _ankle_release,
        "deg",
        2.0,
        40.0,
        ("step_release.lean_deg", "step_release.step_length_m", "step_release.contact_ms"),
        # the presets with a nervous system step with the step program (planned for a delayed,
        # lagged plant) on the present state their internal model predicts over the delay, the
        # activation lag inverted on it, the rear foot trailing after the step ("program-trail");
        # W's ideal controller with the feedback stepper (docs/validate.md, "The predicted step",
        # "Braking after the lunge"); the swing on the bang-bang jerk path timed by the preset's
        # own hip flexion rate limit for the step's length ("The S-curve tracked", "The young's
        # fast step")
        {p: {"step_program": "program-trail", "swing_path": "s-curve-timed"} for p in ("young", "older")},
        # Wojcik's success: no fall, at most one step, standing still at the end (not upright, not
        # over the set point: validate_rule); the leans raised 1 deg at a time from 2 deg until one
        # fails, as Wojcik raised them until the step failed (a bisection over 2-40 deg passed over
        # leans that fall below its threshold)
        criterion=ONE_STEP,
        staircase=1.0,
    ),
    "waist_pull": Experiment(
        "waist_pull",
        "forward waist pull imposing a displacement (Mille et al. 2003)",
        "a stiff cable from the pelvis to a motor that travels the displacement forward at a peak "
        f"velocity of {PULL_VELOCITY_M_S:g} m/s (the platform's trapezoid; ~250 % of the ankle-to-toe "
        "length per s, in Mille's fast range, above the ~121 % BoS/s beyond which velocity no longer "
        "mattered), then lets go, from human quiet stance (HUMAN_STANCE), the QP distribution; the "
        "largest displacement recovered with the feet in place (a step is needed beyond it), and the "
        "waist's position ahead of the ankles when the cable is let go, as % of the ankle-to-toe length "
        "(Mille's measure)",
        {
            **_COMMON,
            **HUMAN_STANCE,
            **_SLOW_TOPPLE,
            "perturbation": "pull",
            "pull_start_s": 0.1,
            "pull_velocity_m_s": PULL_VELOCITY_M_S,
            # the QP: with W's min-norm split the ideal preset's threshold trial (0.0233 m) ends in a
            # MuJoCo divergence once the knees reach straight (its torques grow without bound as a
            # leg stretches), not a fall; the QP's bounded normal forces make it a fall
            # (docs/validate.md, "The ideal's waist-pull divergence")
            "distribution": "qp",
        },
        _pull,
        "m",
        0.005,
        0.5,
        ("waist_pull.threshold", "waist_pull.percent_bos"),
    ),
}


@dataclass
class Trial:
    """One run: the experiment, preset, magnitude and what came of it."""

    experiment: str
    neuromotor: str
    magnitude: float
    unit: str
    survived: bool
    fall_time_s: float | None
    peak_ankle_torque_n_m: float
    onset_ms: float
    hip_knee_motion_deg: float
    wall_time_s: float
    # pulls: the waist ahead of the ankles at the let-go (else the central body's peak forward
    # travel), % of the ankle-to-toe length
    percent_bos: float = math.nan
    steps: int = 0  # steps taken (stepping runs)
    step_length_m: float = math.nan  # the first step: the stepping foot's horizontal displacement
    contact_ms: float = math.nan  # the first step: from release (or 0) to that foot's contact
    recovered: bool = False  # the run's ``recovered`` (RECOVERED): at rest over the final feet
    passed: bool = False  # counted by the experiment's criterion (survived, recovered, or one step)
    end_s: float = math.nan  # the simulated time the run ended (a fall, at rest, or its duration)
    final_com_error_m: float = math.nan  # at the end: the COM from the set point judged by
    final_com_speed_m_s: float = math.nan  # at the end: the central body's COM speed
    final_orientation_error_deg: float = math.nan  # at the end: the trunk from the set point's
    still: bool = False  # the central body slower than 5 cm/s over the run's last 0.5 s (ONE_STEP)
    end_speed_m_s: float = math.nan  # its largest speed over that window
    stop_reason: str = ""  # why the run ended before its duration: "fell", "at_rest" (early_stop), ""
    cpu_time_s: float = math.nan  # the run's CPU time (this process's; wall_time_s is loaded)
    #: what came of the run (:func:`outcome`): "recovered", "survived", "fell", "diverged", "error"
    outcome: str = ""
    detail: str = ""  # a divergence's or a controller error's message ("" otherwise)

    def row(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Threshold:
    """The largest magnitude that passed (``value``; ``bound`` "<" when even ``lo`` failed, ">"
    when ``hi`` passed) and the trial at it."""

    experiment: str
    neuromotor: str
    value: float
    unit: str
    bound: str = ""
    at: Trial | None = None
    trials: list = field(default_factory=list)
    dropped: int = 0  # trials a pool ran beside the search that it did not need (not in ``trials``)

    @property
    def lowest_failure(self) -> float | None:
        """The smallest magnitude tried that failed (None if none did): below ``value`` it is an
        island the search passed (a bisection can; the staircase cannot)."""
        failed = [t.magnitude for t in self.trials if not t.passed]
        return min(failed) if failed else None

    @property
    def lowest_failure_outcome(self) -> str | None:
        """What came of the lowest failing trial (:data:`OUTCOMES`; None if none failed): a fall, or a
        divergence or error that says nothing of balance."""
        failed = [t for t in self.trials if not t.passed]
        return min(failed, key=lambda t: t.magnitude).outcome if failed else None

    @property
    def highest_pass(self) -> float | None:
        """The largest magnitude tried that passed (None if none did)."""
        passed = [t.magnitude for t in self.trials if t.passed]
        return max(passed) if passed else None


def run_trial(
    exp: Experiment, neuromotor: str, magnitude: float, running: Callable[[float, float], None] | None = None
) -> Trial:
    """One trial of ``exp`` at ``magnitude`` with the ``neuromotor`` preset; ``running(t, duration)``
    every 50 ms of simulated time ``t`` of the run's ``duration`` [s] (the same run either way)."""
    s = Scenario(
        neuromotor=neuromotor, **exp.base, **exp.preset_keys.get(neuromotor, {}), **exp.magnitude(magnitude)
    )
    scene = build_scene(s)
    t, cpu = time.perf_counter(), time.process_time()
    tick = None if running is None else lambda t_sim: running(t_sim, s.duration_s)
    r = simulate(s, scene=scene, progress=tick)
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    if r.interrupted:  # Ctrl-C / SIGTERM inside the run: not a fall, the end of the bisection
        raise KeyboardInterrupt
    what, detail = outcome(r)
    survived = what in ("recovered", "survived")
    peak, onset, motion = _ankle_measures(r, s)
    if s.perturbation == "pull":  # Mille's measure: the waist's position ahead of the ankles
        forward = waist_ahead_of_ankles_m(scene, r)
    else:  # the central body's peak forward displacement (the biped faces -x)
        forward = float(np.max(r.com[0, 0] - r.com[:, 0]))
    bos = 100.0 * forward / ankle_to_toe_m(s.model)
    n_steps, length, contact = _step_measures(r, s)
    recovered = bool(survived and r.recovered)
    speed = float(np.linalg.norm(r.qvel[-1, :3])) if r.qvel is not None and len(r.qvel) else math.nan
    still, end_speed = still_at_end(r.qvel, s.control_rate_hz)
    still = still or r.stop_reason == AT_REST  # at rest at its equilibrium: still to the run's end
    passed = {SURVIVED: survived, RECOVERED: recovered, ONE_STEP: one_step_passes(survived, n_steps, still)}
    why = "fell" if r.fell else (r.stop_reason or "")
    return Trial(exp.key, neuromotor, float(magnitude), exp.unit, bool(survived), r.fall_time_s, peak, onset,
                 motion, wall, bos, n_steps, length, contact, recovered, bool(passed[exp.criterion]),
                 float(r.times[-1]) if len(r.times) else math.nan, float(r.final_com_error_m), speed,
                 float(r.final_orientation_error_deg), still, end_speed, why, cpu, what, detail)  # fmt: skip


#: :attr:`Trial.outcome`'s values: at rest over the final feet at the end (the run's ``recovered``);
#: to the run's end without a fall, divergence or error, not at rest; fell (the contact monitor's
#: fall); MuJoCo's integration diverged (its bad-acceleration warning) or a recorded state, velocity
#: or torque is not finite; the controller raised (a singular state).
OUTCOMES = ("recovered", "survived", "fell", "diverged", "error")


def outcome(r) -> tuple[str, str]:
    """(:data:`OUTCOMES`' value, its message) of a run: a divergence before an error before a fall
    (a state MuJoCo could not integrate says nothing of balance)."""
    recorded = (getattr(r, k, None) for k in ("qpos", "qvel", "torques"))
    finite = all(np.isfinite(a).all() for a in recorded if a is not None)
    if r.diverged is not None or not finite:
        return "diverged", r.diverged or "a recorded state, velocity or torque is not finite"
    if r.controller_error is not None:
        return "error", r.controller_error
    if r.fell:
        return "fell", ""
    return ("recovered" if r.recovered else "survived"), ""


#: ``--quick``'s staircase: this many times the experiment's step, and no halving: 2, 10, 18 deg
#: (the young's one-step trials that stand run the whole 7 s, 30-36 s of CPU each; with 4 deg
#: steps the young's 2, 6, 10 and 14 deg took 89 s of CPU, two 7 s trials one after the other).
QUICK_STAIRCASE_FACTOR = 8.0


def run_experiment(
    exp: Experiment,
    neuromotor: str,
    iterations: int,
    progress: Callable[[Trial], None] | None = None,
    running: Callable[[float, float, float], None] | None = None,
    *,
    quick: bool = False,
    pool: Executor | None = None,
    waiting: Callable[[float, float], None] | None = None,
    stop=None,
) -> Threshold:
    """The threshold of ``exp`` for the preset: the largest magnitude whose trial passes (the
    experiment's criterion). With a staircase, the magnitude raised from ``lo`` by the step until a
    trial fails, then ``min(iterations, STAIRCASE_HALVINGS)`` halvings between the last that passed
    and it: every step below the threshold passed (``quick``: :data:`QUICK_STAIRCASE_FACTOR` times
    the step, no halving: a smoke run of the protocol, not a measurement). Without, a
    bisection in [lo, hi] on a logarithmic scale, ``iterations`` halvings after the bracket's two
    trials. ``progress`` is called with each trial as it ends, ``running(magnitude, t, duration)``
    every 50 ms of a running trial's simulated time (:func:`run_trial`; without a pool).
    ``pool``: the next trial the search may need runs beside the one it waits for
    (:mod:`biped.analysis.validate_search`; the same trials and threshold), ``waiting(magnitude,
    wall_s)`` every 10 s of a running trial's wait; ``stop`` (a :class:`threading.Event`) set ends a
    wait in KeyboardInterrupt."""
    if pool is None:

        def trial(magnitude: float) -> Trial:
            tick = None if running is None else lambda t_sim, dur: running(magnitude, t_sim, dur)
            return run_trial(exp, neuromotor, magnitude, tick)

    else:
        trial = functools.partial(run_trial, exp, neuromotor)
    trials = search.Trials(trial, pool, progress, waiting, stop)
    if exp.staircase > 0:
        step = QUICK_STAIRCASE_FACTOR * exp.staircase if quick else exp.staircase
        halvings = 0 if quick else min(iterations, search.STAIRCASE_HALVINGS)
        bound, value, at = search.staircase(
            trials, exp.lo, exp.hi, step, halvings, lambda a, b: 0.5 * (a + b)
        )
        return Threshold(exp.key, neuromotor, value, exp.unit, bound, at, trials.taken, trials.dropped)
    trials.start(exp.lo)
    trials.start(exp.hi)
    lo_t = trials.run(exp.lo)
    if not lo_t.passed:
        trials.drop()
        return Threshold(exp.key, neuromotor, exp.lo, exp.unit, "<", None, trials.taken, trials.dropped)
    hi_t = trials.run(exp.hi)
    if hi_t.passed:
        return Threshold(exp.key, neuromotor, exp.hi, exp.unit, ">", hi_t, trials.taken, trials.dropped)
    value, at = search.bisect(trials, (exp.lo, exp.hi, lo_t), iterations, lambda a, b: math.sqrt(a * b))
    return Threshold(exp.key, neuromotor, value, exp.unit, "", at, trials.taken, trials.dropped)
