"""Model builders: textbook systems on :class:`core.multibody.System`, shared by scenes, tests and benchmarks.

Each builder returns an assembled :class:`~core.multibody.System` at its
initial state (and, where a scene needs more, a small frozen dataclass with
the body and joint handles). Global +z is up; SI units.
"""

from ._cam import (
    CAM_CONTACT_MODELS,
    CAM_LAWS,
    FOLLOWER_KINDS,
    CamCurve,
    CamFollower,
    CamKinematics,
    CamMotion,
    CamProfile,
    CamSystem,
)
from ._linkages import SliderCrank, SpatialDoublePendulum, slider_crank, spatial_double_pendulum
from ._pendulum import ROD_RADIUS_RATIO, ReducedChainMotion, pendulum_chain, pendulum_chain_reduced
from ._rolling_disk import (
    FLAT_LEAN,
    RollingDiskMotion,
    rolling_disk,
    rolling_disk_critical_spin,
    rolling_disk_reference,
)
from ._top import HeavyTop, heavy_top
from ._vibration import (
    DiskRotor,
    SphericalPendulum,
    SteadyTop,
    TwoMassOscillator,
    disk_rotor,
    spherical_pendulum,
    steady_top,
    two_mass_oscillator,
)

__all__ = [
    "DiskRotor",
    "SphericalPendulum",
    "SteadyTop",
    "TwoMassOscillator",
    "disk_rotor",
    "spherical_pendulum",
    "steady_top",
    "two_mass_oscillator",
    "CAM_CONTACT_MODELS",
    "CAM_LAWS",
    "FLAT_LEAN",
    "FOLLOWER_KINDS",
    "ROD_RADIUS_RATIO",
    "CamCurve",
    "CamFollower",
    "CamKinematics",
    "CamMotion",
    "CamProfile",
    "CamSystem",
    "HeavyTop",
    "ReducedChainMotion",
    "RollingDiskMotion",
    "SliderCrank",
    "SpatialDoublePendulum",
    "heavy_top",
    "pendulum_chain",
    "pendulum_chain_reduced",
    "rolling_disk",
    "rolling_disk_critical_spin",
    "rolling_disk_reference",
    "slider_crank",
    "spatial_double_pendulum",
]
