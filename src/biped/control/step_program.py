"""A step program for a delayed, lagged, rate-limited plant (scenario key ``step_program =
"program"``; docs/validate.md, "The step program").

:class:`~biped.control.stepping.SteppingController` swings the foot with a stiff task-space
feedback loop (kp 400 /s^2): W's instant torques close it in a few ms, but on 100 ms old state,
behind a 60 ms activation lag and a torque rate limit, the same loop cannot lift a loaded foot
(docs/validate.md, "Misses"). People split a stepping response into a reaction, a weight transfer
and the step (Thelen et al. 1997, J Gerontol A 52:M8-13); a controller with a human latency must
plan what it cannot correct in time. :class:`StepProgram` keeps the stepping controller's trigger,
swing-foot choice, landing rule, stance control and touchdown, and changes how a step is made:

1. **weight transfer** (``transfer_s`` after the trigger): double support as before, plus a
   feed-forward lateral acceleration ``transfer_acc_m_s2`` of the central body's COM toward the
   stance foot (W Alg. 4's ``pddot_d``): the contact distribution moves the centre of pressure
   under the swing foot first, which pushes the body over the stance foot (an anticipatory
   postural adjustment), and the stance leg takes the load before the swing foot must rise.
2. **swing**: the swing ankle's path (minimum jerk to the landing point, a bump of ``apex_m``; with
   ``swing_brake``, the bang-bang jerk path :func:`~biped.control.swing_plan.scurve`, scenario key
   ``swing_path``) is a plan in time from the swing's start. The feed-forward acceleration is the plan's
   ``lead_s`` ahead (the activation lag: a first-order lag delays a smooth command by about its
   time constant); the feedback compares the delayed state with the plan ``delay_s`` ago (the
   state the controller sees is that old), with gains ``kp_pos``, ``kv_pos``. The landing point is
   the stepping controller's, from the capture point predicted ``delay_s`` forward by the linear
   inverted pendulum (``xi(t + d) = cop + (xi(t) - cop) e^(omega d)``). The stance: W's recursions
   with the swing leg a passive branch, so the reaction of the swing leg's hip torques on the
   central body is not in W's model; the program feeds it forward (``reaction_ff``): the moment
   ``-sum(tau_k a_k)`` of the three hip joints (axes a_k) as a desired acceleration ``X =
   -P_1^{-1} W`` (W Alg. 4's ``pddot_d``, ``wdot_d``, as the lean release holds its tether), so
   the stance leg cancels it (an internal model of the limb, as people anticipate a limb's
   reaction); without it the swing's hip flexion pitched the trunk 24 deg forward and the foot
   rose instead of travelling (docs/validate.md).
3. **touchdown**: the swing foot's contact once its sole has been seen 1 cm above the floor (a
   sliding foot's contact flicker is not a landing) and half the planned swing has passed (with
   ``land_within_m``: only near the landing point or once the plan is over), or the planned swing
   time plus ``give_up_s`` after the swing's start if it never rose.

With no delay and no lag (``delay_s = lead_s = 0``) the swing follows the plan with the gains
given; W's ideal runs use the feedback stepping controller (the default ``step_program``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import mujoco
import numpy as np

from biped.control import capture as cp
from biped.control.stepping import SteppingConfig, SteppingController
from biped.control.swing_plan import jerk_bound, scurve
from biped.control.workspace import Target
from biped.errors import ScenarioError

__all__ = ["StepProgram", "StepProgramConfig", "predicted_capture_point"]

#: The sole must have been seen this high above the floor before a contact counts as a landing [m].
LIFT_M = 0.01


@dataclass(frozen=True)
class StepProgramConfig:
    """The program's timing and gains (SI units; chosen here, not fitted: docs/validate.md).

    delay_s: the controller's own feedback delay (the state it gets is this old).
    swing_time_s: the planned swing's duration: about the shortest a torque rate limit allows
    (docs/validate.md: a jerk-limited swing of d = 0.45 m takes (32 d / J)^(1/3) = 0.44 s, J =
    827 N m/s (the young hip flexion rate limit) / 0.8 m (the leg) / ~6 kg (the leg's effective
    mass at the ankle, from the swing's computed torque)).
    lead_s: the feed-forward's lead over the plan (the activation lag's time constant).
    transfer_s: the weight transfer's duration. transfer_acc_m_s2: its lateral feed-forward
    acceleration of the COM toward the stance foot. kp_pos, kv_pos: the swing foot's feedback
    gains on the delayed error [1/s^2, 1/s] (60, 12: a loop of delay margin 0.051 s with the 60 ms
    lag, half the young delay: tolerated for a swing of 0.45 s, where (10, 4.2), margin 0.18 s,
    left the foot 0.1-0.2 m behind its plan; docs/validate.md). give_up_s: after the planned
    swing time, how long a foot that never rose keeps trying before double support returns.
    toe_lift_deg: dorsiflexion added in the swing's first half. damping_n_m_s: the plant's
    intrinsic joint damping, fed forward on the plan's joint rates. rot_gain_scale: the trunk's
    orientation gains in single support times this (kv by its square root; 1: the preset's, delay
    margin 0.176 s with the young lag; 2 (margin 0.127 s) moved the young threshold by 0.04 deg,
    the feedback stepper's 4 has 0.084 s, below the delay). reaction_ff: the share of the swing
    leg's hip torques' reaction fed forward to the stance (1: all, 0: none, the program before).
    rear_trails: after the step, in double support, the height set point is capped by the front
    (landing) leg alone, not by both legs (:meth:`StepProgram._leg_capped`): the rear foot may
    roll onto its toe and trail instead of the hips being lowered to keep it flat (False: both
    legs, the program before; docs/validate.md, "Braking after the lunge").
    rear_toe_free_deg: with ``rear_trails``, after the step in double support, the rear foot is no
    support of the QP while its sole is tilted more than this [deg] (rolled onto its toe); 0: a
    support whenever the stepping controller's flags say so (the program before). The QP takes a
    support foot as flat, its centre of pressure anywhere on the sole: on a toe-down rear foot it
    asked the rear hip for up to 133 N m of extension, and when the toe left the floor the rate
    limit let that torque fall only over 0.17 s, which flung the leg 0.5 m up and 0.27 m back
    (docs/validate.md, "The young's rear foot flung").
    swing_brake: None (the ankle's path the minimum-jerk polynomial), or the path the bang-bang
    jerk profile (:func:`biped.control.swing_plan.scurve`; 1: ending at rest, as the
    minimum-jerk path, in 0.81 of its time for the same peak jerk; docs/validate.md).
    swing_jerk_m_s3: 0 (the swing takes ``swing_time_s``), or the path's peak jerk [m/s^3]: the
    swing's time is then the shortest whose path reaches the landing point within it (the
    bang-bang path's ``jerk_bound d / T^3``, the minimum-jerk's ``60 d / T^3``), d from the swing's
    start to the landing point planned for the time left, recomputed with the landing point, and
    the plan's clock runs at ``1 / T`` (a longer T slows the plan, it does not move it back); at
    least ``swing_time_s`` (:func:`biped.control.swing_plan.swing_jerk_m_s3`; docs/validate.md,
    "The S-curve tracked").
    land_within_m: None (a contact after half the planned swing is the landing), or a contact of
    the swing foot counts as its landing only with the sole centre within this distance of the
    landing point, or once the planned swing is over; before, the swing goes on.
    aim_offset_m: None (the landing point lies the stepper's ``offset_m`` beyond the capture point
    predicted for the touchdown), or this offset instead (< 0: behind it; Hof, Vermerris &
    Gjaltema 2010: people land a constant offset beyond the XCoM; docs/validate.md, "Aiming the
    timed step").
    """

    delay_s: float = 0.0
    lead_s: float = 0.0
    swing_time_s: float = 0.45
    transfer_s: float = 0.1
    transfer_acc_m_s2: float = 3.0
    kp_pos: float = 60.0
    kv_pos: float = 12.0
    give_up_s: float = 0.3
    toe_lift_deg: float = 10.0
    damping_n_m_s: float = 0.0
    rot_gain_scale: float = 1.0
    reaction_ff: float = 1.0
    rear_trails: bool = False
    rear_toe_free_deg: float = 0.0
    swing_brake: float | None = None
    swing_jerk_m_s3: float = 0.0
    land_within_m: float | None = None
    aim_offset_m: float | None = None

    def __post_init__(self):
        if not isinstance(self.rear_trails, bool):
            raise ScenarioError(f"step program: rear_trails must be true or false; got {self.rear_trails!r}")
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "aim_offset_m":
                if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and abs(v) <= 0.3):
                    raise ScenarioError(
                        f"step program: aim_offset_m must be None or a number in [-0.3, 0.3] m; got {v!r}"
                    )
                continue
            if f.name == "rear_trails" or (f.name in ("swing_brake", "land_within_m") and v is None):
                continue  # a bool (checked above); no brake: the minimum-jerk path
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ScenarioError(f"step program: {f.name} must be a number >= 0; got {v!r}")
        if self.swing_brake is not None and self.swing_brake > 1:
            raise ScenarioError(
                f"step program: swing_brake must be in [0, 1] or None; got {self.swing_brake!r}"
            )
        if not self.swing_time_s > 0:
            raise ScenarioError(f"step program: swing_time_s must be > 0 s; got {self.swing_time_s!r}")


def predicted_capture_point(xi, cop, omega: float, ahead_s: float) -> np.ndarray:
    """The capture point ``ahead_s`` later under the linear inverted pendulum with the centre of
    pressure fixed at ``cop``: ``cop + (xi - cop) e^(omega ahead_s)`` (its exact solution)."""
    xi, cop = np.asarray(xi, dtype=float), np.asarray(cop, dtype=float)
    return cop + (xi - cop) * math.exp(omega * ahead_s)


class StepProgram(SteppingController):
    """The stepping controller with the program above (same call and results)."""

    def __init__(self, config, stepping: SteppingConfig | None = None, joint_order=None, *,
                 tree=None, program: StepProgramConfig | None = None):  # fmt: skip
        self.program = program or StepProgramConfig()
        base = stepping or SteppingConfig()
        pg = self.program
        # the stance gains a delayed loop tolerates: the scenario's own (the presets' have a delay
        # margin of 1.8-2.2 x the young delay; the trunk's x rot_gain_scale in single support), not
        # the feedback stepper's trunk x4 (margin 0.084 s) nor its COM gains after the step
        # (margin 0.117 s)
        g = config.gains
        base = replace(base, kp_pos=pg.kp_pos, kv_pos=pg.kv_pos, swing_time_s=pg.swing_time_s,
                       swing_rot_gain_scale=pg.rot_gain_scale, lateral_rot_gain_scale=pg.rot_gain_scale,
                       post_step_kp_xy=g.kp_com[0], post_step_kv_xy=g.kv_com[0])  # fmt: skip
        super().__init__(config, base, joint_order, tree=tree)
        self._central = self.model.body("central_body").id

    def reset(self) -> None:
        super().reset()
        self._t_transfer = 0.0
        self._side_y = 0.0  # the lateral direction toward the stance foot (+-1)
        self._lifted = False
        self._el = 0.0  # time since the swing's start [s]
        self._u = 0.0  # the swing's phase (with swing_jerk_m_s3: its clock at 1 / T)
        self._t_clock = 0.0  # the swing clock's last call [s]
        self._v_ff: np.ndarray | None = None  # the plan's ankle velocity lead_s ahead

    # ------------------------------------------------------------------ the call
    def __call__(self, t: float, qpos: np.ndarray, qvel: np.ndarray, feet) -> np.ndarray:
        if self.phase == "transfer":
            return self._transfer_call(t, qpos, qvel, feet)
        return super().__call__(t, qpos, qvel, feet)

    def _start_step(self, t, xi, feet, closing=None):
        super()._start_step(t, xi, feet, closing)
        i = self.swing
        assert i is not None
        self.phase = "transfer" if self.program.transfer_s > 0 else "swing"
        self._t_transfer = t
        self._lifted = False
        com_y = float(self.data.subtree_com[0][1])
        self._side_y = math.copysign(1.0, self._sole_pose(1 - i)[0][1] - com_y)

    def _transfer_call(self, t, qpos, qvel, feet):
        m, d = self.model, self.data
        d.qpos[:] = qpos
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        if self._transferred(t):  # the swing starts now
            self.phase = "swing"
            assert self.swing is not None
            self._t_start = t
            self._p0 = d.xpos[self._foot[self.swing]].copy()
            self.steps[-1]["transfer_s"] = t - self._t_transfer
            return super().__call__(t, qpos, qvel, feet)
        tgt = self._leg_capped(self.target, (0, 1))
        acc = np.array(tgt.com_acc, dtype=float)
        acc[1] += self._side_y * self.program.transfer_acc_m_s2
        target = replace(tgt, com_acc=tuple(map(float, acc)))
        ctrl = self.ctrl if len(self.steps) > 1 else self._ctrl_before
        tau = ctrl.torques(qpos, qvel, target=target, gains=self.gains,
                           feet_in_contact=self._flags(bool(feet[0]), bool(feet[1])))  # fmt: skip
        return self._out(tau)

    def _leg_capped(self, target: Target, legs) -> Target:
        """The stepping controller's height cap; with ``rear_trails``, after the step in double
        support, the front (landing) leg's alone: as the COM runs on past the feet's midpoint the
        rear leg's cap lowered the set point, the hips sank, the front knee folded (from 65 to 107
        deg at a young 10 deg release) and the rear foot was pulled off the floor; capped by the
        front leg the hips stay up and the rear heel rises, the foot rolling onto its toe."""
        if self.program.rear_trails and self.phase == "double" and self.steps and len(legs) == 2:
            legs = (("left", "right").index(self.steps[-1]["foot"]),)
        return super()._leg_capped(target, legs)

    def _flags(self, left, right):
        """The stepping controller's support flags; with ``rear_toe_free_deg`` > 0 and
        ``rear_trails``, after the step in double support, not the rear foot while its sole is
        tilted more than that (its tilt: the angle between the sole's normal and the vertical)."""
        flags = super()._flags(left, right)
        p = self.program
        if p.rear_toe_free_deg > 0 and p.rear_trails and self.phase == "double" and self.steps and flags:
            rear = 1 - ("left", "right").index(self.steps[-1]["foot"])
            if self._tilt_deg(rear) > p.rear_toe_free_deg:
                flags = tuple(f and k != rear for k, f in enumerate(flags))
        return flags

    def _tilt_deg(self, i: int) -> float:
        """Sole ``i``'s tilt from flat [deg]: the angle of its frame's z axis from the vertical."""
        return math.degrees(math.acos(min(1.0, max(-1.0, float(self.data.xmat[self._foot[i]][8])))))

    def _transferred(self, t: float) -> bool:
        """Whether the weight transfer is over: ``transfer_s`` has passed, or the lateral capture
        point, predicted ``delay_s + lead_s`` ahead (the centre of pressure between the feet),
        lies within the stance sole's half width of its centre (the stance foot can then
        carry the body alone)."""
        p = self.program
        el = t - self._t_transfer
        if el >= p.transfer_s:
            return True
        i = self.swing
        assert i is not None
        mujoco.mj_subtreeVel(self.model, self.data)
        com = self.data.subtree_com[0]
        v = self.data.subtree_linvel[0]
        omega = cp.omega0(max(float(com[2]), 0.05), self._gravity)
        xi_y = float(com[1] + v[1] / omega)
        mid_y = 0.5 * float(self._sole_pose(0)[0][1] + self._sole_pose(1)[0][1])
        xi_y = mid_y + (xi_y - mid_y) * math.exp(omega * (p.delay_s + p.lead_s))
        return abs(xi_y - float(self._sole_pose(1 - i)[0][1])) <= self._sole[1 - i][2]

    def _swing_call(self, t, qpos, qvel, xi, omega, feet):
        s, p = self.stepping, self.program
        i = self.swing
        assert i is not None and self._p0 is not None
        st = 1 - i
        step = self.steps[-1]
        el = t - self._t_start
        timed = p.swing_jerk_m_s3 > 0  # the swing's clock runs at 1 / T, T from the step's length
        if timed:
            if self._landing is None:
                self._u = 0.0
            else:
                self._u += (t - self._t_clock) / self._T
            self._t_clock = t
            el = self._u * self._T
        self._el = el
        if self._sole_low(i) > LIFT_M:
            self._lifted = True
        if step["lift_off_s"] is None and not feet[i]:
            step["lift_off_s"] = t
        if feet[i] and el > 0.5 * self._T and self._lifted and self._arrived(i, el):
            return self._touch_down(t, qpos, qvel, feet, xi)
        if el > self._T + p.give_up_s and not self._lifted:  # it never rose: stand on both again
            step["aborted"] = True
            return self._touch_down(t, qpos, qvel, feet, xi)
        stance_c, cop = self._stance_cop(st)  # the stepper's stance CoP
        side = 1.0 if i == 1 else -1.0
        if self._landing is None or el < s.retarget_until * self._T:
            xi_now = predicted_capture_point(xi, cop, omega, p.delay_s)
            if timed:
                self._T, self._landing = self._feasible_time(xi_now, cop, omega, stance_c, side, i)
                el = self._el = self._u * self._T
                step["swing_time_s"] = self._T
            else:
                remaining = max(self._T - el, 0.0)
                self._landing = cp.step_target(xi_now, cop, omega, remaining, stance_c[:2], side, self._aim_offset(),
                                               self._limits)  # fmt: skip
        land = self._landing
        step["target_m"] = [float(land[0]), float(land[1]), 0.0]
        sole_off = self._sole[i][0]
        ankle_land = np.array([land[0] - sole_off[0], land[1] - sole_off[1], -sole_off[2]])
        pd, vd, _ = self._plan(el - p.delay_s, ankle_land)  # what the delayed state is compared with
        _, self._v_ff, ad = self._plan(el + p.lead_s, ankle_land)  # the feed-forward, ahead of the lag
        return self._single_support(i, qpos, qvel, omega, cop, pd, vd, ad)

    def _feasible_time(self, xi, cop, omega, stance_c, side, i):
        """(T, the landing point): the swing's time for its own length, the shortest whose path's
        peak jerk (:func:`~biped.control.swing_plan.jerk_bound` d / T^3; the minimum-jerk path's
        60 d / T^3) is ``swing_jerk_m_s3``, d the distance from the swing's start to the landing
        point planned for the time left, ``(1 - u) T`` (a fixed point; the landing limits bound d),
        never less than ``swing_time_s``."""
        p = self.program
        assert self._p0 is not None
        k = 60.0 if p.swing_brake is None else jerk_bound(p.swing_brake)
        c0 = self._p0[:2] + self._sole[i][0][:2]  # the sole centre at the swing's start
        T = max(self._T, p.swing_time_s)
        for _ in range(30):
            land = cp.step_target(xi, cop, omega, max(T * (1.0 - self._u), 0.0), stance_c[:2], side, self._aim_offset(),
                                  self._limits)  # fmt: skip
            d = float(np.linalg.norm(np.asarray(land[:2]) - c0))
            T_new = max(p.swing_time_s, (k * d / p.swing_jerk_m_s3) ** (1.0 / 3.0))
            if abs(T_new - T) < 1e-5:
                break
            T = T_new
        return T_new, land

    def _aim_offset(self) -> float:
        """The landing point's offset beyond the predicted capture point [m]."""
        a = self.program.aim_offset_m
        return self._offset if a is None else float(a)

    def _arrived(self, i: int, el: float) -> bool:
        """Whether a contact of the swing foot is its landing (``land_within_m``): its sole centre
        within that distance of the landing point, or the planned swing over; None: any contact
        after half the swing (the program before)."""
        w = self.program.land_within_m
        if w is None or el >= self._T or self._landing is None:
            return True
        return float(np.linalg.norm(self._sole_pose(i)[0][:2] - self._landing[:2])) <= w

    def _single_support(self, i, qpos, qvel, omega, cop, pd, vd, ad):
        """The stepping controller's single support, with the swing leg's hip torques' reaction
        on the central body fed forward to the stance (``reaction_ff``): W's controller models the
        free leg as a passive branch, so without it the swing's hip flexion pitches the trunk."""
        if self.program.reaction_ff <= 0:
            return super()._single_support(i, qpos, qvel, omega, cop, pd, vd, ad)
        s = self.stepping
        m, d = self.model, self.data
        hip = d.xpos[self._hip[i]]
        r = pd - hip
        if np.linalg.norm(r) > s.reach_m:
            pd = hip + r * (s.reach_m / np.linalg.norm(r))
        tau_sw = np.array(self._swing_torques(i, pd, vd, ad))
        moment = np.zeros(3)
        for k in range(3):  # hip abduction, flexion, rotation: their reaction on the central body
            j = m.dof_jntid[self._leg_dofs[i][k]]
            moment -= tau_sw[k] * d.xaxis[j]
        moment *= self.program.reaction_ff
        flags = (i == 1, i == 0)
        R = d.ximat[self._central].reshape(3, 3)
        out = self.ctrl.compute(qpos, qvel, gains=self._swing_gains, feet_in_contact=flags)
        X = -np.linalg.solve(out.P1, np.concatenate([np.zeros(3), R.T @ moment]))
        acc = omega**2 * (d.subtree_com[0][:2] - cop)
        com = np.array(self.target.com)
        com[2] -= self._swing_drop(i)
        target = self._leg_capped(Target.wendlandt(com=tuple(com), tilt_deg=s.swing_tilt_deg), [1 - i])
        ca = R @ X[:3]
        target = replace(target, com_acc=(float(acc[0] + ca[0]), float(acc[1] + ca[1]), float(ca[2])),
                         ang_acc=tuple(map(float, R @ X[3:])))  # fmt: skip
        tau = np.array(
            self.ctrl.torques(qpos, qvel, target=target, gains=self._swing_gains, feet_in_contact=flags)
        )
        tau[self._leg_tau[i]] = tau_sw
        return self._out(self._knee_guarded(tau, 1 - i))

    def _sole_low(self, i: int) -> float:
        """The height of the lowest corner of sole ``i`` above the floor [m] (a heel lifted about
        the toe is not a foot off the floor)."""
        c, _ = self._sole_pose(i)
        R = self.data.xmat[self._foot[i]].reshape(3, 3)
        return float(c[2] - abs(R[2, 0]) * self._sole[i][1] - abs(R[2, 1]) * self._sole[i][2])

    def _flat_foot_angles(self, i: int, ahead: float) -> tuple[float, float]:
        """(inversion, dorsiflexion) that put foot ``i`` flat with zero yaw on its shank's
        orientation predicted ``ahead`` seconds on (the shank's angular velocity held)."""
        m, d = self.model, self.data
        jr = np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, None, jr, self._shank[i])
        w_sh = jr @ d.qvel  # the shank's angular velocity, world
        quat = np.zeros(4)
        dR = np.zeros(9)
        n = float(np.linalg.norm(w_sh))
        mujoco.mju_axisAngle2Quat(quat, w_sh / (n + 1e-12), n * ahead)
        mujoco.mju_quat2Mat(dR, quat)
        R = (dR.reshape(3, 3) @ d.xmat[self._shank[i]].reshape(3, 3)).T
        return self._inv_sign[i] * math.atan2(R[2, 1], R[1, 1]), math.atan2(R[0, 2], R[0, 0])

    def _swing_torques(self, i, pd, vd, ad):
        """The stepping controller's swing-leg torques (task-space feedback on the delayed error,
        the plan's acceleration ahead) with two parts an internal model of the limb supplies:

        - the plant's intrinsic joint damping (``damping_n_m_s``, which W's controller does not
          model) times the joint rates the plan asks for ``lead_s`` ahead (hip ab/adduction, hip
          flexion, knee: the plan's ankle velocity through the leg's Jacobian);
        - the ankle's flat-foot angles on the shank's orientation predicted ``delay_s + lead_s``
          ahead, plus ``toe_lift_deg`` of dorsiflexion in the first half of the swing, and the
          damping of the rate that prediction asks for: on the delayed shank a foot lags a
          fast-turning shank and its toe catches the floor."""
        tau = super()._swing_torques(i, pd, vd, ad)
        m, d, s, p = self.model, self.data, self.stepping, self.program
        dofs = self._leg_dofs[i]
        q = d.qpos[self._leg_qpos[i]]
        b = p.damping_n_m_s
        if b > 0 and self._v_ff is not None:
            jp = np.zeros((3, m.nv))
            mujoco.mj_jacBody(m, d, jp, None, self._foot[i])
            J3 = jp[:, dofs][:, [0, 1, 3]]
            qd_ff = J3.T @ np.linalg.solve(J3 @ J3.T + 1e-4 * np.eye(3), self._v_ff)
            tau[[0, 1, 3]] += b * qd_ff
        ahead = p.delay_s + p.lead_s
        inv, dors = self._flat_foot_angles(i, ahead)
        if ahead > 0:
            inv0, dors0 = self._flat_foot_angles(i, 0.0)
            rate = ((inv - inv0) / ahead, (dors - dors0) / ahead)
        else:
            rate = (0.0, 0.0)
        if self._el < 0.5 * self._T:
            dors += math.radians(p.toe_lift_deg)
        jf = np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, None, jf, self._foot[i])
        w = jf @ d.qvel
        for k, qk, wk, rk in ((4, inv, self._inv_sign[i] * w[0], rate[0]), (5, dors, w[1], rate[1])):
            tau[k] = s.ankle_kp * (qk - q[k]) - s.ankle_kv * wk + d.qfrc_bias[dofs[k]] + b * rk
        return np.clip(tau, -s.swing_torque_max_n_m, s.swing_torque_max_n_m)

    def _plan(self, el: float, ankle_land: np.ndarray):
        """The ankle's planned (position, velocity, acceleration) ``el`` after the swing's start:
        minimum jerk from the start to ``ankle_land`` in ``self._T``, a bump of ``apex_m``, then
        down at ``descent_m_s``; before the start, the start at rest."""
        s, T = self.stepping, self._T
        p0 = self._p0
        assert p0 is not None
        sc = min(max(el / T, 0.0), 1.0)
        brake = self.program.swing_brake
        h, hd, hdd = cp.min_jerk(sc) if brake is None else scurve(sc, brake)  # the path's shape
        b, bd, bdd = cp.bump(sc)
        pd = p0 + (ankle_land - p0) * h
        vd = (ankle_land - p0) * hd / T
        ad = (ankle_land - p0) * hdd / T**2
        pd[2] += s.apex_m * b
        vd[2] += s.apex_m * bd / T
        ad[2] += s.apex_m * bdd / T**2
        if el < 0:
            vd[:] = 0.0
            ad[:] = 0.0
        if el >= T:
            pd[2] = ankle_land[2] - s.descent_m_s * (el - T)
            vd = np.array([0.0, 0.0, -s.descent_m_s])
            ad = np.zeros(3)
        return pd, vd, ad
