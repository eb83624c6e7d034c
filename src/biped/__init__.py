"""biped: simulate and control the balance of human-like bipeds.

Implements J. M. Wendlandt's recursive workspace balancing controller (1997) for a 13-body,
18-DOF 3D biped and M. Bediz's single-rigid-body postural models (NPS thesis, 1997).
"""

from biped import _numba_cache
from biped.errors import BipedError

_numba_cache.configure()  # before any kernel is defined: a cache folder this user can write

__version__ = "0.1.0"
__all__ = ["BipedError", "__version__"]
