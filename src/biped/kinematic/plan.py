"""A gait's :class:`Plan` (segments on a terrain, evaluated to joint angles by the legs' IK) and
the :class:`Motion` it samples (see :mod:`biped.kinematic.gaits` for how plans are built)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from biped.errors import ReachError, ScenarioError
from biped.kinematic.figure import JOINT_NAMES, FigureDims, FigurePoses, landmarks, part_poses
from biped.kinematic.ik import leg_ik
from biped.kinematic.segments import DEG, SIDES, _hip_y, _lerp
from biped.kinematic.terrain import FLAT, Terrain

if TYPE_CHECKING:
    from biped.kinematic.gaits import GaitParams

_J = {n: i for i, n in enumerate(JOINT_NAMES)}


# ------------------------------------------------------------------------------------------
# plans and motions
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Plan:
    """A gait as a sequence of segments; evaluate it at any times with :meth:`evaluate`.

    Attributes:
        dims, params: the figure and the gait parameters.
        segments: the segments in time order (private types).
        terrain: the ground.
        markers: ``({"time_s", "label"}, ...)`` gait changes and events.
        distance: forward distance travelled by the feet [m]; climbed: height gained on stairs
            [m] (a jump down does not subtract from it).
    """

    dims: FigureDims
    params: GaitParams
    segments: tuple
    terrain: Terrain = FLAT
    markers: tuple = ()
    distance: float = 0.0
    climbed: float = 0.0

    @property
    def starts(self) -> np.ndarray:
        d = np.array([seg.duration for seg in self.segments])
        return np.concatenate([[0.0], np.cumsum(d)])

    @property
    def duration(self) -> float:
        return float(sum(seg.duration for seg in self.segments))

    def evaluate(self, times: ArrayLike) -> Motion:
        """The figure's pose at ``times`` (T,) [s]: targets of the segments, then leg IK
        (eq. 4.12-4.19) and B's arm rule. Raises :class:`ReachError` if a foot is out of reach."""
        times = np.asarray(times, dtype=float)
        starts = self.starts
        if times.ndim != 1 or np.any(times < -1e-12) or np.any(times > starts[-1] + 1e-9):
            raise ScenarioError(f"times must be a 1-D array within [0, {starts[-1]:.6g}] s")
        idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(self.segments) - 1)
        T = times.size
        d, p = self.dims, self.params
        pelvis, pitch = np.empty((T, 3)), np.empty(T)
        roll, lean, arm_w = np.empty(T), np.empty(T), np.empty(T)
        stance = np.empty((T, 2), bool)
        swing_s = np.empty((T, 2))
        leg_xy = {sd: np.empty((T, 2)) for sd in SIDES}
        leg_phi = {sd: np.empty(T) for sd in SIDES}
        labels = np.empty(T, dtype=object)
        for k, seg in enumerate(self.segments):
            m = idx == k
            if not np.any(m):
                continue
            s = np.clip((times[m] - starts[k]) / seg.duration, 0.0, 1.0)
            f = seg.evaluate(d, p, s)
            pelvis[m], pitch[m], roll[m], lean[m], arm_w[m] = f.pelvis, f.pitch, f.roll, f.lean, f.arm_w
            labels[m] = seg.label
            cp, sp = np.cos(f.pitch), np.sin(f.pitch)
            for j, sd in enumerate(SIDES):
                stance[m, j] = f.stance[sd]
                swing_s[m, j] = f.swing_s[sd]
                mode, val = f.feet[sd]
                if mode == "world":
                    # ankle relative to the hip, in the pelvis frame (pelvis pitched about +y;
                    # the lateral hip offset is along the pitch axis, so it does not turn)
                    hip = f.pelvis + np.array([0.0, _hip_y(d, sd), 0.0])
                    r = val - hip
                    rx = cp * r[:, 0] - sp * r[:, 2]
                    rz = sp * r[:, 0] + cp * r[:, 2]
                    leg_xy[sd][m] = np.stack([-rz, rx], 1)
                    leg_phi[sd][m] = f.pitch  # a flat foot seen from the pitched pelvis
                else:
                    leg_xy[sd][m] = np.stack([val, np.zeros(s.size)], 1)
                    leg_phi[sd][m] = 0.0
        angles = np.zeros((T, len(JOINT_NAMES)))
        angles[:, _J["torso_roll"]] = roll
        angles[:, _J["torso_pitch"]] = lean
        for sd in SIDES:
            try:
                ik = leg_ik(leg_xy[sd][:, 0], leg_xy[sd][:, 1], leg_phi[sd], d.thigh, d.shank, knee=p.knee)
            except ReachError as exc:
                raise ReachError(f"{sd} leg: {exc}") from None
            angles[:, _J[f"{sd}_hip_flexion"]] = ik.theta1
            angles[:, _J[f"{sd}_knee"]] = ik.theta2
            angles[:, _J[f"{sd}_ankle_dorsiflexion"]] = ik.theta3
        for sd, other in (("left", "right"), ("right", "left")):
            th = angles[:, _J[f"{other}_hip_flexion"]]
            sh = p.shoulder_gain * th + p.shoulder_offset * DEG
            el = p.elbow_gain * th + p.elbow_offset * DEG
            angles[:, _J[f"{sd}_shoulder_flexion"]] = _lerp(sh, p.jump_shoulder * DEG, arm_w)
            angles[:, _J[f"{sd}_elbow_flexion"]] = _lerp(el, p.jump_elbow * DEG, arm_w)
        c, s_ = np.cos(pitch), np.sin(pitch)
        rot = np.zeros((T, 3, 3))
        rot[:, 0, 0], rot[:, 0, 2], rot[:, 1, 1], rot[:, 2, 0], rot[:, 2, 2] = c, s_, 1.0, -s_, c
        return Motion(self, times, pelvis, rot, pitch, angles, stance, swing_s, labels)

    def sample(self, rate: float = 200.0) -> Motion:
        """:meth:`evaluate` on a uniform grid of ``rate`` Hz covering the whole plan."""
        if not rate > 0:
            raise ScenarioError(f"rate must be > 0 Hz, got {rate!r}")
        n = math.floor(self.duration * rate + 1e-9) + 1
        times = np.arange(n) / rate
        if times[-1] < self.duration - 1e-12:
            times = np.append(times, self.duration)
        return self.evaluate(times)


@dataclass(frozen=True)
class Motion:
    """The figure's motion on a time grid.

    Attributes:
        plan: the plan it was evaluated from.
        times: (T,) s.
        pelvis_pos: (T, 3) mid-hip point in the world [m].
        pelvis_rot: (T, 3, 3) pelvis orientation (world <- pelvis).
        pelvis_pitch: (T,) its pitch about +y [rad] (nonzero only in the somersault).
        angles: (T, 12) joint angles [rad], columns :data:`~biped.kinematic.figure.JOINT_NAMES`.
        stance: (T, 2) bool, [left, right] foot bears weight (planted).
        swing_phase: (T, 2) phase in [0, 1] of a swinging / flying foot, nan otherwise.
        labels: (T,) segment label at each time.
    """

    plan: Plan
    times: np.ndarray
    pelvis_pos: np.ndarray
    pelvis_rot: np.ndarray
    pelvis_pitch: np.ndarray
    angles: np.ndarray
    stance: np.ndarray
    swing_phase: np.ndarray
    labels: np.ndarray

    @property
    def dims(self) -> FigureDims:
        return self.plan.dims

    def poses(self) -> FigurePoses:
        """World frames of the 15 parts (:func:`~biped.kinematic.figure.part_poses`)."""
        return part_poses(self.dims, self.pelvis_pos, self.pelvis_rot, self.angles)

    def landmarks(self) -> dict:
        """Heel, toe, ankle and hip points in the world, name -> (T, 3) [m]."""
        return landmarks(self.dims, self.poses())
