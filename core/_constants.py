"""Default tolerances shared by core's integrators and simulations (a leaf module: one place for each).

Imported by :mod:`rigidlab.core.integrators` (and re-exported there), by
``rigidlab.core.multibody``'s ``simulate`` and by the model builders in
:mod:`rigidlab.core.models`; applications pass ``None`` or these names instead of
repeating the numbers.
"""

from __future__ import annotations

__all__ = ["CAM_RTOL", "CAM_ATOL", "DEFAULT_ATOL", "DEFAULT_RTOL", "RIDE_ATOL", "RIDE_RTOL", "SEPARATION_XTOL"]

#: scipy-style relative and absolute tolerances of the adaptive methods (DOP853, RK45) when none is given:
#: :func:`rigidlab.core.integrators.integrate` and ``System.simulate``.
DEFAULT_RTOL = 1e-8
DEFAULT_ATOL = 1e-10

#: DOP853's tolerances of :meth:`rigidlab.core.models.CamFollower.simulate` (its compliant flight; the constraint model is
#: a kinematic analysis, exact to the Newton tolerance).
CAM_RTOL = 1e-10
CAM_ATOL = 1e-12

#: DOP853's tolerances of :func:`rigidlab.core.models.whipple_ride` (the bicycle's ride: seen, not measured).
RIDE_RTOL = 1e-6
RIDE_ATOL = 1e-8

#: Brent's method's absolute tolerance on the cam angle (rad) of the closed-form separation search
#: (:meth:`rigidlab.core.models.CamFollower.separation_intervals`).
SEPARATION_XTOL = 1e-12
