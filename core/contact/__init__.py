"""Non-impulsive contact between rigid bodies (Eqs. 8.84-8.109).

Surfaces are given in body frames by two surface parameters with closed-form
derivatives up to the third (:class:`Plane`, :class:`Sphere`,
:class:`Ellipsoid`, :class:`Torus`, :class:`ParametricSurface`), planar
profiles by one (:class:`PlanarCurve`, curve-on-curve contact of a planar
cam). ``System.add_contact`` adds a contact between two of them to a
:class:`rigidlab.core.multibody.System`: the five contact constraints with the
surface parameters as non-generalized coordinates and the normal force as
the one independent multiplier, or a compliant (Hunt-Crossley) force.
``MultibodyTrajectory.contact(c)`` returns a :class:`ContactHistory`;
``MultibodyTrajectory.separations`` lists :class:`Separation` events.
The formulation is explained in ``docs/contact.md``.

Example::

    from rigidlab.core.contact import Plane, Sphere
    from rigidlab.core.multibody import System
    system = System(gravity=(0.0, 0.0, -9.81))
    ball = system.add_body("ball", mass=1.0, inertia=(0.004, 0.004, 0.004), position=(0, 0, 0.1))
    c = system.add_contact(system.ground, Plane(), ball, Sphere(0.1))
    traj = system.simulate([0.0, 0.5, 1.0])
    traj.contact(c).normal_force           # (3,) N: m g
"""

from ._contact import CONTACT_MODELS, Contact, ContactHistory, Separation, gap_crossings
from ._curves import PlanarCurve
from ._errors import CONTACT_RANK_TOL, ContactError
from ._surfaces import Ellipsoid, ParametricSurface, Plane, Sphere, Surface, Torus

__all__ = [
    "CONTACT_MODELS",
    "CONTACT_RANK_TOL",
    "Contact",
    "ContactError",
    "ContactHistory",
    "Ellipsoid",
    "ParametricSurface",
    "PlanarCurve",
    "Plane",
    "Separation",
    "Sphere",
    "Surface",
    "Torus",
    "gap_crossings",
]
