"""Stepping recovery around W's controller: when the capture point leaves the feet, take a step.
Not in W (W keeps the feet where they are); the capture-point rules are Pratt et al. 2006 and
Koolen et al. 2012, the math :mod:`biped.control.capture`.

Phases (one :class:`SteppingController` call per control period, ``(t, qpos, qvel, feet)``):

- **double support**: until the first step, exactly the feet-in-place controller of the
  scenario (with "qp": its QP, the legs' weight in the cones, the sensed feet), so a push that
  takes no step runs as without stepping. Every call the whole-body COM (MuJoCo ``subtree_com``
  of the biped's own model) gives the capture point ``xi = x + v / omega_0``, ``omega_0 =
  sqrt(g / h)``, h the COM height above the floor. The feet cannot hold once xi has left the
  support polygon of the soles in contact (the QP's CoP limits: no CoP outside it brings xi
  back, ``xi' = omega_0 (xi - p)``) for ``hold`` periods
  (:class:`~biped.control.capture.CaptureTrigger`), or (``dwell_s`` set) once xi has stayed
  within ``dwell_margin_m`` of the polygon's edge for ``dwell_s``: then, if fewer than
  ``max_steps`` steps were taken, a step starts.
- **swing**: swing foot rule: for the first step, the foot off the floor if only one is on it,
  else the foot whose sole centre lies nearer to xi across the body (the push side: a push to
  the biped's right steps with the right foot); later steps alternate feet, and with ``crossover``
  a later sideways step whose capture point lies past the stance foot crosses over. The stance
  leg carries the body through W's
  recursions with the contact flags (stance, not swing): Alg. 3 with one big base, the QP's
  single-sole cone (friction rows on the floor's axes and scaled by ``swing_friction_scale``
  if set; or the min-norm split with one foot); the stance controller keeps the
  height and orientation set points and lets the COM run horizontally (kp, kv of x, y zero),
  as the LIPM prediction assumes. The landing point of the swing sole's centre is
  :func:`~biped.control.capture.step_target` (xi when the foot lands, from the stance sole
  centre as CoP, plus ``offset_m``, clamped to :class:`~biped.control.capture.StepLimits`),
  recomputed every control period for the first ``retarget_until`` of the swing. The ankle follows a
  minimum-jerk path to it in x, y, with a
  bump of height ``apex_m`` in z, flat sole, zero yaw; after ``swing_time_s`` it keeps moving
  down at ``descent_m_s`` until touchdown. Swing-leg torques: task-space computed torque on the
  leg's own 6 joints, ``tau = M_ll J_leg^{-1} (a_d + Kp e + Kd e') + b_l`` (J_leg the (6, 6)
  Jacobian of the foot frame (MuJoCo ``mj_jacBody``), M_ll the leg block of the mass matrix,
  b_l the leg's bias forces (gravity, Coriolis); the base's acceleration and J' q' are neglected;
  damped least squares near the knee singularity).
- **touchdown**: the swing foot's contact flag after half the swing time. Then double support
  again, the horizontal set point moved by the change of the feet's midpoint (the set point keeps
  its offset from the feet, now over the new support polygon).

``steps`` records every step: foot, lift_off_s (first period without contact), touch_down_s,
position_m (the sole centre at touchdown), target_m (the last landing target).
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np

from biped.control import capture as cp
from biped.control import closing_step, leg_geometry
from biped.control.limits import clip_torques
from biped.control.policy import PolicyConfig, _model_path, make_policy
from biped.control.stepping_body import SteppingBody, ankle_axis_along_sole, ankle_reaches, sole_pose, w_body
from biped.control.stepping_config import SteppingConfig
from biped.control.stepping_swing import AIRBORNE_M, SwingPhase
from biped.control.workspace import Gains, Target
from biped.errors import ScenarioError
from biped.model import TreeModel

__all__ = ["SteppingConfig", "SteppingController"]

#: Time constant of the low-pass filter on the capture point's rate [s].
RATE_TAU_S = 0.01


# the swing path's pieces (pure functions in capture.py; the old names kept for the tests)
_min_jerk = cp.min_jerk
_bump = cp.bump


class SteppingController(SwingPhase):
    """W's controller plus capture-point steps, ``(t, qpos (19,), qvel (18,), feet) -> torques
    (12,)`` in ``joint_order`` (default the model's). ``config`` is the underlying
    :class:`~biped.control.policy.PolicyConfig` (must be the workspace controller). ``body``: the
    biped's structure (:class:`~biped.control.stepping_body.SteppingBody`; default W's,
    :func:`~biped.control.stepping_body.w_body` of the config's model)."""

    def __init__(
        self,
        config: PolicyConfig,
        stepping: SteppingConfig | None = None,
        joint_order=None,
        *,
        tree: TreeModel | None = None,
        body: SteppingBody | None = None,
    ):
        if config.controller != "workspace":
            raise ScenarioError("stepping needs the workspace controller (controller = 'workspace')")
        self.config = config
        self.stepping = stepping or SteppingConfig()
        if body is None:
            self.model = mujoco.MjModel.from_xml_path(str(_model_path(config)))
        else:
            self.model = body.model
        self.data = mujoco.MjData(self.model)
        # a robot's controllers take its soles and big base (W's: read from the tree's model)
        ws = {} if body is None else {"soles": body.controller_soles, "big_base": body.big_base}
        ws = {k: v for k, v in ws.items() if v is not None}
        # with "qp" the torque limits are the QP's constraints (as in make_policy); the swing leg's
        # torques and the min-norm split's are clipped (_out)
        inner = replace(config, torque_limits=config.torque_limits if config.distribution == "qp" else None)
        if config.distribution == "qp" and self.stepping.qp_moment_weight is not None:
            from biped.control.distribution import QPWeights

            inner = replace(
                inner,
                qp_weights=replace(
                    config.qp_weights or QPWeights(),
                    moment=self.stepping.qp_moment_weight,
                    leg_weight=self.stepping.qp_leg_weight,
                    floor_friction=self.stepping.floor_friction,
                ),
            )
        self._inner = make_policy(inner, tree=tree, **ws)
        self.ctrl = self._inner.controller
        # before the first step: the scenario's own controller (its QP weights), so that a push
        # that takes no step runs exactly as without stepping
        plain = replace(inner, qp_weights=config.qp_weights)
        self._ctrl_before = make_policy(plain, tree=tree, **ws).controller if plain != inner else self.ctrl

        def qp_with(**changes):  # a controller of the stepping QP with these weights changed
            assert inner.qp_weights is not None  # every caller checks it
            w = replace(inner.qp_weights, **changes)
            return make_policy(replace(inner, qp_weights=w), tree=tree, **ws).controller

        # after a step, once at rest: the stepping QP with the scenario's moment weight
        self._ctrl_settle = self.ctrl
        if self.stepping.settle_after_s is not None and inner.qp_weights is not None and config.qp_weights:
            self._ctrl_settle = qp_with(moment=config.qp_weights.moment)
        # after a step, in double support: the stepping QP, its friction pyramid scaled by
        # post_step_friction_scale if set (a margin for a rear foot the QP takes as flat and loaded)
        self._ctrl_post = self.ctrl
        if self.stepping.post_step_friction_scale is not None and inner.qp_weights is not None:
            self._ctrl_post = qp_with(friction_scale=self.stepping.post_step_friction_scale)
        # single support: the stepping QP, its friction pyramid scaled by swing_friction_scale
        # (a sideways step's: lateral_swing_friction_scale, if set)
        # (its own controller also when swing_inertia_share rewrites its friction each period, or the
        # stance model its rows: neither must stay in the double support's QP after touchdown)
        self._ctrl_swing = self.ctrl
        sp = self.stepping
        own = (
            sp.swing_friction_scale is not None
            or sp.swing_inertia_share is not None
            or sp.stance_contact_model
        )
        if own and inner.qp_weights is not None:
            scale = sp.swing_friction_scale
            self._ctrl_swing = qp_with(
                friction_scale=inner.qp_weights.friction_scale if scale is None else scale
            )
        self._ctrl_swing_by_mode = {False: self._ctrl_swing, True: self._ctrl_swing}
        if sp.lateral_swing_friction_scale is not None and inner.qp_weights is not None:
            self._ctrl_swing_by_mode[True] = qp_with(friction_scale=sp.lateral_swing_friction_scale)
        names = tuple(self.ctrl.joint_names)
        self.joint_names = tuple(joint_order) if joint_order is not None else names
        if sorted(self.joint_names) != sorted(names):
            raise ScenarioError(
                f"controller joints {names} differ from the requested order {self.joint_names}"
            )
        self._order = np.array([names.index(n) for n in self.joint_names])
        m0 = self.model  # each output joint's dof and passive damping (rest_damping_compensation)
        self._out_dof = np.array([m0.jnt_dofadr[m0.joint(n).id] for n in self.joint_names])
        self._out_damping = np.asarray(m0.dof_damping)[self._out_dof].copy()
        only = self.stepping.rest_damping_joints
        if only is not None:
            self._out_damping *= [any(n.endswith(e) for e in only) for n in self.joint_names]
        self.limits = None
        if config.torque_limits is not None and not config.torque_limits.unlimited:
            self.limits = config.torque_limits.reorder(self.joint_names)
            lim = config.torque_limits.reorder(names)  # in the controller's order
            self._ctrl_limits = (lim.lower, lim.upper)
        m = self.model
        self.body = body = body if body is not None else w_body(m, self.ctrl.tree)
        self._foot = list(body.feet)
        self._hip = list(body.hips)
        self._shank = list(body.shanks)
        # the body of each leg's first ankle hinge (W's {side}_ankle_1): its origin is the ankle
        self._ankle = [int(m.jnt_bodyid[m.joint(leg[4]).id]) for leg in body.leg_joints]
        self._root = body.root
        self._inv_sign = list(body.inversion_sign)
        self._sole = list(body.soles)  # (sole centre in the foot body frame (3,), half length, half width)
        self._sole_axes = body.sole_axes  # None: the foot body's axes (W)
        self._foot_rot = body.foot_rotation  # None: the identity (W)
        self._facing = body.facing  # None: facing -x (W)
        # each leg's dofs (qvel index) and torque index (controller order), hip to ankle
        self._leg_dofs, self._leg_tau, self._leg_qpos = [], [], []
        for leg in body.leg_joints:
            js = [names.index(n) for n in leg]
            self._leg_tau.append(np.array(js))
            self._leg_dofs.append(np.array([m.jnt_dofadr[m.joint(names[i]).id] for i in js]))
            self._leg_qpos.append(np.array([m.jnt_qposadr[m.joint(names[i]).id] for i in js]))
        self._gravity = float(-m.opt.gravity[2])
        self._mass = float(np.sum(m.body_mass))
        # each leg's mass: the bodies its joints move (SwingPhase._inertia_friction)
        self._leg_mass = [
            float(sum(m.body_mass[b] for b in {int(m.jnt_bodyid[m.joint(j).id]) for j in leg}))
            for leg in body.leg_joints
        ]
        self._ankle_reach = self._ankle_reaches() if self.stepping.ankle_limited_polygon else None
        self.base_target: Target = config.target
        self.gains: Gains = config.gains
        self._gains_by_mode = {
            lateral: Gains(
                kp_com=(0.0, 0.0, self.gains.kp_com[2]),
                kv_com=(0.0, 0.0, self.gains.kv_com[2]),
                kp_rot=tuple(k * x for x in self.gains.kp_rot),
                kv_rot=tuple(math.sqrt(k) * x for x in self.gains.kv_rot),
            )
            for lateral, k in (
                (False, self.stepping.swing_rot_gain_scale),
                (True, self.stepping.lateral_rot_gain_scale),
            )
        }
        self._swing_gains = self._gains_by_mode[False]
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        s = self.stepping
        self.trigger = self._new_trigger()
        self._T, self._offset, self._limits = s.swing_time_s, s.offset_m, s.limits
        self.phase = "double"
        self.target = self.base_target
        self.steps: list[dict] = []
        self.swing: int | None = None  # index of the swinging foot
        self._mid0: np.ndarray | None = None  # the feet's midpoint at the first call
        self._ankle_z0: float | None = None  # the ankles' height above the floor then (feet flat)
        self._t_start = 0.0
        self._p0: np.ndarray | None = None
        self._landing: np.ndarray | None = None
        self._stance0 = np.zeros(2)  # the stance sole centre when the step started
        self._last_td = -1e9
        self.last_capture_point: np.ndarray | None = None
        self._t_prev = -math.inf
        self._xi_rate = np.zeros(2)  # low-passed rate of the capture point [m/s]
        self._settled = False  # after a step, at rest: the settling controller
        self.arm_time_s = -math.inf  # no step before [s] (the lean release arms it when sensed)
        self._dwell_since: float | None = None  # since when xi is near the edge (the slow trigger)
        self._cross = False  # the step swings the foot across the stance foot
        self._cross_ahead: float | None = None  # its end of the stance foot, once decided
        self._swing0 = np.zeros(2)  # the swing sole's centre when the step started
        self._swing_el = 0.0  # time into the swing [s] (swing_drop_ramp)
        self._stance_start = np.zeros(2)  # foot 1's sole centre from foot 0's at the start (facing)
        self._closing: int | None = None  # the foot of the closing step (shift and swing)
        self._closed = False  # a closing step was started (one per run)
        self._close_pending = False  # settled after a step: the closing check waits for rest
        self._shift_t = 0.0  # when the closing step's shift began
        self._shift_from = self._shift_to = np.zeros(2)  # the set point's path in the shift
        self._uncross = False  # the closing step uncrosses the feet
        self._knee_drop: float | None = None  # the deepest drop the knees carry (first call)

    @property
    def recovery_steps(self) -> int:
        """The steps taken but the closing one (those ``max_steps`` counts)."""
        return sum(1 for st in self.steps if not st.get("closing"))

    def _new_trigger(self) -> cp.CaptureTrigger:
        s = self.stepping
        return cp.CaptureTrigger(s.margin_m, s.rearm_margin_m, s.hold, s.lateral_margin_m, s.trigger_rate_m_s)

    @property
    def holding_controller(self):
        """The workspace controller of double support before the first step."""
        return self._ctrl_before

    @property
    def set_point_com(self) -> np.ndarray:
        """The central-body COM set point now (moved with the feet after each step) [m]."""
        return np.array(self.target.com)

    # ------------------------------------------------------------------ kinematics
    def _sole_pose(self, i: int) -> tuple[np.ndarray, float]:
        return sole_pose(self.body, self.data, i)

    def _ankle_reaches(self) -> list[tuple[int, float]]:
        """Per leg: (5th hinge's id, reach [m]) (:func:`~biped.control.stepping_body.ankle_reaches`)."""
        if self.limits is None or self.limits.lower is None or self.limits.upper is None:
            raise ScenarioError(
                "ankle_limited_polygon needs torque limits (torque_limits = 'model' or 'human')"
            )
        return ankle_reaches(self.body, self.limits, self.joint_names)

    def _sole_rect(self, i: int, cut: bool = True, share: float = 1.0):
        """Foot ``i``'s sole as (centre_xy, yaw, half_length, half_width); with
        ``ankle_limited_polygon`` (and ``cut``) cut along its length to the CoPs its ankle's
        limit holds carrying the share ``share`` of the weight: within ``r / share`` of the 5th
        hinge's axis (across it the sole's own width: measured, cutting it too made T1's
        diagonal steps start early and fail)."""
        c, yaw = self._sole_pose(i)
        hl, hw = self._sole[i][1], self._sole[i][2]
        if self._ankle_reach is None or not cut:
            return c[:2], yaw, hl, hw
        ax, rx = self._ankle_axis(i, c, yaw)
        rx = rx / share if share > 1e-12 else math.inf
        x0, x1 = max(-hl, ax - rx), min(hl, ax + rx)
        u = np.array([math.cos(yaw), math.sin(yaw)])
        # at least 1 mm each way (an axis off the sole: a thin strip at its nearest edge)
        return c[:2] + 0.5 * (x0 + x1) * u, yaw, max(0.5 * (x1 - x0), 1e-3), hw

    def _ankle_axis(self, i: int, c, yaw: float) -> tuple[float, float]:
        """(where foot ``i``'s 5th hinge's axis crosses its sole's length [m, from the sole
        centre ``c``], the reach ``r`` its limit holds with the whole weight [m])."""
        assert self._ankle_reach is not None  # ankle_limited_polygon
        j5, rx = self._ankle_reach[i]
        return ankle_axis_along_sole(self.data, j5, c, yaw), rx

    def _polygon(self, feet, cut: bool = True) -> np.ndarray:
        idx = [i for i in (0, 1) if feet[i] or self._sole_pose(i)[0][2] < 0.02]
        # a foot counts while it touches or its sole is within 2 cm of the floor
        if not idx:
            idx = [0, 1]
        if self._ankle_reach is not None and cut and len(idx) == 2:
            return self._shared_polygon()
        return cp.support_polygon([self._sole_rect(i, cut) for i in idx])

    def _shared_polygon(self) -> np.ndarray:
        """Both feet down, ``ankle_limited_polygon``: the total CoPs the soles hold when each
        ankle's limit bounds its own CoP along its sole and the weight is shared in any way, a
        share w on the left foot, 1 - w on the right: the hull over w of ``w A(w) + (1 - w)
        B(1 - w)``, each sole cut to its ankle's reach over its share (:meth:`_sole_rect`). Each
        term's support function is piecewise linear in w, bending where a cut meets the sole's
        end (``w = r / (hl -/+ ax)``), so the hull over those shares and 0, 1 is the exact set
        (the linear program of the CoPs, tests/test_robot_stepping.py)."""
        ws = {0.0, 1.0}
        for i in (0, 1):
            c, yaw = self._sole_pose(i)
            ax, rx = self._ankle_axis(i, c, yaw)
            hl = self._sole[i][1]
            for end in (hl - ax, hl + ax):
                if end > 0 and 0.0 < rx / end < 1.0:
                    ws.add(rx / end if i == 0 else 1.0 - rx / end)
        pts = []
        for w in sorted(ws):
            a = cp.sole_corners(*self._sole_rect(0, True, w))
            b = cp.sole_corners(*self._sole_rect(1, True, 1.0 - w))
            pts.append((w * a[:, None, :] + (1.0 - w) * b[None, :, :]).reshape(-1, 2))
        return cp.convex_hull(np.vstack(pts))

    # ------------------------------------------------------------------ the call
    def __call__(self, t: float, qpos: np.ndarray, qvel: np.ndarray, feet) -> np.ndarray:
        m, d, s = self.model, self.data, self.stepping
        d.qpos[:] = qpos
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        mujoco.mj_subtreeVel(m, d)
        com = d.subtree_com[0].copy()
        vcom = d.subtree_linvel[0].copy()
        omega = cp.omega0(max(com[2], 0.05), self._gravity)  # the floor is z = 0
        xi = cp.capture_point(com[:2], vcom[:2], omega)
        if self.last_capture_point is not None and t > self._t_prev:
            raw = (xi - self.last_capture_point) / (t - self._t_prev)
            self._xi_rate += min(1.0, (t - self._t_prev) / RATE_TAU_S) * (raw - self._xi_rate)
        self._t_prev = t
        self.last_capture_point = xi
        if self._mid0 is None:
            self._mid0 = 0.5 * (self._sole_pose(0)[0] + self._sole_pose(1)[0])
            self._ankle_z0 = float(np.mean([d.xpos[a][2] for a in self._ankle]))
            self._stance_start = closing_step.facing_offset(self)
            self._knee_drop = leg_geometry.knee_carried_drop(self)
        left, right = bool(feet[0]), bool(feet[1])
        if (
            self.phase in ("double", "shift")
            and self.recovery_steps < s.max_steps
            and t - self._last_td >= s.refractory_s
            and t >= self.arm_time_s
        ):
            poly = self._polygon((left, right))
            fired = self.trigger.update(poly, xi, self._xi_rate)  # (in the closing shift, not the dwell)
            if fired or (self.phase == "double" and self._dwelt(t, poly, xi)):
                self._start_step(t, xi, (left, right))
        if self.phase == "shift":
            tau = closing_step.shift_call(self, t, qpos, qvel, com, xi, (left, right))
            if tau is not None:
                return tau
        if self.phase == "swing":
            return self._swing_call(t, qpos, qvel, xi, omega, (left, right))
        ctrl = self._ctrl_post if self.steps else self._ctrl_before
        if (
            s.settle_after_s is not None
            and self.steps
            and t - self._last_td >= s.settle_after_s
            and float(np.hypot(vcom[0], vcom[1])) < s.settle_speed_m_s
        ):
            self._close_pending |= not self._settled and s.closing_step and not self._closed
            self._settled = True
        # at rest after a step: the closing step, decided once (a period the compiled loop hands back)
        if self._close_pending and float(np.hypot(vcom[0], vcom[1])) < s.closing_speed_m_s:
            self._close_pending = False
            if closing_step.begin(self, t, com):
                return self.__call__(t, qpos, qvel, feet)  # the shift's first period
        if self._settled:
            ctrl = self._ctrl_settle
        if not self.steps and s.holding_sensed and self.config.distribution == "qp":
            flags = (left, right)  # before the first step: the feet-in-place QP exactly
        else:
            flags = self._flags(left, right)
        target = self._leg_capped(self._resting(self.target, vcom), (0, 1))
        tau = ctrl.torques(qpos, qvel, target=target, gains=self.gains, feet_in_contact=flags)
        if s.rest_damping_compensation and self._settled:
            # the hinges' passive damping the controller does not model, cancelled (before the clip)
            return self._out(tau, self._out_damping * np.asarray(qvel)[self._out_dof])
        return self._out(tau)

    def _resting(self, target: Target, vcom) -> Target:
        """After a step, with ``post_step_rest_drop_m``: ``target`` raised from the post-step
        crouch toward the resting drop as the COM's horizontal speed falls below
        ``settle_speed_m_s`` (linear in the speed; at rest the resting drop)."""
        s = self.stepping
        if s.post_step_rest_drop_m is None or not self.steps or self._closing is not None:
            return target
        k = 1.0 - min(1.0, float(np.hypot(vcom[0], vcom[1])) / s.settle_speed_m_s)
        rise = k * max(s.post_step_height_drop_m - s.post_step_rest_drop_m, 0.0)
        return replace(target, com=(target.com[0], target.com[1], target.com[2] + rise))

    def _leg_capped(self, target: Target, legs) -> Target:
        """``target`` no higher than the standing ``legs`` reach (:func:`leg_geometry.leg_capped`)."""
        return leg_geometry.leg_capped(self, target, legs)

    def _dwelt(self, t, poly, xi) -> bool:
        """The slow trigger (``dwell_margin_m``, ``dwell_s``): True once the capture point has
        stayed within ``dwell_margin_m`` of the support polygon's edge (or outside it) for
        ``dwell_s``: the feet hold it there only by a CoP at the edge, and the body creeps over."""
        s = self.stepping
        if s.dwell_s is None:
            return False
        ex, ey = cp.excess(poly, xi)
        if max(ex, ey) <= -s.dwell_margin_m:
            self._dwell_since = None
            return False
        if self._dwell_since is None:
            self._dwell_since = t
        if t - self._dwell_since >= s.dwell_s:
            self._dwell_since = None
            return True
        return False

    def _flags(self, left, right):
        # "sensed" support: the sensed feet. Otherwise (W's fixed support, also with "qp", where
        # make_policy passes the sensed feet) both feet, except a foot whose sole centre is over
        # 2 cm above the floor: the sensed feet made the goal push and the 18 m/s push from behind
        # fall; both feet always made the QP load feet in the air while the biped tumbled after its
        # last step, and MuJoCo diverged (docs/controller.md, "Stepping")
        if self.config.support == "sensed":
            return (left, right)
        if self.config.distribution != "qp":
            return None
        return tuple(bool(f) or self._sole_pose(k)[0][2] < AIRBORNE_M for k, f in enumerate((left, right)))

    def _out(self, tau, extra=None):
        out = np.asarray(tau)[self._order]
        if extra is not None:
            out = out + extra
        if self.limits is not None:
            out = clip_torques(out, self.limits)
        return out
