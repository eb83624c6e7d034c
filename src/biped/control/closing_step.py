"""The closing step of the stepping recovery (``SteppingConfig.closing_step``, off by default; issue
#23 item 2): once at rest after the last recovery step, a slow step of one foot back to a
comfortable stance. Built and measured, not adopted: it takes ~2 s after the last step, and in
4 s trials many pushes are then not at rest (docs/controller.md, "The closing step").

The rule (docs/controller.md, "The closing step"): the stance is *comfortable* when, in W's
facing, the feet are not crossed (each foot on its own side of the other, as at the start), their
lateral distance between sole centres lies within ``closing_band_m`` of the starting stance width
(W's 16.8 cm; people's natural stance: 16.5 cm, SD 3.8 cm, between the feet, "Feet distance and
static postural balance", Bio-Med Mater Eng, bme1085; McIlroy & Maki 1997 ~17 cm between the
heel centres) and neither foot is more than ``closing_band_m`` ahead of the other. Otherwise the
foot farther from the COM moves (the COM then needs the shorter shift over the remaining foot's
sole): first the set point moves over the remaining sole's centre, critically damped (double
support, ``"shift"``) until the capture point and the COM lie ``closing_inside_m`` inside that
sole, then the foot
swings slowly (``closing_swing_time_s``) to the starting stance width beside it, on its own
side, level with it; after the touchdown the set point goes back over the feet's midpoint.

Functions of the :class:`~biped.control.stepping.SteppingController` ``ctl`` (its MuJoCo data
after ``mj_forward`` of the present state)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from biped.control import capture as cp

__all__ = [
    "begin",
    "comfortable",
    "crossed",
    "facing_offset",
    "landing",
    "plan",
    "ready",
    "shift_call",
    "shift_target",
]


def _to_facing(ctl, v: np.ndarray) -> np.ndarray:
    return v if ctl._facing is None else ctl._facing @ v


def facing_offset(ctl) -> np.ndarray:
    """Foot 1's sole centre from foot 0's, horizontal, in W's facing [m]."""
    return _to_facing(ctl, ctl._sole_pose(1)[0][:2] - ctl._sole_pose(0)[0][:2])


def crossed(ctl) -> bool:
    """Whether each foot stands on the other's side of it (in W's facing, against the start)."""
    return bool(facing_offset(ctl)[1] * ctl._stance_start[1] <= 0.0)


def comfortable(ctl) -> bool:
    """Whether the feet stand as the rule above calls comfortable."""
    s, start = ctl.stepping, ctl._stance_start
    now = facing_offset(ctl)
    if crossed(ctl):
        return False
    return bool(
        abs(abs(now[1]) - abs(start[1])) <= s.closing_band_m and abs(now[0] - start[0]) <= s.closing_band_m
    )


def plan(ctl, com_xy: np.ndarray) -> int:
    """The foot that moves: the one whose sole centre lies farther from the COM."""
    d = [float(np.linalg.norm(ctl._sole_pose(i)[0][:2] - com_xy)) for i in (0, 1)]
    return 0 if d[0] > d[1] else 1


def landing(ctl, i: int) -> np.ndarray:
    """Where foot ``i``'s sole centre lands: beside the other's at the starting stance's offset."""
    start = ctl._stance_start  # foot 1 from foot 0
    rel = start if i == 1 else -start
    rel = ctl._facing.T @ rel if ctl._facing is not None else rel
    return ctl._sole_pose(1 - i)[0][:2] + rel


def shift_end(ctl, i: int) -> np.ndarray:
    """The set point's horizontal COM over foot ``1 - i``'s sole centre (W's offset from the
    feet's midpoint kept)."""
    mid = 0.5 * (ctl._sole_pose(0)[0][:2] + ctl._sole_pose(1)[0][:2])
    return np.array(ctl.target.com[:2]) + ctl._sole_pose(1 - i)[0][:2] - mid


def shift_target(ctl, el: float):
    """The set point ``el`` into the shift: the horizontal COM from the set point ``a`` to
    :func:`shift_end` ``b`` as a critically damped approach, ``b + (a - b) (1 + k el) e^{-k el}``
    (k = ``closing_shift_rate_1_s``), its velocity and acceleration fed forward. Its capture point
    ``x + v / omega_0`` never passes ``b`` while k <= omega_0 (~3.5 /s): a minimum-jerk path in
    0.4 s + 2 s per metre put it past the sole, and the trigger fired (measured)."""
    a, b, k = ctl._shift_from, ctl._shift_to, ctl.stepping.closing_shift_rate_1_s
    e = math.exp(-k * el)
    com = (*(b + (a - b) * (1.0 + k * el) * e), ctl.target.com[2])
    vel = (*(-(a - b) * k * k * el * e), 0.0)
    acc = (*(-(a - b) * k * k * (1.0 - k * el) * e), 0.0)
    f = [tuple(float(x) for x in v) for v in (com, vel, acc)]
    return replace(ctl.target, com=f[0], com_vel=f[1], com_acc=f[2])


def ready(ctl, i: int, com_xy: np.ndarray, xi: np.ndarray) -> bool:
    """Whether the capture point lies ``closing_inside_m`` and the COM ``closing_com_inside_m``
    (None: ``closing_inside_m``) inside foot ``1 - i``'s sole."""
    c, yaw = ctl._sole_pose(1 - i)
    _, hl, hw = ctl._sole[1 - i]
    poly = cp.support_polygon([(c[:2], yaw, hl, hw)])
    s = ctl.stepping
    mc = s.closing_inside_m if s.closing_com_inside_m is None else s.closing_com_inside_m
    return cp.signed_distance(poly, xi) <= -s.closing_inside_m and cp.signed_distance(poly, com_xy) <= -mc


def begin(ctl, t: float, com: np.ndarray) -> bool:
    """At the settling switch: start the closing step's shift if the rule asks for one (once a
    run, ``closing_step`` on, the stance not comfortable); True if it started."""
    s = ctl.stepping
    if not s.closing_step or ctl._closed or comfortable(ctl):
        return False
    ctl._closed, ctl._shift_t, ctl.phase = True, t, "shift"
    ctl._closing = i = plan(ctl, com[:2])
    ctl._shift_from, ctl._shift_to = np.array(ctl.target.com[:2]), shift_end(ctl, i)
    return True


def shift_call(ctl, t, qpos, qvel, com, xi, feet):
    """The closing step's weight shift (double support, the settling controller, the set point
    over the foot that stays): its torques, or None once the swing starts (``ready``) or the
    shift is given up after ``closing_shift_max_s`` (then back to double support over both feet)."""
    # Imported here, not at the top: biped.control.stepping imports this module (its helpers sit
    # below it), so a top-level import would be circular, and the class is needed only here, for
    # its own step start (a StepProgram overrides _start_step; the closing step is not its step).
    from biped.control.stepping import SteppingController

    s, i, el = ctl.stepping, ctl._closing, t - ctl._shift_t
    if ready(ctl, i, com[:2], xi):
        SteppingController._start_step(ctl, t, xi, feet, closing=i)  # (not a StepProgram's own)
        return None
    if el > s.closing_shift_max_s:
        ctl.phase, ctl._closing = "double", None
        return None
    target = ctl._leg_capped(shift_target(ctl, el), (0, 1))
    g = ctl.gains  # critically damped horizontally: no overshoot past the sole
    kv = tuple(
        2.0 * math.sqrt(k) if j < 2 else v for j, (k, v) in enumerate(zip(g.kp_com, g.kv_com, strict=True))
    )
    tau = ctl._ctrl_settle.torques(
        qpos, qvel, target=target, gains=replace(g, kv_com=kv), feet_in_contact=ctl._flags(*feet)
    )
    return ctl._out(tau)
