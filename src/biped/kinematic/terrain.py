"""The ground the figure walks on: a floor at z = 0 and full-width blocks (stairs) on it.

The terrain varies along x only (the walking direction): each block is ``(x0, x1, top)``, an
obstacle occupying ``x0 <= x < x1`` from the floor up to ``top`` [m], infinitely wide in y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from biped.errors import ScenarioError

__all__ = ["FLAT", "Terrain"]


@dataclass(frozen=True)
class Terrain:
    """A floor at z = 0 and blocks ``((x0, x1, top), ...)`` [m] on it."""

    blocks: tuple = ()

    def __post_init__(self):
        blocks = tuple(tuple(float(v) for v in b) for b in self.blocks)
        for b in blocks:
            if len(b) != 3 or not all(np.isfinite(b)) or b[1] <= b[0] or b[2] <= 0:
                raise ScenarioError(
                    f"a terrain block is (x0, x1, top) with x1 > x0 and top > 0 (m), got {b!r}"
                )
        object.__setattr__(self, "blocks", blocks)

    @classmethod
    def stairs(cls, x_start: float, rise: float, run: float, n: int, top_run: float | None = None) -> Terrain:
        """``n`` steps up starting at ``x_start``: tread i (1..n) at height ``i rise`` from
        ``x_start + (i - 1) run``; the top tread is ``top_run`` long (default ``run``) and ends in a
        vertical drop back to the floor."""
        if not (rise > 0 and run > 0 and n >= 1):
            raise ScenarioError(
                f"stairs need rise > 0 m, run > 0 m and n >= 1 steps, got {rise!r}, {run!r}, {n!r}"
            )
        top_run = run if top_run is None else top_run
        blocks = []
        for i in range(1, n + 1):
            x0 = x_start + (i - 1) * run
            x1 = x0 + (top_run if i == n else run)
            blocks.append((x0, x1, i * rise))
        return cls(tuple(blocks))

    def height(self, x: ArrayLike) -> np.ndarray:
        """Terrain height at ``x`` (any shape) [m]."""
        x = np.asarray(x, dtype=float)
        h = np.zeros_like(x)
        for x0, x1, top in self.blocks:
            h = np.where((x >= x0) & (x < x1), np.maximum(h, top), h)
        return h

    def sole_gap(self, heel: np.ndarray, toe: np.ndarray) -> np.ndarray:
        """Smallest vertical gap between a straight sole and the terrain below it [m].

        Args:
            heel, toe: (T, 3) ends of the sole's centre line in the world.

        Returns:
            (T,) min over the sole of (sole height - terrain height); negative = penetration. A
            block edge under the sole counts (the sole is checked over every block it overlaps).
        """
        heel, toe = np.asarray(heel, dtype=float), np.asarray(toe, dtype=float)
        xa, za, xb, zb = heel[:, 0], heel[:, 2], toe[:, 0], toe[:, 2]
        gap = np.minimum(za, zb)  # the floor
        lo, hi = np.minimum(xa, xb), np.maximum(xa, xb)
        dx = np.where(np.abs(xb - xa) > 1e-12, xb - xa, 1e-12)
        for x0, x1, top in self.blocks:
            a, b = np.maximum(lo, x0), np.minimum(hi, x1)
            over = a <= b
            # the sole is linear in x: its lowest point over [a, b] is at an end of that interval
            za_ = za + (a - xa) / dx * (zb - za)
            zb_ = za + (b - xa) / dx * (zb - za)
            g = np.minimum(za_, zb_) - top
            gap = np.where(over, np.minimum(gap, g), gap)
        return gap

    def boxes(
        self, width: float = 2.0
    ) -> tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...]:
        """The blocks as MuJoCo boxes ``(centre (3,), half sizes (3,))`` [m], ``width`` wide."""
        return tuple(
            ((0.5 * (x0 + x1), 0.0, 0.5 * top), (0.5 * (x1 - x0), 0.5 * width, 0.5 * top))
            for x0, x1, top in self.blocks
        )


FLAT = Terrain()
