"""What the simulations mean: recovery envelopes of a sweep and Hof's feet-in-place bound.

Above :mod:`biped.sim` (it reads sweep rows and builds the push scene for body numbers), below
:mod:`biped.viz` (which draws these results).
"""

from biped.analysis.envelope import Envelope, envelope, survived, sweep_data
from biped.analysis.feet_in_place import (
    FeetInPlaceBound,
    feet_in_place_bound,
    hof_bound,
    ray_to_polygon_edge,
    support_polygon,
)

__all__ = [
    "Envelope",
    "FeetInPlaceBound",
    "envelope",
    "feet_in_place_bound",
    "hof_bound",
    "ray_to_polygon_edge",
    "support_polygon",
    "survived",
    "sweep_data",
]
