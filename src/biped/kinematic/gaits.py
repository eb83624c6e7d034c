"""Bediz's stepping algorithms for the kinematic figure (B IV-B-3, Appendix B), made consistent.

B moves the body on a prescribed path and bends each leg by inverse kinematics toward a foot
point on his "swinging bar" (eq. 4.20-4.21); his code does not tie the foot to the floor, so the
stance foot slides and sinks, and every gait starts with a jump of the joint angles. Here the
*footholds* come first and every quantity follows from them:

- **Footholds.** Stepping forward: the feet land ``L = P1 sin(2 alpha)`` apart, the step length
  of B's bar: a stance leg at ``+-alpha`` shortened to ``P2 = P1 cos(alpha)`` (eq. 4.20) has its
  ankle ``P1 cos(alpha) sin(alpha)`` ahead of / behind the hip. Stepping up: one tread per step,
  ``rise`` and ``run`` given; the default rise is eq. 4.23 at B's 30 deg,
  ``h = (l1 + l2)(1 - cos 30 deg)`` (B's 0.267949 units for l1 = l2 = 1).
- **Double support.** When the leading foot lands, the trailing leg is at ``-alpha_trail`` and the
  leading leg at ``+alpha_lead`` from the vertical; the hip is where both bars meet:
  ``H = (dx + dz tan alpha_lead) / (tan alpha_trail + tan alpha_lead)`` above the trailing ankle.
  On level ground with ``alpha = 20 deg`` this is ``P1 cos^2(alpha)``, B's bar (eq. 4.20). On
  stairs the trailing leg is B's bar at ``alpha_down = 10 deg`` and ``alpha_lead`` follows from the
  run (30 deg for the default stairs: B's "-10 to +30 deg").
- **Pelvis.** A Catmull-Rom spline through the double-support poses (the figure walks at constant
  speed in steady state, as B's ``X + 0.1 z``), plus B's body-height term (eq. 4.22)
  ``A (1 - cos 2 pi f t)``, ``A = 0.08 l1`` (B's 0.08 units with l1 = 1), ``f`` = one period per
  step, highest at mid-stance as B's text says (his code has the opposite phase).
- **Stance foot**: fixed in the world and flat; the stance leg's angles come from IK.
- **Swing foot**: eq. 4.21 with its factor made continuous: the foot sits on the bar from the hip
  to a ground point ``g`` at ``k(s) = 1 - 0.05 sin^2(pi s)`` of its length (``k = 0.95`` at
  mid-swing as B; ``k = 1`` at lift-off and touch-down so that the foot leaves and lands where a
  stance foot stands), ``g`` moving from the lift-off to the landing foothold with zero speed at
  both ends (on stairs it rises before it moves forward, to clear the nosing).
- **Arms** swing with the opposite leg (B): shoulder ``0.7 theta1 - 10 deg``, elbow
  ``1.5 theta1 + 10 deg`` of the opposite hip angle (B's ``+10`` / ``-10`` in his leg frame, whose
  y axis must point backward for his ``theta2 = +acos`` to be a human knee; docs/walk.md).
  **Torso** rolls toward the stance leg,
  ``11/3 deg sin(pi s)`` (B: z/3 for z up to 11), and leans 7 deg on stairs (B).
- **Jump** (B's ``jump``): crouch, straight up, along a semicircle (with B's 360 deg somersault
  unless disabled), straight down, absorb, back up to standing.

Every gait starts and ends standing still, so gaits chain with continuous joint angles and
velocities. Times: one step lasts ``L / speed``; a stair step 0.5/0.35 of that (B's frame
increments); the jump's phases B's frame counts relative to a step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from biped.errors import ScenarioError
from biped.kinematic.figure import FigureDims
from biped.kinematic.ik import stair_elevation

# the gait's parts, one concept a module; re-exported here, where callers have always found them
from biped.kinematic.metrics import WalkMetrics, walk_metrics
from biped.kinematic.plan import Motion, Plan
from biped.kinematic.segments import DEG, SIDES, STAIR_CLEARANCE, _Flight, _HalfStep, _hip_y, _Squat, _Stand
from biped.kinematic.terrain import FLAT, Terrain

__all__ = [
    "GAITS",
    "SIDES",
    "STAIR_CLEARANCE",
    "GaitParams",
    "Motion",
    "Plan",
    "WalkMetrics",
    "chain",
    "demo",
    "jump",
    "stair_geometry",
    "step_forward",
    "step_upward",
    "walk_metrics",
]

#: B's frame increments (Appendix B, delta_t units): a forward half step takes 21 / 0.5 frames,
#: a stair step 21 / 0.35, the jump's phases 100 / 1, 100 / 5, 100 / 1, 100 / 3, 100 / 5, 100 / 2.
_B_STEP_FRAMES = 21.0 / 0.5


@dataclass(frozen=True)
class GaitParams:
    """Parameters of the gaits, defaulting to B's (angles in deg, lengths in m or fractions).

    Attributes:
        alpha: forward stepping, stance bar angle range +-alpha (B IV-B-3a: 20).
        swing_factor: eq. 4.21's 0.95 (reached at mid-swing).
        height_amplitude: eq. 4.22's amplitude in units of the thigh length (B: 0.08, l1 = 1).
        shoulder_gain, shoulder_offset, elbow_gain, elbow_offset: arm swing from the opposite hip
            angle (B: 0.7, 10, 1.5, 10; the offsets' signs are B's read in our leg frame, see
            the module docstring).
        torso_roll: torso roll amplitude toward the stance side (B: 11/3).
        alpha_down: stairs, trailing-leg angle at double support (B: 10).
        stair_lean: forward torso lean on stairs (B: 7).
        stand_fraction: standing hip-ankle distance / (l1 + l2) (B's jump starts at 1.95 / 2).
        crouch_fraction, takeoff_fraction, tuck_fraction, touchdown_fraction: hip-ankle
            distances of the jump (B: 0.475, -, 0.725, -; see docs/walk.md for the changes).
        jump_distance: forward length of the jump's semicircle [m].
        jump_lean: torso lean during the jump (B: 10).
        jump_shoulder, jump_elbow: arm angles during the jump (B swings the arms back 20 deg).
        somersault: turn the body 360 deg along the semicircle (B does).
        knee: IK knee branch, "human" or "reverse".
        stair_time_factor: stair step duration / forward step duration (B: 0.5 / 0.35).
    """

    alpha: float = 20.0
    swing_factor: float = 0.95
    height_amplitude: float = 0.08
    shoulder_gain: float = 0.7
    shoulder_offset: float = -10.0
    elbow_gain: float = 1.5
    elbow_offset: float = 10.0
    torso_roll: float = 11.0 / 3.0
    alpha_down: float = 10.0
    stair_lean: float = 7.0
    stand_fraction: float = 0.975
    crouch_fraction: float = 0.70
    takeoff_fraction: float = 0.99
    tuck_fraction: float = 0.725
    touchdown_fraction: float = 0.90
    jump_distance: float = 0.6
    jump_lean: float = 10.0
    jump_shoulder: float = -20.0
    jump_elbow: float = 20.0
    somersault: bool = True
    knee: str = "human"
    stair_time_factor: float = 0.5 / 0.35

    def __post_init__(self):
        if not 0.0 < self.alpha < 45.0:
            raise ScenarioError(f"alpha must be in (0, 45) deg, got {self.alpha!r}")
        if not 0.5 <= self.swing_factor < 1.0:
            raise ScenarioError(f"swing_factor must be in [0.5, 1), got {self.swing_factor!r}")
        if not 0.0 < self.alpha_down < 45.0:
            raise ScenarioError(f"alpha_down must be in (0, 45) deg, got {self.alpha_down!r}")
        for k in (
            "stand_fraction",
            "crouch_fraction",
            "takeoff_fraction",
            "tuck_fraction",
            "touchdown_fraction",
        ):
            v = getattr(self, k)
            if not 0.3 <= v < 1.0:
                raise ScenarioError(f"{k} must be in [0.3, 1) of the leg length, got {v!r}")
        if self.jump_distance < 0:
            raise ScenarioError(f"jump_distance must be >= 0 m, got {self.jump_distance!r}")


# ------------------------------------------------------------------------------------------
# gait builders
# ------------------------------------------------------------------------------------------


def _step_time(dims, params, speed):
    if not (isinstance(speed, (int, float)) and math.isfinite(speed) and speed > 0):
        raise ScenarioError(f"speed must be a positive number of m/s, got {speed!r}")
    L = dims.leg * math.sin(2.0 * params.alpha * DEG)
    return L / speed


def _check_steps(steps):
    if not (isinstance(steps, (int, np.integer)) and steps >= 1):
        raise ScenarioError(f"steps must be an integer >= 1, got {steps!r}")


def _standing_pelvis(dims, params, ankle_x, ground_z):
    return np.array([ankle_x, 0.0, ground_z + dims.ankle_height + params.stand_fraction * dims.leg])


def _ankles(dims, x, z):
    return {sd: np.array([x, _hip_y(dims, sd), z + dims.ankle_height]) for sd in SIDES}


def _walk(dims, params, footholds, a_trail, a_lead, T, lean, label, bump=True):
    """Half steps over ``footholds`` [(x, ground z), ...]: both feet start at footholds[0], the left
    foot swings first, one footfall per further foothold, and the trailing foot closes beside the
    last. Returns the segments."""
    ha = dims.ankle_height
    N = len(footholds) - 1
    F = [np.array([x, 0.0, z]) for x, z in footholds]
    # double-support poses: standing, after each footfall, standing
    D = [_standing_pelvis(dims, params, F[0][0], F[0][2])]
    ta, tl = math.tan(a_trail), math.tan(a_lead)
    for i in range(1, N + 1):
        dx, dz = F[i][0] - F[i - 1][0], F[i][2] - F[i - 1][2]
        H = (dx + dz * tl) / (ta + tl)
        D.append(np.array([F[i - 1][0] + H * ta, 0.0, F[i - 1][2] + ha + H]))
    D.append(_standing_pelvis(dims, params, F[N][0], F[N][2]))
    V = [np.zeros(3)] + [(D[i + 1] - D[i - 1]) / (2.0 * T) for i in range(1, N + 1)] + [np.zeros(3)]
    feet = {sd: np.array([F[0][0], _hip_y(dims, sd), F[0][2] + ha]) for sd in SIDES}
    segs = []
    A = params.height_amplitude * dims.thigh if bump else 0.0
    for i in range(1, N + 2):
        swing = "left" if i % 2 == 1 else "right"
        stance = "right" if swing == "left" else "left"
        target = F[min(i, N)]
        land = np.array([target[0], _hip_y(dims, swing), target[2] + ha])
        regular = 1 < i < N + 1
        segs.append(
            _HalfStep(
                T,
                stance,
                feet[stance].copy(),
                feet[swing].copy(),
                land,
                D[i - 1],
                V[i - 1],
                D[i],
                V[i],
                A if regular else 0.0,
                lean if i > 1 else 0.0,
                lean if i < N + 1 else 0.0,
                label,
                "in" if i == 1 else "out" if i == N + 1 else "",
            )
        )
        feet[swing] = land
    return segs


def stair_geometry(
    dims: FigureDims, params: GaitParams, rise: float | None = None, run: float | None = None
) -> tuple[float, float, float]:
    """Rise, run and leading-leg angle of B's stair step (B IV-B-3b).

    The trailing leg at double support is B's bar at ``alpha_down`` (eq. 4.20): the hip is
    ``H = P1 cos^2(alpha_down)`` above its ankle. The default rise is eq. 4.23 at 30 deg; the
    default run puts the leading leg at 30 deg (B's alpha range -10..+30 deg). Given a rise and a
    run, the leading-leg angle follows: ``tan alpha_up = (run - H tan alpha_down) / (H - rise)``.

    Returns:
        ``(rise [m], run [m], alpha_up [rad])``.

    Raises:
        ScenarioError: a run shorter than the foot or than the trailing leg's reach, or a rise
            that the leading leg cannot reach.
    """
    P1 = dims.leg
    ad = params.alpha_down * DEG
    H = P1 * math.cos(ad) ** 2
    if rise is None:
        rise = float(stair_elevation(30.0 * DEG, dims.thigh, dims.shank))
    if not (math.isfinite(rise) and 0 < rise < 0.5 * P1):
        raise ScenarioError(f"stair rise must be in (0, {0.5 * P1:.3f}) m (half the leg), got {rise!r}")
    if run is None:
        run = H * math.tan(ad) + (H - rise) * math.tan(30.0 * DEG)
    min_run = max(dims.foot + 0.02, H * math.tan(ad) + 0.01)
    if not (math.isfinite(run) and run >= min_run):
        raise ScenarioError(
            f"stair run must be at least {min_run:.3f} m (the foot, {dims.foot:.3f} m, plus 2 cm, and "
            f"more than the trailing leg's {H * math.tan(ad):.3f} m at {params.alpha_down} deg), got {run!r}"
        )
    a_up = math.atan2(run - H * math.tan(ad), H - rise)
    d_lead = math.hypot(run - H * math.tan(ad), H - rise)
    if d_lead > 0.995 * P1 or a_up > 60 * DEG:
        raise ScenarioError(
            f"stair rise {rise:.3f} m and run {run:.3f} m put the leading foot {d_lead:.3f} m from the hip at "
            f"{a_up / DEG:.1f} deg; the leg reaches {P1:.3f} m: use a shorter run or rise"
        )
    return rise, run, a_up


def _markers(segs, t0=0.0):
    out, t, last = [], t0, None
    for s in segs:
        if s.label != last:
            out.append({"time_s": t, "label": s.label})
            last = s.label
        t += s.duration
    return out


def step_forward(
    dims: FigureDims | None = None,
    steps: int = 6,
    speed: float = 1.0,
    params: GaitParams | None = None,
    start_x: float = 0.0,
    ground_z: float = 0.0,
    terrain: Terrain = FLAT,
) -> Plan:
    """B's stepping-forward algorithm (B IV-B-3a): ``steps`` footfalls of length
    ``L = P1 sin(2 alpha)`` from standing at ``start_x`` to standing, at ``speed`` m/s."""
    dims = dims or FigureDims.from_anthropometry()
    params = params or GaitParams()
    _check_steps(steps)
    T = _step_time(dims, params, speed)
    L = dims.leg * math.sin(2.0 * params.alpha * DEG)
    a = params.alpha * DEG
    footholds = [(start_x + i * L, ground_z) for i in range(steps + 1)]
    segs = _walk(dims, params, footholds, a, a, T, 0.0, "forward")
    return Plan(dims, params, tuple(segs), terrain, tuple(_markers(segs)), distance=steps * L, climbed=0.0)


def step_upward(
    dims: FigureDims | None = None,
    steps: int = 5,
    speed: float = 1.0,
    params: GaitParams | None = None,
    rise: float | None = None,
    run: float | None = None,
    start_x: float = 0.0,
    ground_z: float = 0.0,
    top_run: float | None = None,
) -> Plan:
    """B's stepping-upward algorithm (B IV-B-3b): from standing at ``start_x`` before a flight of
    ``steps`` stairs, one tread per footfall, to standing on the top tread (see
    :func:`stair_geometry` for rise and run)."""
    dims = dims or FigureDims.from_anthropometry()
    params = params or GaitParams()
    _check_steps(steps)
    rise, run, a_up = stair_geometry(dims, params, rise, run)
    T = _step_time(dims, params, speed) * params.stair_time_factor
    margin = 0.5 * (run - dims.foot)
    x_stair = start_x + run - (dims.heel_back + margin)  # the first riser
    terrain = Terrain.stairs(x_stair, rise, run, steps, top_run)
    terrain = Terrain(tuple((x0, x1, top + ground_z) for x0, x1, top in terrain.blocks))
    footholds = [(start_x + i * run, ground_z + i * rise) for i in range(steps + 1)]
    segs = _walk(
        dims,
        params,
        footholds,
        params.alpha_down * DEG,
        a_up,
        T,
        params.stair_lean * DEG,
        "upstairs",
        bump=False,
    )
    return Plan(
        dims, params, tuple(segs), terrain, tuple(_markers(segs)), distance=steps * run, climbed=steps * rise
    )


def jump(
    dims: FigureDims | None = None,
    speed: float = 1.0,
    params: GaitParams | None = None,
    start_x: float = 0.0,
    ground_z: float = 0.0,
    land_z: float | None = None,
    distance: float | None = None,
    terrain: Terrain = FLAT,
) -> Plan:
    """B's jump (``jump`` in Appendix B): crouch, straight up, along a semicircle (somersault if
    ``params.somersault``), straight down onto ``land_z``, absorb, back up to standing.

    Phase durations follow B's frame counts relative to a forward step (crouch 2.4, up 0.48,
    semicircle 2.4, down 0.79, absorb and rise 0.48 and 0.95, hold 1.2 steps)."""
    dims = dims or FigureDims.from_anthropometry()
    params = params or GaitParams()
    T = _step_time(dims, params, speed)
    land_z = ground_z if land_z is None else land_z
    D = params.jump_distance if distance is None else distance
    P1, ha = dims.leg, dims.ankle_height
    feet0 = _ankles(dims, start_x, ground_z)
    feet1 = _ankles(dims, start_x + D, land_z)
    stand0 = _standing_pelvis(dims, params, start_x, ground_z)
    crouch = stand0.copy()
    crouch[2] = ground_z + ha + params.crouch_fraction * P1
    take = stand0.copy()
    take[2] = ground_z + ha + params.takeoff_fraction * P1
    top = take + np.array([D, 0.0, 0.0])
    touch = np.array([start_x + D, 0.0, land_z + ha + params.touchdown_fraction * P1])
    absorb = touch.copy()
    absorb[2] = land_z + ha + params.tuck_fraction * P1
    stand1 = _standing_pelvis(dims, params, start_x + D, land_z)
    lean = params.jump_lean * DEG
    turn = 2.0 * math.pi if params.somersault else 0.0
    f = T / _B_STEP_FRAMES  # seconds per B frame unit
    segs = (
        _Squat(100 * f, feet0, stand0, crouch, 0.0, lean, 0.0, 1.0, "jump: crouch"),
        _Squat(20 * f, feet0, crouch, take, lean, lean, 1.0, 1.0, "jump: up"),
        _Flight(
            100 * f,
            "arc",
            take,
            top,
            params.takeoff_fraction * P1,
            params.tuck_fraction * P1,
            params.tuck_fraction * P1,
            turn,
            lean,
            "jump: semicircle",
        ),
        _Flight(
            33 * f,
            "drop",
            top,
            touch,
            params.tuck_fraction * P1,
            params.tuck_fraction * P1,
            params.touchdown_fraction * P1,
            0.0,
            lean,
            "jump: down",
        ),
        _Squat(20 * f, feet1, touch, absorb, lean, lean, 1.0, 1.0, "jump: absorb"),
        _Squat(40 * f, feet1, absorb, stand1, lean, 0.0, 1.0, 0.0, "jump: back up"),
        _Stand(50 * f, stand1, feet1, label="jump: stand"),
    )
    return Plan(dims, params, segs, terrain, tuple(_markers(segs)), distance=D, climbed=land_z - ground_z)


def chain(*plans: Plan, terrain: Terrain | None = None) -> Plan:
    """Plans one after the other (each starts where and as the previous one ends: standing)."""
    if not plans:
        raise ScenarioError("chain needs at least one plan")
    segs: list = []
    markers: list[dict] = []
    t = 0.0
    for p in plans:
        segs.extend(p.segments)
        markers.extend({"time_s": m["time_s"] + t, "label": m["label"]} for m in p.markers)
        t += p.duration
    blocks = sorted({b for p in plans for b in p.terrain.blocks})
    return Plan(
        plans[0].dims,
        plans[0].params,
        tuple(segs),
        terrain or Terrain(tuple(blocks)),
        tuple(markers),
        distance=sum(p.distance for p in plans),
        climbed=sum(max(p.climbed, 0.0) for p in plans),
    )


def demo(
    dims: FigureDims | None = None,
    speed: float = 1.0,
    params: GaitParams | None = None,
    forward_steps: int = 6,
    up_steps: int = 5,
    final_steps: int = 4,
    rise: float | None = None,
    run: float | None = None,
) -> Plan:
    """B's demonstration (``main`` in Appendix B): 6 steps forward, 5 up the stairs, a jump off
    the top tread down to the floor, 4 steps forward."""
    dims = dims or FigureDims.from_anthropometry()
    params = params or GaitParams()
    fw = step_forward(dims, forward_steps, speed, params)
    x1 = fw.distance
    up = step_upward(dims, up_steps, speed, params, rise, run, start_x=x1)
    rise_, run_, _ = stair_geometry(dims, params, rise, run)
    x2, z2 = x1 + up_steps * run_, up_steps * rise_
    edge = up.terrain.blocks[-1][1]
    D = max(params.jump_distance, edge - x2 + dims.heel_back + 0.05)
    jp = jump(dims, speed, params, start_x=x2, ground_z=z2, land_z=0.0, distance=D)
    fw2 = step_forward(dims, final_steps, speed, params, start_x=x2 + D)
    return chain(fw, up, jp, fw2, terrain=up.terrain)


GAITS = ("forward", "upstairs", "jump", "demo")
