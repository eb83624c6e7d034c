"""The stepping controller's swing phase (:class:`SwingPhase`, a mixin of
:class:`biped.control.stepping.SteppingController`): a step's start (which foot, crossover,
landing limits), the swing (the landing target, the ankle's path) with the stance in single
support, and the touchdown.

- **start**: swing foot rule: for the first step, the foot off the floor if only one is on it,
  else the foot whose sole centre lies nearer to xi across the body (the push side); later steps
  alternate feet, and with ``crossover`` a later sideways step whose capture point lies past the
  stance foot crosses over; a closing step (:mod:`biped.control.closing_step`) moves the foot it
  names to a fixed landing point.
- **swing**: the stance leg carries the body through W's recursions with the contact flags
  (stance, not swing): Alg. 3 with one big base, the QP's single-sole cone; the stance controller
  keeps the height and orientation set points and lets the COM run horizontally, with the LIPM's
  acceleration fed forward. The landing point of the swing sole's centre is
  :func:`~biped.control.capture.step_target`, recomputed every control period for the first
  ``retarget_until`` of the swing; the ankle follows a minimum-jerk path to it with a bump of
  height ``apex_m``; after ``swing_time_s`` it keeps moving down at ``descent_m_s`` until
  touchdown. Swing-leg torques: the body's swing law (:mod:`biped.control.swing`).
- **touchdown**: the swing foot's contact flag after half the swing time; then double support
  again, the set point moved by the change of the feet's midpoint.

Moved out of ``stepping.py`` unchanged (the same arithmetic, bit for bit)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from biped.control import capture as cp
from biped.control import closing_step, crossover_path, leg_geometry, stance_dynamics, swing_period
from biped.control.setpoint import replaced
from biped.control.swing import swing_reaction_wrench
from biped.control.workspace import Gains

__all__ = ["AIRBORNE_M", "FEET", "SwingPhase"]

FEET = ("left", "right")
#: With W's fixed support and "qp", a foot whose sole centre is this far above the floor is left
#: out of the double-support QP (and, with ``airborne_stance``, of the single-support one) [m].
AIRBORNE_M = 0.10


class SwingPhase:
    """The swing-phase methods of :class:`~biped.control.stepping.SteppingController` (a mixin:
    they use its state, set in its ``__init__`` and ``reset``)."""

    #: the plain swing's compiled period (:mod:`biped.control.swing_period`), made on first use
    _swing_plan: swing_period.SwingPlan | None = None

    if TYPE_CHECKING:  # the controller's attributes, for the type checker

        def __getattr__(self, name: str) -> Any: ...

    def _start_step(self, t, xi, feet, closing=None):
        s = self.stepping
        poly = self._polygon(feet)
        ex = max(xi[0] - poly[:, 0].max(), poly[:, 0].min() - xi[0])
        ey = max(xi[1] - poly[:, 1].max(), poly[:, 1].min() - xi[1])
        lateral = ey > ex
        if closing is not None:  # slow, W's orientation gains, to a fixed landing point
            self._T, self._offset, self._limits = s.closing_swing_time_s, 0.0, s.limits
            lateral = True
        elif lateral:
            self._T, self._offset, self._limits = s.lateral_swing_time_s, s.lateral_offset_m, s.lateral_limits
        else:
            self._T, self._offset, self._limits = s.swing_time_s, s.offset_m, s.limits
        self._swing_gains = self._gains_by_mode[lateral]
        self._ctrl_swing = self._ctrl_swing_by_mode[lateral]
        if closing is not None:
            swing = closing
        elif self.steps:  # later steps alternate feet
            swing = 1 - FEET.index(self.steps[-1]["foot"])
        elif feet[0] != feet[1] and not lateral:
            swing = 0 if not feet[0] else 1
        else:
            dy = [abs(self._sole_pose(i)[0][1] - xi[1]) for i in (0, 1)]
            swing = 0 if dy[0] < dy[1] else 1
        self.swing = swing
        # a crossover: a sideways step whose capture point lies beyond the stance sole's centre,
        # on the side away from the swing foot (the alternate foot cannot reach it on its own side)
        # (in W's facing: a robot's floor turned by its ``facing`` rotation)
        across = xi[:2] - self._sole_pose(1 - swing)[0][:2]
        if self._facing is not None:
            across = self._facing @ across
        own = 1.0 if swing == 1 else -1.0
        self._cross = bool(
            s.crossover and self.steps and lateral and own * across[1] < 0.0 and closing is None
        )
        if self._cross and s.crossover_swing_time_s is not None:
            self._T = s.crossover_swing_time_s
        self._cross_ahead = None  # a crossover's end of the stance foot (+1 ahead, -1 behind)
        self._cross_windows = None  # its along and across windows (crossover_path "timed")
        self._swing0 = self._sole_pose(swing)[0][:2].copy()  # the swing sole's centre at the start
        self.phase = "swing"
        self._dwell_since = None
        self._t_start = t
        self._p0 = self.data.xpos[self._foot[swing]].copy()
        self._stance0 = self._sole_pose(1 - swing)[0][:2].copy()
        self._landing = None if closing is None else closing_step.landing(self, swing)
        self._closing = closing  # a recovery step during the shift ends it
        self._uncross = closing is not None and closing_step.crossed(self)
        self.steps.append(
            {
                "foot": FEET[swing],
                "start_s": t,
                "sideways": bool(lateral),
                "stance_slip_m": None,
                "lift_off_s": None,
                "touch_down_s": None,
                "position_m": None,
                "target_m": None,
            }
        )
        if s.crossover:  # the record says so where crossovers may happen ("capture" as before)
            self.steps[-1]["crossover"] = self._cross
        if s.closing_step:
            self.steps[-1]["closing"] = closing is not None

    def _swing_call(self, t, qpos, qvel, xi, omega, feet):
        s = self.stepping
        i = self.swing
        assert i is not None  # called only while a foot swings
        if swing_period.compiled_swing(self):  # the plain swing: one compiled call (both loops)
            return self._planned_call(t, qpos, qvel, xi, omega, feet)
        st = 1 - i
        step = self.steps[-1]
        el = t - self._t_start
        if step["lift_off_s"] is None and not feet[i]:
            step["lift_off_s"] = t
        # touchdown: on the floor after half the swing, once seen off it (else the swing goes on)
        if feet[i] and el > 0.5 * self._T and step["lift_off_s"] is not None:
            return self._touch_down(t, qpos, qvel, feet, xi)
        stance_c, cop = self._stance_cop(st)
        self._swing_el = el  # (the drop's ramp, swing_drop_ramp)
        side = 1.0 if i == 1 else -1.0
        if self._closing is None and (self._landing is None or el < s.retarget_until * self._T):
            self._landing = self._step_target(xi, cop, omega, self._T - el, stance_c[:2], side)
        land = self._landing
        assert land is not None  # set above, or when the closing step started
        step["target_m"] = [float(land[0]), float(land[1]), 0.0]
        # ankle path: the sole centre lands on `land`, flat, zero yaw
        sole_off = self._sole[i][0] if self._foot_rot is None else self._foot_rot[i] @ self._sole[i][0]
        ankle_land = np.array([land[0] - sole_off[0], land[1] - sole_off[1], -sole_off[2]])
        p0 = self._p0
        if self._cross and s.crossover_path == "timed" and self._cross_windows is None:
            assert p0 is not None  # timed from the step's geometry, once
            band = self._sole[i][2] + self._sole[st][2]
            gap = self._swing0[1] - self._stance0[1]
            d = ankle_land - p0
            self._cross_windows = crossover_path.windows(d[0], d[1], gap, band)
            if s.crossover_max_acc_m_s2 is not None:  # long enough for the bound on both moves
                self._T = crossover_path.swing_time(
                    d[0], d[1], self._cross_windows, self._T, s.crossover_max_acc_m_s2
                )
                step["swing_time_s"] = self._T
        T = self._T
        sc = el / T
        h, hd, hdd = cp.min_jerk(sc)
        b, bd, bdd = cp.bump(sc)
        pd = p0 + (ankle_land - p0) * h
        vd = (ankle_land - p0) * hd / T
        ad = (ankle_land - p0) * hdd / T**2
        if self._cross or self._uncross:  # around the stance foot: along x in the first 60 % of the swing,
            assert p0 is not None  # y in the last (uncrossing: across first, then along x)
            order = (0, 1) if self._cross else (1, 0)
            wins = crossover_path.FIXED
            if self._cross and s.crossover_path == "timed":  # timed from the step's geometry (above)
                assert self._cross_windows is not None
                wins = self._cross_windows
            for k, (s0, s1) in zip(order, wins, strict=True):
                hk, hdk, hddk = cp.min_jerk((sc - s0) / (s1 - s0))
                dk = ankle_land[k] - p0[k]
                Tk = T * (s1 - s0)
                pd[k], vd[k], ad[k] = p0[k] + dk * hk, dk * hdk / Tk, dk * hddk / Tk**2
        pd[2] += s.apex_m * b
        vd[2] += s.apex_m * bd / T
        ad[2] += s.apex_m * bdd / T**2
        if sc >= 1.0:
            pd[2] = ankle_land[2] - s.descent_m_s * (el - T)
            vd[2] = -s.descent_m_s
        return self._single_support(i, qpos, qvel, omega, cop, pd, vd, ad)

    def _planned_call(self, t, qpos, qvel, xi, omega, feet):
        """A period of the plain swing (:func:`biped.control.swing_period.plan`: the lift-off, the
        touchdown check, the landing point, the ankle's path, the stance's flags and feed-forward),
        then the swing law and W's controller, as :meth:`_single_support`."""
        i = self.swing
        assert i is not None
        pl = self._swing_plan
        if pl is None:
            pl = self._swing_plan = swing_period.SwingPlan()
        if pl(self, t, feet[i], xi, omega) == swing_period.TOUCHDOWN:
            return self._touch_down(t, qpos, qvel, feet, xi)
        o = pl.out
        target = replaced(self._swing_set_point(self._swing_com(i)), com_acc=(float(o[9]), float(o[10]), 0.0))
        tau_swing = self._swing_torques(i, o[0:3], o[3:6], o[6:9])
        flags = (bool(pl.contact[0]), bool(pl.contact[1]))
        tau = np.array(
            self._ctrl_swing.torques(
                qpos, qvel, target=target, gains=self._swing_gains, feet_in_contact=flags
            )
        )
        tau[self._leg_tau[i]] = tau_swing
        return self._out(tau)

    def _swing_com(self, i: int) -> np.ndarray:
        """The plain swing's COM set point: the body's, ``_swing_drop`` lower."""
        com = np.array(self.target.com)
        com[2] -= self._swing_drop(i)
        return com

    def _stance_cop(self, st: int) -> tuple[np.ndarray, np.ndarray]:
        """(the stance sole ``st``'s centre (3,), the stance CoP (2,)): the point of the stance
        sole nearest the COM (the QP pushes it there)."""
        stance_c, yaw = self._sole_pose(st)
        c, sn = math.cos(yaw), math.sin(yaw)
        rel = self.data.subtree_com[0][:2] - stance_c[:2]
        loc = np.array([c * rel[0] + sn * rel[1], -sn * rel[0] + c * rel[1]])
        loc = np.clip(loc, [-self._sole[st][1], -self._sole[st][2]], [self._sole[st][1], self._sole[st][2]])
        return stance_c, stance_c[:2] + np.array([c * loc[0] - sn * loc[1], sn * loc[0] + c * loc[1]])

    def _single_support(self, i, qpos, qvel, omega, cop, pd, vd, ad):
        """The torques while foot ``i`` swings toward ``pd`` (velocity ``vd``, acceleration ``ad``;
        a point out of the leg's reach is pulled back within it) and the other foot stands."""
        s = self.stepping
        hip = self.data.xpos[self._hip[i]]
        r = pd - hip
        if np.linalg.norm(r) > s.reach_m:  # out of reach: the nearest point within it
            if s.reach_on_floor and abs(r[2]) < s.reach_m:  # at its height: the foot still lands
                k = math.sqrt(s.reach_m**2 - r[2] ** 2) / float(np.hypot(r[0], r[1]))
                pd = np.array([hip[0] + k * r[0], hip[1] + k * r[1], pd[2]])
            else:
                pd = hip + r * (s.reach_m / np.linalg.norm(r))
        # stance: W's recursions with the swing foot off (one big base, single-sole QP); with
        # "qp", a stance sole over AIRBORNE_M up (the biped tumbling) is left out as in double
        # support: a QP loading a foot in the air made MuJoCo diverge
        flags = (i == 1, i == 0)
        if s.airborne_stance and self._sole_pose(1 - i)[0][2] >= AIRBORNE_M:
            flags = (False, False)
        # the COM falls freely over the stance sole: the LIPM's acceleration as feed-forward
        acc = omega**2 * (self.data.subtree_com[0][:2] - cop)
        com = np.array(self.target.com)
        drop = 0.0 if self._closing is not None else self._swing_drop(i)
        vz = az = 0.0
        # a crossover with crossover_modelled: the forward and backward steps' stance settings
        sideways = self.steps[-1]["sideways"] and not (self._cross and s.crossover_modelled)
        ramp = (
            s.swing_drop_ramp
            if not sideways or s.lateral_swing_drop_ramp is None
            else s.lateral_swing_drop_ramp
        )
        if ramp:  # the drop reached along a minimum-jerk path over the planned swing
            h, hd, hdd = cp.min_jerk(min(self._swing_el / self._T, 1.0))
            drop, vz, az = drop * h, -drop * hd / self._T, -drop * hdd / self._T**2
        com[2] -= drop
        target = self._leg_capped(self._swing_set_point(com), [1 - i])
        changes = {"com_acc": (float(acc[0]), float(acc[1]), az)}
        if ramp:  # the drop's rate too (without the ramp the target as before, bit for bit)
            changes["com_vel"] = (target.com_vel[0], target.com_vel[1], vz)
        target = replaced(target, **changes)
        tau_swing = self._swing_torques(i, pd, vd, ad)
        if s.swing_inertia_share is not None:  # forward and backward steps only
            self._inertia_friction(i, ad, 0.0 if sideways else s.swing_inertia_share)
        applied = tau_swing  # the torques the actuators give (clipped as _out clips)
        if self.limits is not None and (s.swing_reaction or s.stance_contact_model):
            lo, hi = self._ctrl_limits
            applied = np.clip(tau_swing, lo[self._leg_tau[i]], hi[self._leg_tau[i]])
        if s.swing_reaction and not (sideways and s.lateral_swing_reaction is False):
            target = self._with_swing_reaction(i, applied, qpos, qvel, target, flags)
        if s.stance_contact_model:  # the stance foot's friction rows on its predicted contact wrench
            on = not (sideways and s.lateral_stance_contact_model is False)
            stance_dynamics.set_stance_map(self, i, applied, flags if on else (False, False))
        tau = np.array(
            self._ctrl_swing.torques(
                qpos, qvel, target=target, gains=self._swing_gains, feet_in_contact=flags
            )
        )
        tau[self._leg_tau[i]] = tau_swing
        return self._out(self._knee_guarded(tau, 1 - i))

    def _swing_set_point(self, com: np.ndarray):
        """The body's swing set point at ``com`` (the body's ``target``, tilted by ``swing_tilt_deg``),
        built once while ``com`` stays the same (the whole swing, but with ``span_leg_m``): a
        Target is validated field by field when built, ~40 us of a swing period's Python."""
        key = com.tobytes()
        memo = getattr(self, "_swing_memo", None)
        if memo is None or memo[0] != key:
            memo = self._swing_memo = (key, self.body.target(tuple(com), self.stepping.swing_tilt_deg))
        return memo[1]

    def _inertia_friction(self, i, ad, share):
        """Set the single-support QP's friction this period: its pyramid's mu less what the swing
        leg's planned horizontal inertial force takes of the weight's friction,
        ``swing_inertia_share`` x leg mass x |a_xy| / (m g), at least ``swing_friction_min_scale`` mu."""
        s = self.stepping
        qp = self._ctrl_swing.qp
        w = qp.weights
        take = share * self._leg_mass[i] * float(np.hypot(ad[0], ad[1])) / (self._mass * self._gravity)
        qp._prm[6] = max(w.friction * w.friction_scale - take, s.swing_friction_min_scale * w.friction)

    def _knee_guarded(self, tau: np.ndarray, st: int) -> np.ndarray:
        """``tau`` (controller order) with the stance knee's one-sided spring-damper added
        (``stance_knee_min_deg``; unchanged when it is not set or the knee is bent more): flexion
        torque ``kp (q - q_min) + kv max(q', 0)`` once the knee (flexion negative) is straighter
        than ``-stance_knee_min_deg``."""
        s = self.stepping
        if s.stance_knee_min_deg is None:
            return tau
        q = float(self.data.qpos[self._leg_qpos[st][3]])
        q_min = -math.radians(s.stance_knee_min_deg)
        if q <= q_min:
            return tau
        qd = float(self.data.qvel[self._leg_dofs[st][3]])
        tau = np.array(tau, dtype=float)
        tau[self._leg_tau[st][3]] -= s.stance_knee_kp * (q - q_min) + s.stance_knee_kv * max(qd, 0.0)
        return tau

    def _height_drop(self, span_m: float, fixed_m: float) -> float:
        return leg_geometry.height_drop(self.stepping, span_m, leg_geometry.carried(fixed_m, self._knee_drop))

    def _swing_drop(self, i: int) -> float:
        return leg_geometry.swing_drop(self, i)

    def _with_swing_reaction(self, i, tau_swing, qpos, qvel, target, flags):
        """``target`` with the feed-forward acceleration that adds the driven swing leg's reaction
        to the stance leg's desired wrench (:func:`biped.control.swing.swing_reaction_wrench`):
        ``F_1^bd = P_1 (X^b + P_1^-1 dF) + z_1 = P_1 X^b + z_1 + dF``."""
        dF = swing_reaction_wrench(self, i, tau_swing)
        P1 = self._ctrl_swing.compute(
            qpos, qvel, target=target, gains=self._swing_gains, feet_in_contact=flags
        ).P1
        dX = np.linalg.solve(P1, dF)
        R = self.data.ximat[self._root].reshape(3, 3)  # the central body's COM principal frame
        # X^b = R^T (com_acc - ...) and R^T R_e ang_acc, R_e = R R_d^T (W Alg. 4)
        Rd = np.zeros(9)
        mujoco.mju_quat2Mat(Rd, np.asarray(target.quat, dtype=float))
        acc = np.asarray(target.com_acc) + R @ dX[:3]
        ang = np.asarray(target.ang_acc) + Rd.reshape(3, 3) @ dX[3:]
        return replace(target, com_acc=tuple(acc), ang_acc=tuple(ang))

    def _step_target(self, xi, cop, omega, t_remaining, stance, side):
        """:func:`~biped.control.capture.step_target` in W's facing (the body's ``facing``
        rotation of the floor, and back); a crossover step lands on the stance foot's far side,
        ahead of or behind it by ``crossover_clear_m``; else the sole centre lies
        ``side_margin_m`` beyond the predicted capture point on the swing foot's side."""
        s, R = self.stepping, self._facing
        if R is not None:
            xi, cop, stance = R @ xi, R @ cop, R @ stance
        if self._cross:
            land = cp.step_target(xi, cop, omega, t_remaining, stance, -side, self._offset, self._limits)
            ahead = self._cross_ahead
            if ahead is None:
                ahead = 1.0 if land[0] >= stance[0] else -1.0
                if s.crossover_side == "near" and abs(land[0] - stance[0]) < s.crossover_clear_m:
                    start = self._swing0 if R is None else R @ self._swing0
                    ahead = 1.0 if start[0] >= stance[0] else -1.0
                if s.crossover_side != "retarget":
                    self._cross_ahead = ahead
            land[0] = stance[0] + ahead * max(ahead * (land[0] - stance[0]), s.crossover_clear_m)
        else:
            land = cp.step_target(
                xi, cop, omega, t_remaining, stance, side, self._offset, self._limits, s.side_margin_m
            )
        return land if R is None else R.T @ land

    def _swing_torques(self, i, pd, vd, ad):
        """The swing leg's torques (the body's swing law; W's :func:`biped.control.swing.swing_leg_torques`)."""
        return self.body.swing(self, i, pd, vd, ad)

    def _touch_down(self, t, qpos, qvel, feet, xi):
        i = self.swing
        assert i is not None and self._mid0 is not None  # a foot swings, after the first call
        step = self.steps[-1]
        c, _ = self._sole_pose(i)
        step["touch_down_s"] = t
        step["position_m"] = [float(x) for x in c]
        # how far the stance sole slid while the foot swung (the swing leg's reaction is not in
        # the stance QP's model: W treats the free leg as passive)
        step["stance_slip_m"] = float(np.linalg.norm(self._sole_pose(1 - i)[0][:2] - self._stance0))
        # Hof et al. 2010: the landing point against the extrapolated COM at touchdown
        step["xcom_m"] = [float(xi[0]), float(xi[1])]
        step["xcom_offset_m"] = cp.xcom_offset(c[:2], xi, self._sole_pose(1 - i)[0][:2])
        if step["lift_off_s"] is None:
            step["lift_off_s"] = step["start_s"]
        mid = 0.5 * (self._sole_pose(0)[0] + self._sole_pose(1)[0])
        com = np.array(self.base_target.com)
        com[:2] += mid[:2] - self._mid0[:2]
        # wider stance: lower hips (fixed, or as low as the legs need to span the step)
        span = float(np.linalg.norm(self._sole_pose(i)[0][:2] - self._sole_pose(1 - i)[0][:2]))
        com[2] -= self._height_drop(span, self.stepping.post_step_height_drop_m)
        self.target = replace(self.base_target, com=tuple(com))
        g = self.config.gains
        sp = self.stepping
        self.gains = Gains(
            kp_com=(sp.post_step_kp_xy, sp.post_step_kp_xy, g.kp_com[2]),
            kv_com=(sp.post_step_kv_xy, sp.post_step_kv_xy, g.kv_com[2]),
            kp_rot=g.kp_rot,
            kv_rot=g.kv_rot,
        )
        self.phase = "double"
        self.swing = None
        self._closing = None
        self._close_pending = False
        self._last_td = t
        self._settled = False
        self.trigger = self._new_trigger()
        target = self._leg_capped(self.target, (0, 1))
        tau = self._ctrl_post.torques(
            qpos, qvel, target=target, gains=self.gains, feet_in_contact=self._flags(*feet)
        )
        return self._out(tau)
