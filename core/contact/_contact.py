"""The contact handle of a System and the per-contact results of a trajectory."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigidlab.core._errors import ArgumentError

__all__ = ["CONTACT_MODELS", "Contact", "ContactHistory", "Separation", "gap_crossings"]

#: Contact models of ``System.add_contact``.
CONTACT_MODELS = ("constraint", "compliant")


@dataclass(frozen=True, eq=False)
class Contact:
    """A contact between a surface of ``body_i`` and a surface of ``body_j`` (``System.add_contact``).

    Attributes
    ----------
    name : str
    body_i, body_j : Body
    surface_i, surface_j : Surface
        In the frames of ``body_i`` and ``body_j``.
    model : str
        ``"constraint"`` (the five contact constraints, Eqs. 8.90-8.94,
        normal force from the multipliers, Eq. 8.107) or ``"compliant"``
        (Hunt-Crossley force from the penetration).
    rolling : bool
        Rolling without slip (two velocity constraints at the contact
        point; one for curves).
    stiffness : float or None
        ``k`` of the compliant law (N/m^exponent); with the constraint
        model it is used after a separation when the run continues with
        ``on_separation="compliant"``.
    damping : float
        Hunt-Crossley ``c`` (s/m): ``F = k delta^e (1 + 3/2 c delta_dot)``.
    exponent : float
        ``e`` (1.5: Hertz).
    tolerance : float
        Largest gap or penetration (m) accepted by ``add_contact`` for the
        constraint model.
    index : int
        Order of creation among the System's contacts.
    initial_gap : float
        Gap (m) along the common normal in the configuration of
        ``add_contact`` (negative: penetration).
    """

    name: str
    body_i: Any
    body_j: Any
    surface_i: Any = field(repr=False)
    surface_j: Any = field(repr=False)
    model: str
    rolling: bool
    stiffness: float | None = field(repr=False)
    damping: float = field(repr=False)
    exponent: float = field(repr=False)
    tolerance: float = field(repr=False)
    index: int = field(repr=False)
    initial_gap: float = field(repr=False)
    _owner: Any = field(repr=False, compare=False)

    kind = "contact"

    @property
    def n_parameters(self) -> int:
        """Surface parameters per body: 2 (surfaces) or 1 (planar curves)."""
        return int(self.surface_i.n_parameters)


@dataclass(frozen=True)
class ContactHistory:
    """One contact along a trajectory (``MultibodyTrajectory.contact(c)``); read-only arrays.

    Attributes
    ----------
    t : (n,) times (s).
    normal_force : (n,) N, positive while pressing: the independent
        multiplier of the five contact constraints (Eq. 8.107) while the
        constraint model holds; the Hunt-Crossley force in the compliant
        model (zero while apart).
    point : (n, 3) contact point on ``surface_i``, global (m).
    point_j : (n, 3) its partner on ``surface_j`` (equal to ``point`` while
        the constraint holds; apart by the gap along the normal otherwise).
    normal : (n, 3) unit outward normal of ``surface_i`` (the common normal,
        pointing from ``body_i`` into ``body_j``), global.
    gap : (n,) m, along ``normal`` from ``point`` to ``point_j``
        (negative: penetration).
    surface_parameters : (n, 4) ``(s_i1, s_i2, s_j1, s_j2)``; for planar
        curves ``(s_i, nan, s_j, nan)``. Sphere and ellipsoid parameters are
        the longitude and latitude of their docstrings (wrapped to
        ``(-pi, pi]``), other parameters as followed (continuous).
    tangential_force : (n, 3) N, the force the rolling constraints apply to
        ``body_j`` (zero without rolling), global.
    force : (n, 3) N, the total contact force on ``body_j`` (``normal_force
        * normal + tangential_force``); ``-force`` acts on ``body_i``.
    multipliers : (n, 5) the chapter's multipliers of the five constraints
        ``[r_i - r_j (3); n . t_1; n . t_2]`` (``lambda = N normal_force`` with
        ``C_s^T lambda = 0``, Eqs. 8.105-8.107); curves ``[2 point rows; 1
        normal row; nan; nan]``. Zero while not in the constraint model.
    constraint : (n,) bool, True where the constraint model held.
    """

    t: np.ndarray  # (n,)
    normal_force: np.ndarray = field(repr=False)  # (n,)
    point: np.ndarray = field(repr=False)  # (n, 3)
    point_j: np.ndarray = field(repr=False)  # (n, 3)
    normal: np.ndarray = field(repr=False)  # (n, 3)
    gap: np.ndarray = field(repr=False)  # (n,)
    surface_parameters: np.ndarray = field(repr=False)  # (n, 4)
    tangential_force: np.ndarray = field(repr=False)  # (n, 3)
    force: np.ndarray = field(repr=False)  # (n, 3)
    multipliers: np.ndarray = field(repr=False)  # (n, 5)
    constraint: np.ndarray = field(repr=False)  # (n,)


@dataclass(frozen=True)
class Separation:
    """The instant a constraint-model contact's normal force crossed zero (it would have to pull).

    Attributes
    ----------
    contact : Contact
    t : float
        Time of the zero crossing (s), located by Brent's method on the
        normal force along the step's dense output.
    point : (3,) ndarray
        Contact point, global (m).
    normal : (3,) ndarray
        Common normal (outward of ``surface_i``), global.
    state : State
        The System's state at ``t``.
    action : str
        What the run did: ``"stopped"``, ``"compliant"`` (continued with
        the compliant model) or ``"bilateral"`` (kept the constraint, which
        then pulls).
    """

    contact: Contact
    t: float
    point: np.ndarray = field(repr=False)
    normal: np.ndarray = field(repr=False)
    state: Any = field(repr=False)
    action: str


def gap_crossings(t: Any, gap: Any, *, compliant: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Times a compliant contact opens and closes between outputs: ``(openings (k,), closings (m,))`` (s).

    One boundary convention for every contact test in core: a contact is
    *closed* where it touches, ``gap <= 0`` (the Hunt-Crossley force ``F = k
    delta^e (1 + 3/2 c delta_dot)`` with ``delta = -gap`` is zero at
    ``gap = 0``, the bodies still touch), *open* where ``gap > 0``; likewise
    a constraint-model contact holds while its normal force (the multiplier,
    Eq. 8.107) is ``>= 0`` and separates where it turns negative. So a
    sample with ``gap == 0`` counts as closed: an opening is a pair of
    outputs with ``gap[i] <= 0 < gap[i + 1]``, a closing one with ``gap[i] >
    0 >= gap[i + 1]``; the time is interpolated linearly in the gap (the
    zero of the chord).

    Parameters
    ----------
    t : (n,) array_like
        Output times (s), non-decreasing.
    gap : (n,) array_like
        Distance along the common normal at those times (m; negative: the
        compliant contact's penetration), e.g. ``traj.contact(c).gap``.
    compliant : (n,) array_like of bool or None, keyword-only
        Which outputs have the contact in the compliant model; only pairs
        of outputs both compliant count (a constraint-model contact's gap is
        round-off). None: all (``~traj.contact(c).constraint`` is the usual
        mask).

    Returns
    -------
    openings, closings : (k,), (m,) ndarray
        Increasing times (s).

    Raises
    ------
    ArgumentError
        ``t``, ``gap`` or ``compliant`` not of one length ``n``.
    """
    tt = np.asarray(t, dtype=float).reshape(-1)
    g = np.asarray(gap, dtype=float).reshape(-1)
    if g.shape != tt.shape:
        raise ArgumentError("gap", f"gap: expected {tt.size} values (one per output time), got {g.size}")
    if compliant is None:
        mask = np.ones(tt.shape, dtype=bool)
    else:
        mask = np.asarray(compliant, dtype=bool).reshape(-1)
        if mask.shape != tt.shape:
            raise ArgumentError("compliant", f"compliant: expected {tt.size} flags (one per output time), got "
                                             f"{mask.size}")
    a, b = g[:-1], g[1:]
    both = mask[:-1] & mask[1:]
    out = []
    for idx in (np.flatnonzero(both & (a <= 0.0) & (b > 0.0)), np.flatnonzero(both & (a > 0.0) & (b <= 0.0))):
        out.append(tt[idx] + a[idx] / (a[idx] - b[idx]) * (tt[idx + 1] - tt[idx]))
    return out[0], out[1]
