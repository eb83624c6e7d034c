"""The common interface of the perturbation paradigms (scenario key ``perturbation``).

A paradigm is a subclass of :class:`Perturbation` in a module of its own, registered in
:data:`biped.sim.perturbations.PARADIGMS`. The scene, the initial state and the push loop call it
at four places, and nowhere else:

1. :meth:`Perturbation.edit_spec` while :func:`biped.sim.scene.scene_spec` builds the scene
   (a platform body, the tether's anchor; every paradigm but the block parks the block);
2. :meth:`Perturbation.initial_state` at the end of :func:`biped.sim.scene.initial_state`
   (the lean of ``release``);
3. :meth:`Perturbation.driver` once per run, after MuJoCo's data holds the initial state and the
   policy exists: a :class:`Driver` or None;
4. :meth:`Driver.apply` before the physics steps of each of the rows :attr:`Driver.rows` (a sorted
   array of control-period indices): it writes MuJoCo's inputs (``xfrc_applied``, ``ctrl`` of the
   paradigm's own actuators, the controller's target) that hold until the next such row. Both the
   Python loop and the compiled loop of :func:`biped.sim.push.run_closed_loop` call it at the same
   rows (the compiled loop stops before each), so the two loops stay bit for bit the same.
   A driver whose inputs are data (:class:`biped.sim.schedule.Schedule`, :attr:`Driver.schedule`:
   fixed ctrl values a row, the set point riding with a joint) has the compiled loop apply them
   itself; it then stops only at the schedule's ``python_rows``.

Every paradigm but the block starts from quiet stance: the soles on the floor (W's pose starts
them 5 mm up) and, with W's workspace controller, its set point moved to the starting pose at row
0 (the sweep's "hold" task), so the response measured is the perturbation's alone, not W's rise
from the crouch to the scenario's set point (``target_com_m``, ``target_tilt_deg`` are then unused).

A paradigm with no rows costs the loop nothing; W's block has none, so its runs are unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import mujoco
import numpy as np

if TYPE_CHECKING:
    from biped.sim.scenario import Scenario
    from biped.sim.scene import Scene
    from biped.sim.schedule import Schedule

#: Where the block waits when another paradigm runs: off the floor's far corner, not colliding,
#: its weight compensated (gravcomp), so it costs no contacts and never moves; not drawn.
PARKED_BLOCK_M = (9.0, 9.0, 0.5)


class Driver:
    """What a paradigm does during one run: at each row of :attr:`rows` (sorted control-period
    indices), :meth:`apply` is called before that row's physics steps."""

    rows: np.ndarray = np.zeros(0, dtype=np.int64)
    #: its inputs on a span of rows as data, which the compiled loop applies itself (None: none)
    schedule: Schedule | None = None
    #: the set point the run ends at, (COM (3,), quaternion (4,)), when the paradigm moves it
    #: (the recovery is judged against it); None: the scenario's
    final_target: tuple | None = None

    def apply(self, k: int, t: float, data: mujoco.MjData) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def finish(self, data: mujoco.MjData) -> dict:
        """What the run measured of the perturbation itself (for ``summary.json``)."""
        return {}


@dataclass(frozen=True)
class Size:
    """A paradigm's size for comparisons: its natural ``magnitude`` (in ``unit``), the
    ``direction_deg`` it pushes the body (from +x toward +y, world frame, the sweep's convention),
    the horizontal impulse it delivers [N s] and the whole-body COM velocity change it causes
    [m/s] (NaN where the paradigm has none)."""

    paradigm: str
    magnitude: float
    unit: str
    direction_deg: float
    impulse_horizontal_n_s: float = float("nan")
    com_velocity_change_m_s: float = float("nan")
    extra: dict = field(default_factory=dict)

    def entry(self) -> dict:
        """The size as ``summary.json``'s ``perturbation`` entry: the fields, ``extra`` spread in."""
        return {
            "paradigm": self.paradigm,
            "magnitude": self.magnitude,
            "unit": self.unit,
            "direction_deg": self.direction_deg,
            "impulse_horizontal_n_s": self.impulse_horizontal_n_s,
            "com_velocity_change_m_s": self.com_velocity_change_m_s,
            **self.extra,
        }


class Perturbation:
    """A perturbation paradigm bound to one scenario; see the module docstring."""

    name: ClassVar[str] = ""
    #: its scenario keys (docs/perturbations.md)
    keys: ClassVar[tuple[str, ...]] = ()
    #: the natural size's unit and what it is
    unit: ClassVar[str] = ""

    def __init__(self, scenario: Scenario):
        self.scenario = scenario

    def edit_spec(self, spec: mujoco.MjSpec) -> None:
        """Add the paradigm's bodies to the scene's spec; parks the block (every paradigm but
        ``block``)."""
        park_block(spec)

    def initial_state(self, scene: Scene, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Change the scene's initial ``qpos``/``qvel`` in place: the block parked, the soles put
        on the floor (quiet stance: W's pose starts them 5 mm up)."""
        qpos[scene.block_qpos_index] = [*PARKED_BLOCK_M, 1.0, 0.0, 0.0, 0.0]
        qvel[scene.block_qvel_index] = 0.0
        onto_floor(scene, qpos)

    def driver(self, scene: Scene, model: mujoco.MjModel, data: mujoco.MjData, policy: Any) -> Driver | None:
        """The run's :class:`Driver` (None: nothing to do during the run)."""
        return None

    def markers(self) -> list[tuple[float, str]]:
        """(time [s], label) of the perturbation's moments, for the replay's timeline."""
        return []

    def over_row(self) -> int | None:
        """The control period from which the perturbation no longer acts: every input it sets
        (forces, its actuators' references, the controller's set point) holds constant from this
        row on, so its state is the run's own (the early-stop rule, :mod:`biped.sim.early_stop`,
        counts a rest only after it). None: the scene's state says when it is over (the block:
        once it lies at rest; the rule checks that). This default, for a paradigm that does not
        say: the row after the run's last, i.e. never (its runs go to their end)."""
        return self.scenario.control_steps + 1

    def arrows(self, scene: Scene, result: Any) -> np.ndarray | None:
        """(n, 2, 3) an arrow per row of ``result`` to draw (from, to; world [m]; NaN: none), the
        push or the tether, for the video; None: nothing to draw."""
        return None

    def size(self, total_mass_kg: float) -> Size:  # pragma: no cover - interface
        raise NotImplementedError

    # sweep support: one magnitude and one direction set the paradigm's keys
    @classmethod
    def sized(cls, base: Scenario, magnitude: float, direction_deg: float) -> dict:  # pragma: no cover
        """The scenario keys that give ``base`` this magnitude (in :attr:`unit`) and push
        direction (deg from +x toward +y, world frame)."""
        raise NotImplementedError


def point_track(scene: Scene, qpos: np.ndarray, body: int, point, rows) -> np.ndarray:
    """(len(rows), 3) the world position of ``point`` (``body``'s frame) at each of ``rows`` of
    ``qpos`` (MuJoCo kinematics)."""
    m = scene.model
    d = mujoco.MjData(m)
    out = np.zeros((len(rows), 3))
    for i, k in enumerate(rows):
        d.qpos[:] = qpos[k]
        mujoco.mj_kinematics(m, d)
        out[i] = d.xpos[body] + d.xmat[body].reshape(3, 3) @ np.asarray(point, dtype=float)
    return out


def onto_floor(scene: Scene, qpos: np.ndarray) -> None:
    """Lower the biped of ``qpos`` (scene layout, in place) so that its lowest sole point is on
    the floor, z = 0 (10 um into it, so that the first control period already has the contacts)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    low = np.inf
    for g in scene.sole_geoms:
        R = d.geom_xmat[g].reshape(3, 3)
        low = min(low, float(d.geom_xpos[g, 2] - np.abs(R[2]) @ m.geom_size[g]))
    qpos[scene.biped_qpos_index[2]] -= low + 1e-5  # 10 um in: MuJoCo sees the contacts at once


def hold_here(controller, data: mujoco.MjData, body: int) -> tuple[np.ndarray, np.ndarray]:
    """Quiet stance: the controller's set point becomes the central body's (``body``) COM and
    orientation in ``data`` (zero velocity and acceleration), written into the array the Python
    and the compiled loop read; returns that (COM, quaternion)."""
    com, quat = data.xipos[body].copy(), data.xquat[body].copy()
    set_target(controller, com, quat)
    return com, quat


def set_target(controller, com, quat) -> None:
    """Write a still set point (COM, quaternion) into ``controller.target.array`` in place."""
    arr = controller.target.array
    arr[0:3] = com
    arr[3:9] = 0.0
    arr[9:13] = quat
    arr[13:19] = 0.0


def workspace_controller(policy: Any):
    """The :class:`~biped.control.workspace.WorkspaceController` behind a loop policy, or None."""
    from biped.control.workspace import WorkspaceController

    ctrl = getattr(getattr(policy, "policy", None), "controller", None)
    return ctrl if isinstance(ctrl, WorkspaceController) else None


def park_block(spec: mujoco.MjSpec) -> None:
    """The block of the scene's spec out of the way: far off, not colliding, weightless."""
    from biped.sim.scene import BLOCK

    body = spec.body(BLOCK)
    body.pos = list(PARKED_BLOCK_M)
    body.gravcomp = 1.0
    g = spec.geom(BLOCK)
    g.contype, g.conaffinity = 0, 0
    g.rgba = [0.9, 0.6, 0.1, 0.0]  # not drawn


def pelvis_point(model: mujoco.MjModel, body: int) -> np.ndarray:
    """(3,) the pelvis in ``body``'s frame: the midpoint of the anchors of the joints of
    ``body``'s children (the hips, for the central body) [m]."""
    pts = []
    for b in range(model.nbody):
        if model.body_parentid[b] == body and b != body:
            pts.append(model.body_pos[b])
    return np.mean(pts, axis=0) if pts else np.zeros(3)


def horizontal(direction_deg: float) -> np.ndarray:
    """(3,) the unit horizontal vector at ``direction_deg`` from +x toward +y."""
    a = math.radians(direction_deg)
    return np.array([math.cos(a), math.sin(a), 0.0])


def world_direction_deg(v) -> float:
    """The direction [deg, in [0, 360)] of the horizontal part of ``v``, from +x toward +y."""
    return float(math.degrees(math.atan2(float(v[1]), float(v[0]))) % 360.0)
