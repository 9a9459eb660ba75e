"""The one place where Euler parameters meet scipy's ``Rotation``.

scipy stores quaternions scalar last unless ``scalar_first=True`` is given;
rigidlab is scalar first everywhere, so every conversion goes through here.
scipy.spatial is imported on first use only: it takes longer to import than
the rest of the core.
"""

from __future__ import annotations

import numpy as np

from ._euler_parameters import canonical_euler_parameters
from ._validation import check_euler_parameters


def to_scipy(p):
    """scipy ``Rotation`` of Euler parameters.

    Parameters
    ----------
    p : array_like, shape (4,) or (n, 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.

    Returns
    -------
    rotation : scipy.spatial.transform.Rotation
    """
    from scipy.spatial.transform import Rotation

    p = check_euler_parameters(p, "p")
    return Rotation.from_quat(p, scalar_first=True)


def from_scipy(rotation):
    """Euler parameters of a scipy ``Rotation``.

    Parameters
    ----------
    rotation : scipy.spatial.transform.Rotation

    Returns
    -------
    p : ndarray, shape (4,) or (n, 4)
        Unit Euler parameters, scalar first, sign-canonical (theta0 >= 0).
    """
    from scipy.spatial.transform import Rotation

    if not isinstance(rotation, Rotation):
        raise ValueError(
            "Expected `rotation` to be a scipy.spatial.transform.Rotation, got "
            f"{type(rotation).__name__}"
        )
    return canonical_euler_parameters(
        np.asarray(rotation.as_quat(scalar_first=True), dtype=np.float64)
    )
