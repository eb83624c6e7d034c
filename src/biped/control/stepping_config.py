"""The parameters of the stepping recovery (:mod:`biped.control.stepping`): one frozen dataclass,
one set for every direction; :meth:`SteppingConfig.for_trigger` gives the set of a scenario's
``step_trigger``."""

from __future__ import annotations

from dataclasses import dataclass, field

from biped.control import capture as cp
from biped.errors import ScenarioError

__all__ = ["QP_MAX_BACK_M", "SteppingConfig"]

#: How far [m] behind the stance sole's centre a backward step of the ``"qp"`` set may land (0.40
#: before the knee-carried drop: with the hips no longer sinking the 0.45 m step made 20 m/s from
#: the front with human limits and faithful physics end at rest, docs/sweep.md).
QP_MAX_BACK_M = 0.45


@dataclass(frozen=True)
class SteppingConfig:
    """Parameters of the stepping recovery (SI units; not in W, chosen here, docs/controller.md).

    max_steps: most steps in a run. margin_m, rearm_margin_m, hold: the trigger
    (:class:`~biped.control.capture.CaptureTrigger`). swing_time_s: planned swing duration T.
    apex_m: swing-foot clearance at mid-swing. offset_m: how far beyond the predicted capture
    point the sole centre lands. descent_m_s: the ankle's downward speed after T until contact.
    kp_pos, kv_pos, kp_rot, kv_rot: the swing foot's task-space gains [1/s^2, 1/s].
    retarget_until: the landing point is recomputed every period until this fraction of
    swing_time_s, then frozen (a late change the foot cannot follow would only move the target).
    refractory_s: no new step within this time after a touchdown. limits: landing limits.
    swing_rot_gain_scale: W's orientation gains times this (kv by its square root) while a foot
    swings: the stance leg must stop the trunk's pitch from the push before the foot can reach.
    qp_moment_weight: with distribution "qp", the QP's moment-row weight used by the stepping
    policy (None: the scenario's qp_moment_weight): 10 keeps the trunk upright in single support
    and after touchdown, where force-first (1) lets it pitch over.
    post_step_kp_xy, post_step_kv_xy: after a step, the horizontal COM gains of W's Alg. 4
    [1/s^2, 1/s]: W's (50, 7.07) ask a decelerating COM for ~10 m/s^2, five times what the LIPM
    over the new feet can give (omega_0^2 times the COM-to-toe distance); the QP then gives up
    the trunk's orientation and the trunk pitches over. kv ~ omega_0 asks for what it can give.
    reach_m: the desired ankle is kept within this distance of the hip joint (leg 0.826 m).
    swing_torque_max_n_m: bound of the swing leg's task-space torques.
    swing_height_drop_m, swing_tilt_deg: while a foot swings the stance leg holds the body this
    much lower than the set point (reach) and upright but for this tilt about -y (the set point's
    forward tilt moves the hips back, away from a forward step).
    knee_carried_drop: with torque limits (and no ``span_leg_m``), both drops above no deeper
        than each stance knee's extension limit carries the whole weight with the CoP at its
        sole's end farthest from the knee (the heel in W's crouch), the knee found again for the
        lowered hips from the standing pose (:func:`biped.control.leg_geometry.knee_carried_drop`,
        once at the first call): lowering the hips bends the knees further and moves them ahead
        of the feet, so the knee that must hold the body over one foot needs more torque. W's
        crouch with human limits: 236 N m needed standing against the knee's 234 N m, so the
        drops are 0 (with 8 cm, the stance knee at its limit for most of a backward step's swing,
        the body sank 13 cm per step and fell after three at 20 m/s from the front).
    post_step_rest_drop_m: if set, the set point after a step is post_step_height_drop_m below
    the standing one only while the COM moves at settle_speed_m_s or faster, and rises linearly
    with the COM's horizontal speed to this drop at rest (robots: the crouch keeps the front
    leg off its straight knee while the trunk pitches; at rest the standing height's offset).
    span_leg_m, stand_hip_m: if set (``step_reach = "leg"``: the starting pose's hip-to-ankle length
    and the hips' height above the ankles), the two height drops above follow the step instead of
    being fixed: the hips go as low as both legs at ``span_leg_m`` need to span the step (the
    landing target's, then the feet's, distance from the stance sole, L): ``stand_hip_m -
    sqrt(span_leg_m^2 - (L / 2)^2)``, between 0 and the fixed drop. From upright stance the
    legs then keep the stance's knee (not straighter: W's controller has no straight-knee
    handling) where the fixed 0.08 m bent the knees of W's crouch past 95 deg.
    lateral_margin_m: the trigger's extra margin along y (3 cm; "qp" trigger 0: 3 cm stepped at
    sideways pushes the feet-in-place QP holds, docs/controller.md).
    holding_sensed: before the first step the QP takes the sensed feet, as the QP alone does (W's
    fixed feet made it a weaker feet-in-place controller that fell at pushes the QP alone holds).
    qp_leg_weight: the stepping QP's share of the legs' weight (0: massless legs, as tuned;
    before the first step the scenario's own). trigger_rate_m_s: if set, step only while xi also
    moves away from the polygon faster than this (changed no envelope cell; off).
    settle_after_s, settle_speed_m_s: if set, once this long after a touchdown the COM moves
    slower than settle_speed_m_s, the double support takes the scenario's QP moment weight (100)
    instead of qp_moment_weight until the next step: weight 10 left the trunk 2.5-5 deg off its
    set point at rest, outside the strict rule's 2 deg.
    lateral_offset_m, lateral_swing_time_s, lateral_limits: a *sideways step* (xi further out of
    the polygon's y-extent than out of its x-extent when the step starts) lands this far beyond
    the predicted capture point, swings this fast, within these limits (the LIPM capture point
    of the whole-body COM ignores the trunk's roll from a hit 1.2 m up: a 3 cm offset and the
    0.22 m width limit left the foot short and the biped fell over it). Sideways the swing foot is
    always the push-side one (the other, unloaded as the body rolls, could only step inward: no
    crossover).
    floor_friction: the stepping QP's friction pyramid on the floor's axes, not the sole's
    (``QPWeights.floor_friction``; before the first step the scenario's QP as it is).
    swing_friction_scale: if set, single support uses a stepping QP whose pyramid is
    ``friction * swing_friction_scale`` (a margin for what the massless-leg cone does not see:
    the driven swing leg's inertia; with 0.55, MuJoCo's contact forces on a forward step's
    stance foot reached mu times the normal force, docs/sweep.md).
    swing_inertia_share, swing_friction_min_scale: if swing_inertia_share is set, a forward or
    backward step's single-support QP plans, each period, its friction less what the swing leg's
    planned horizontal inertial force takes of the weight's, ``share * m_leg * |a_xy| / (m g)``, at
    least ``swing_friction_min_scale * friction`` (measured, not adopted: docs/sweep.md).
    stance_contact_model: single support's QP holds the stance foot's normal-force and friction
    rows on the floor's wrench predicted from the whole biped's dynamics (the swing leg's driven
    reaction, the legs' inertia and weight; :mod:`biped.control.stance_dynamics`), not on the
    massless-leg wrench it plans (needs qp_leg_weight 0). stance_contact_rows: which of the stance
    foot's cone rows hold the prediction: 1 the normal-force and friction rows, 2 also the yaw
    rows, 3 also the CoP rows (2 and 3 measured, not better: docs/sweep.md; 2 on set C' holds a
    forward step's stance foot's yaw, 11 -> 1.5 deg, but lowers the human-limit front and the 1.55 m
    subject's 135 and 180 deg limits: docs/sweep.md, "The stance foot's yaw").
    lateral_stance_contact_model: False: a sideways step's (and the closing step's) single support
    without it (None: as stance_contact_model).
    lateral_swing_friction_scale: if set, a *sideways step*'s (and the closing step's) single
    support uses this scale instead (measured, not adopted: docs/sweep.md, "The stance foot's
    friction in single support").
    ankle_limited_polygon: the trigger's support polygon (and the dwell's and the step's
        sideways test) is the set of total centres of pressure the soles hold when each ankle's
        torque limit bounds its own along its sole: within ``|tau_max| / (w m g)`` of the leg's
        5th hinge's axis for a foot carrying the share w of the weight (one foot down: w = 1;
        both: any split); needs torque limits (off: W's geometric soles).
    swing_reaction: add the driven swing leg's reaction (:func:`biped.control.swing.swing_reaction_wrench`)
    of its torques clipped to the limits to the stance leg's desired wrench (off: on W's biped
    it made the stance foot slide further, measured; robots: on).
    lateral_swing_reaction: False: a sideways step's (and the closing step's) single support
    without the swing reaction (None: as swing_reaction).
    dwell_margin_m, dwell_s: if dwell_s is set, a step also starts once the capture point has
    stayed within dwell_margin_m of the support polygon's edge for dwell_s (the feet hold it
    there only with the CoP at the edge while the body creeps over it).
    side_margin_m: the landing sole centre lies at least this far beyond the predicted capture
    point sideways, on the swing foot's side (:func:`biped.control.capture.step_target`), so
    that a backward or forward step also catches the sideways fall over the stance foot.
    crossover, crossover_clear_m: a later sideways step whose capture point lies beyond the
    stance sole's centre on the side away from the swing foot crosses over: it lands on the
    stance foot's far side (lateral limits mirrored), at least crossover_clear_m ahead of or
    behind the stance sole's centre (the soles clear), its path along x first, then across.
    crossover_side: which of the stance foot's ends a crossover passes: "retarget" (the side of
    the landing target, decided again every period it is recomputed), "start" (decided when the
    step starts, then kept), "near" (decided when the step starts: the side of the target if it
    lies beyond crossover_clear_m, else the side on which the swing foot starts, the shorter path).
    crossover_swing_time_s: a crossover's planned swing time (None: lateral_swing_time_s).
    crossover_modelled: a crossover's single support takes the forward and backward steps'
    stance settings (``stance_contact_model``, ``swing_reaction``, ``swing_drop_ramp``), not the
    sideways steps' ``lateral_*`` ones (its friction stays ``lateral_swing_friction_scale``'s;
    measured, not adopted: docs/sweep.md, "The crossover's path").
    crossover_path: when a crossover's foot moves along x and across: "fixed" (x in the swing's
    first 60 %, across in its last 60 %) or "timed" (the windows from the step's geometry: across
    from the start as long as the soles' side band is reached only once the move along x is done,
    :func:`biped.control.crossover_path.windows`, decided at the step's first period).
    crossover_max_acc_m_s2: with crossover_path "timed", a crossover's swing time is lengthened
        (from lateral_swing_time_s or crossover_swing_time_s, decided at the step's first period)
        until neither move's planned minimum-jerk peak acceleration exceeds this
        (:func:`biped.control.crossover_path.swing_time`); None: the swing time as set (a 0.57 m
        move behind the stance foot in 0.11 s planned 183 m/s^2 and flung the swing foot 23 cm
        up: measured, not adopted, docs/sweep.md "The crossover's path").
    reach_on_floor: a swing point beyond reach_m from the swing hip is pulled in horizontally at
    its own height (the foot still comes down to the floor at the farthest point it reaches there)
    instead of toward the hip (which lifts it: the foot hangs above the floor and never lands).
    swing_drop_ramp: the single support's height drop below the set point (swing_height_drop_m,
    or what the span needs) reached along a minimum-jerk path over the planned swing time, its
    velocity and acceleration fed forward, instead of at once (a set point 8 cm lower at the
    swing's start asks for ~16 m/s^2 down with W's height gain: the plan unloads the stance foot).
    lateral_swing_drop_ramp: a sideways step's (None: as swing_drop_ramp).
    rest_damping_compensation: once settled after a step (``settle_after_s``), each joint's torque
    adds the model's passive hinge damping times the joint's rate (the MJCF's ``damping``, 1.0 N m
    s/rad a hinge), which W's controller does not model: through the closed chain of two planted
    feet it damps the trunk's yaw by ~12 N m s/rad (a backward-stepped 1.55 m subject), 5x the yaw
    PD's own ``P_1 k_v`` (2.4), and the trunk turned back with a ~1.7 s time constant. Before
    settling the damping stays (cancelled there too, the subject fell more: docs/sweep.md).
    rest_damping_joints: with rest_damping_compensation, only the joints whose names end with one
    of these (e.g. ``("hip_rotation",)``: the hinges that turn most with the trunk's yaw); None:
    every joint.
    stance_knee_min_deg, stance_knee_kp, stance_knee_kv: if stance_knee_min_deg is set (``step_reach
    = "leg"``: 8 deg, ``biped.sim.policies.STANCE_KNEE_MIN_DEG``), in single support the stance knee gets a one-sided
    spring-damper (kp [N m/rad], kv [N m s/rad] on its extending rate) added to W's torque once
    it is straighter than that: W's controller has no handling of the straight knee's singularity,
    and from upright stance a large forward lean straightened the stance knee past 0 within 0.25 s
    of the swing's start, the singular leg throwing the stance foot off the floor before the
    swing foot landed (docs/validate.md, "Why the ideal stops").
    airborne_stance: in single support, a stance sole over ``AIRBORNE_M`` (10 cm) above the
    floor is left out of the QP (the biped tumbles; no wrench is distributed), as a foot in the
    air is in double support.
    post_step_friction_scale: if set, the double support after a step (until the next step or
    the settling switch) uses a stepping QP whose friction pyramid is ``friction *
    post_step_friction_scale`` (``step_reach = "leg"`` with the feedback stepper: 0.35, the
    scale the sweeps measured for a forward or backward step's stance foot,
    ``biped.sim.policies.POST_STEP_FRICTION_SCALE``): the rear foot lands on its toe edge (rolled
    5-8 deg by the push-off) with the QP's minimum normal force, and the full pyramid let the QP
    hold the trunk's yaw by opposing lateral forces on the feet at that foot's friction limit;
    its real normal force flickered, it slid 0.4 m back and out and the ideal preset fell at an
    11 deg lean release (docs/validate.md, "The rear foot's friction after the step").
    closing_step, closing_speed_m_s, closing_band_m, closing_inside_m, closing_com_inside_m,
    closing_swing_time_s, closing_shift_max_s: once at rest after the last recovery step (after
    the settling switch, the first period the COM moves slower than closing_speed_m_s), if the
    stance is not comfortable (crossed, or its width or stagger more than closing_band_m from the
    starting stance's), shift the COM over one foot until the capture point lies closing_inside_m
    and the COM closing_com_inside_m (None: closing_inside_m) inside that sole (the set point's
    critically damped approach at closing_shift_rate_1_s, given up after closing_shift_max_s),
    then swing the other foot in closing_swing_time_s beside it at the starting stance
    (:mod:`biped.control.closing_step`).
    The ``"qp"`` set turns on floor_friction, sets swing_friction_scale 0.55 (one scale for
    every step: 0.35 on forward and backward steps, lateral_swing_friction_scale 0.55, cut the
    stance slip at 135 deg from 21.8 to 1.4 cm but lowered the front's limit with human torque
    limits and the 1.55 m subject's from behind, docs/sweep.md) and
    lateral_rot_gain_scale 1 (docs/controller.md, "Stance-foot slip"), dwell_s 0.5 s,
    side_margin_m 0.04, airborne_stance, crossover and knee_carried_drop; closing_step stays off (it lowered every
    direction's envelope, docs/sweep.md).
    """

    max_steps: int = 3
    margin_m: float = 0.0
    rearm_margin_m: float = 0.02
    hold: int = 3
    swing_time_s: float = 0.25
    apex_m: float = 0.05
    offset_m: float = 0.03
    descent_m_s: float = 0.3
    kp_pos: float = 400.0
    kv_pos: float = 40.0
    kp_rot: float = 400.0
    kv_rot: float = 40.0
    refractory_s: float = 0.15
    retarget_until: float = 1.0
    reach_m: float = 0.78
    swing_rot_gain_scale: float = 4.0
    qp_moment_weight: float | None = 10.0
    qp_leg_weight: float = 0.0
    holding_sensed: bool = False
    settle_after_s: float | None = None
    settle_speed_m_s: float = 0.1
    trigger_rate_m_s: float | None = None
    post_step_kp_xy: float = 10.0
    post_step_kv_xy: float = 3.5
    ankle_kp: float = 80.0
    ankle_kv: float = 0.5
    swing_torque_max_n_m: float = 1000.0
    swing_height_drop_m: float = 0.08
    post_step_height_drop_m: float = 0.08
    post_step_rest_drop_m: float | None = None
    knee_carried_drop: bool = False
    swing_tilt_deg: float = 0.0
    span_leg_m: float | None = None
    stand_hip_m: float | None = None
    swing_reaction: bool = False
    lateral_swing_reaction: bool | None = None
    ankle_limited_polygon: bool = False
    floor_friction: bool = False
    swing_friction_scale: float | None = None
    lateral_swing_friction_scale: float | None = None
    swing_inertia_share: float | None = None
    swing_friction_min_scale: float = 0.2
    stance_contact_model: bool = False
    stance_contact_rows: int = 1
    lateral_stance_contact_model: bool | None = None
    dwell_margin_m: float = 0.02
    dwell_s: float | None = None
    side_margin_m: float = 0.0
    airborne_stance: bool = False
    stance_knee_min_deg: float | None = None
    stance_knee_kp: float = 1000.0
    stance_knee_kv: float = 20.0
    crossover: bool = False
    crossover_clear_m: float = 0.24
    crossover_side: str = "retarget"
    crossover_swing_time_s: float | None = None
    crossover_modelled: bool = False
    crossover_path: str = "fixed"
    crossover_max_acc_m_s2: float | None = None
    reach_on_floor: bool = False
    swing_drop_ramp: bool = False
    lateral_swing_drop_ramp: bool | None = None
    rest_damping_compensation: bool = False
    rest_damping_joints: tuple | None = None
    post_step_friction_scale: float | None = None
    closing_step: bool = False
    closing_band_m: float = 0.05
    closing_inside_m: float = 0.015
    closing_com_inside_m: float | None = None
    closing_swing_time_s: float = 0.6
    closing_shift_max_s: float = 2.5
    closing_shift_rate_1_s: float = 3.0
    closing_speed_m_s: float = 0.05
    limits: cp.StepLimits = field(default_factory=cp.StepLimits)
    lateral_margin_m: float = 0.03
    lateral_offset_m: float = 0.15
    lateral_swing_time_s: float = 0.2
    lateral_rot_gain_scale: float = 4.0
    lateral_limits: cp.StepLimits = field(default_factory=lambda: cp.StepLimits(max_step=0.6, max_width=0.6))

    @classmethod
    def for_trigger(cls, trigger: str, **kw) -> SteppingConfig:
        """The parameters of the scenario's ``step_trigger``: "capture" (these defaults) or "qp"
        (the QP alone until its feet cannot hold: sensed feet before the first step, no
        sideways margin, backward steps up to ``QP_MAX_BACK_M``)."""
        if trigger == "qp":
            kw = {
                "holding_sensed": True,
                "lateral_margin_m": 0.0,
                "limits": cp.StepLimits(max_back=QP_MAX_BACK_M),
                "settle_after_s": 0.3,
                "floor_friction": True,
                "swing_friction_scale": 0.55,
                "lateral_rot_gain_scale": 1.0,
                "dwell_s": 0.5,
                "side_margin_m": 0.04,
                "airborne_stance": True,
                "crossover": True,
                "knee_carried_drop": True,
                **kw,
            }
        elif trigger != "capture":
            raise ScenarioError(f"step_trigger must be 'capture' or 'qp'; got {trigger!r}")
        return cls(**kw)

    def __post_init__(self):
        if not (isinstance(self.max_steps, int) and self.max_steps >= 0):
            raise ScenarioError(f"max_steps must be an integer >= 0; got {self.max_steps!r}")
        if self.stance_contact_model and self.qp_leg_weight != 0:
            raise ScenarioError(
                "stance_contact_model predicts the legs' weight itself: it needs qp_leg_weight = 0; "
                f"got {self.qp_leg_weight!r}"
            )
        if self.crossover_side not in ("retarget", "start", "near"):
            raise ScenarioError(
                f"crossover_side must be 'retarget', 'start' or 'near'; got {self.crossover_side!r}"
            )
        if self.crossover_path not in ("fixed", "timed"):
            raise ScenarioError(f"crossover_path must be 'fixed' or 'timed'; got {self.crossover_path!r}")
        if self.crossover_max_acc_m_s2 is not None and (
            self.crossover_path != "timed" or not self.crossover_max_acc_m_s2 > 0
        ):
            raise ScenarioError(
                "crossover_max_acc_m_s2 must be a positive acceleration [m/s^2] with crossover_path "
                f"'timed', or None; got {self.crossover_max_acc_m_s2!r} with {self.crossover_path!r}"
            )
        if self.stance_contact_rows not in (1, 2, 3):
            raise ScenarioError(
                "stance_contact_rows must be 1 (normal force and friction), 2 (and yaw) or 3 (and CoP); "
                f"got {self.stance_contact_rows!r}"
            )
        if not self.swing_time_s > 0:
            raise ScenarioError(f"swing_time_s must be > 0 s; got {self.swing_time_s!r}")
