"""Contact constants and errors (a leaf module: the kernel, the float path and the search import it).

``ContactError`` is a ``rigidlab.core.integrators.RunFailure`` and a ``ValueError``;
the tolerances are those of the Newton iteration on the surface parameters
(Eqs. 8.90-8.109).
"""

from __future__ import annotations

from typing import Any

from rigidlab.core.integrators import RunFailure

__all__ = ["COMPLIANT", "CONSTRAINT", "CONTACT_RANK_TOL", "ContactError"]

#: Rank tolerance of C_s (Eq. 8.109): the volume spanned by the columns of
#: C_s scaled to unit length (rows scaled by the contact's length scale) must
#: exceed it; a line or surface contact has zero volume.
CONTACT_RANK_TOL = 1e-8

#: Newton on the surface parameters stops when a step is below this fraction
#: of the contact's length scale (the geometry at the last iterate is used;
#: the gap is stationary in s, so its error is of second order).
_STEP_TOL = 1e-11
_MAX_ITER = 25
_CHART_LIMIT = 1.0  # rad: a sphere/ellipsoid chart is re-centred beyond this latitude or longitude

CONSTRAINT, COMPLIANT = 0, 1


class ContactError(RunFailure, ValueError):
    """Contact geometry that cannot be followed (no contact point, rank loss); ``t`` says when.

    Raised at a trial stage of an adaptive step (a state far from the
    accepted ones), it makes the integrator retry the step shorter
    (``retry_shorter``, see ``rigidlab.core.integrators``); at an accepted state it
    stops the run.
    """

    retry_shorter = True

    def __init__(self, message: str, *, t: float | None = None):
        super().__init__(message)
        self.t = t


def _lost(contact: Any, t: float | None, why: str) -> str:
    when = "" if t is None else f" at t={t:.6g}"
    return f"contact {contact.name!r}: the contact point cannot be followed{when}: {why}"
