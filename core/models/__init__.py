"""Model builders: textbook systems on :class:`core.multibody.System`, shared by scenes, tests and benchmarks.

Each builder returns an assembled :class:`~core.multibody.System` at its
initial state (and, where a scene needs more, a small frozen dataclass with
the body and joint handles). Global +z is up; SI units.
"""

from ._linkages import SliderCrank, SpatialDoublePendulum, slider_crank, spatial_double_pendulum
from ._pendulum import ROD_RADIUS_RATIO, pendulum_chain
from ._top import HeavyTop, heavy_top

__all__ = [
    "ROD_RADIUS_RATIO",
    "HeavyTop",
    "SliderCrank",
    "SpatialDoublePendulum",
    "heavy_top",
    "pendulum_chain",
    "slider_crank",
    "spatial_double_pendulum",
]
