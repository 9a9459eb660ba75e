"""Input validation shared by every representation.

Every public function of :mod:`rigidlab.core.rotations` validates its inputs here and
raises :class:`ValueError` naming the argument, what was expected and what
was given. Conventions are stated once in ``docs/conventions.md``.
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from rigidlab.core._validation import _holds_bool, check_degrees, degrees_out

#: Largest accepted deviation ``| ||p|| - 1 |`` of Euler parameters (and of
#: unit axes) from unit norm. Inputs within it are accepted (and normalized
#: where the result must be a rotation); inputs beyond it are rejected.
UNIT_NORM_TOL = 1e-6

# The same test on the squared norm: | ||p||^2 - 1 | <= 2 tol + tol^2 is
# equivalent to | ||p|| - 1 | <= tol.
UNIT_NORM2_TOL = 2.0 * UNIT_NORM_TOL + UNIT_NORM_TOL**2

# Squared norms within 4 eps of 1 are unit to rounding: dividing by the norm
# would change the components by at most 2 eps, so the hot kernels skip it.
NORMALIZED_TOL = 4.0 * np.finfo(np.float64).eps

#: Largest accepted entry of ``|A @ A.T - I|`` for a rotation matrix ``A``.
ORTHOGONALITY_TOL = 1e-6

_AXES = "xyz"


def _index_str(index):
    """Format a batch index for an error message."""
    if len(index) == 0:
        return ""
    return f" at batch index {tuple(int(i) for i in index)}"


def _scaled_norm(arr):
    """Split vectors ``arr = m s`` along the last axis, ``m = max|arr_i|``.

    Returns ``m`` (...), ``s`` (..., k) and ``|s|`` (...) (``s = 0``,
    ``|s| = 0`` where ``m = 0``). ``|arr| = m |s|`` and ``arr / |arr| =
    s / |s|`` without the overflow or underflow of the squares of huge or
    tiny entries.
    """
    m = np.max(np.abs(arr), axis=-1)
    s = arr / np.where(m == 0.0, 1.0, m)[..., None]
    return m, s, np.sqrt(np.einsum("...i,...i->...", s, s))


def _scaled_from_one(arr):
    """Split vectors ``arr = m s`` along the last axis, ``m = max(1, max|arr_i|)``.

    Returns ``s`` (..., k) and ``1 / m`` (...). For entries within +-1 this
    is exact (``m = 1``), so formulas in ``1 + arr . arr`` written as
    ``1/m^2 + s . s`` keep their values; for huge entries (Rodriguez
    parameters near a half turn, MRP near a full turn) nothing overflows.
    """
    m = np.maximum(np.max(np.abs(arr), axis=-1), 1.0)
    return arr / m[..., None], 1.0 / m


_FLOAT64 = np.dtype(np.float64)


def as_float_array(x, name):
    """Convert ``x`` to a float64 array or raise a ValueError naming it.

    Complex input is refused rather than cast (a cast would silently drop
    the imaginary part), and so is boolean input (``True`` is not the
    angle 1 rad; numpy would turn ``[0.1, True, 0.2]`` into
    ``[0.1, 1.0, 0.2]``), as in the rest of the core. A float64 ndarray is
    returned as is.
    """
    if type(x) is np.ndarray and x.dtype is _FLOAT64:
        return x
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"Expected `{name}` to be an array of real numbers, got {x!r}"
        ) from exc
    if arr.dtype.kind == "c" or (
        arr.dtype.kind == "O"
        and any(isinstance(v, (complex, np.complexfloating)) for v in arr.flat)
    ):
        raise ValueError(
            f"Expected `{name}` to be real numbers, got complex "
            f"(dtype {arr.dtype}): {_short_repr(x)}"
        )
    if arr.dtype.kind == "b" or (arr.dtype.kind == "O" or not isinstance(x, np.ndarray)) and _holds_bool(x):
        where = " " if isinstance(x, (bool, np.bool_)) else " in "
        raise ValueError(
            f"Expected `{name}` to be an array of real numbers, got a boolean{where}{_short_repr(x)}"
        )
    try:
        return arr.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"Expected `{name}` to be an array of real numbers, got {x!r}"
        ) from exc


def _short_repr(x, limit=80):
    """``repr(x)`` cut to ``limit`` characters for an error message."""
    text = repr(x)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _raise_non_finite(arr, name, n_trailing):
    full = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
    batch_index = full[: arr.ndim - n_trailing]
    value = float(arr[full])
    where = ""
    if n_trailing:
        where = f" in {arr[batch_index].tolist()}"
    raise ValueError(
        f"Expected `{name}` to be finite, got {value}{where}{_index_str(batch_index)}"
    )


def check_finite(arr, name, n_trailing=0):
    """Raise a ValueError naming ``name`` if ``arr`` holds NaN or infinity."""
    if not np.isfinite(arr).all():
        _raise_non_finite(arr, name, n_trailing)
    return arr


def check_vector(x, name, size=3):
    """Validate an array of shape ``(..., size)`` with finite float64 entries.

    Parameters
    ----------
    x : array_like, shape (..., size)
    name : str
        Argument name used in error messages.
    size : int
        Length of the last axis.

    Returns
    -------
    arr : ndarray, shape (..., size), float64
    """
    arr = as_float_array(x, name)
    if arr.ndim < 1 or arr.shape[-1] != size:
        raise ValueError(
            f"Expected `{name}` to have shape (..., {size}), got shape {arr.shape}"
        )
    return check_finite(arr, name, 1)


def check_scalar_array(x, name):
    """Validate an array of finite float64 scalars of shape ``(...)``."""
    arr = as_float_array(x, name)
    return check_finite(arr, name, 0)


def check_unit_vector(x, name, tol=UNIT_NORM_TOL):
    """Validate unit vectors of shape ``(..., 3)`` (e.g. rotation axes).

    Returns the vectors divided by their norm (a change of at most ``tol``).
    """
    arr = check_vector(x, name, 3)
    x = arr[..., 0]
    y = arr[..., 1]
    z = arr[..., 2]
    # Same arithmetic as the fused checks of the blocked kernels.
    with np.errstate(over="ignore", under="ignore"):  # huge / tiny: rejected below
        n2 = x * x + y * y + z * z
    norm = np.sqrt(n2)
    ok = np.abs(n2 - 1.0) <= 2.0 * tol + tol * tol
    if not ok.all():
        index = np.argwhere(~ok)[0] if ok.ndim else ()
        bad = arr[tuple(index)]
        # hypot: the true norm even where the squares overflow or underflow
        bad_norm = float(np.hypot(np.hypot(bad[0], bad[1]), bad[2]))
        raise ValueError(
            f"Expected `{name}` to be a unit vector (| |{name}| - 1 | <= {tol:g}), "
            f"got norm {bad_norm!r}{_index_str(index)}"
        )
    return arr / norm[..., None]


def check_euler_parameters(p, name="p", tol=UNIT_NORM_TOL):
    """Validate Euler parameters and return them normalized.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    name : str
        Argument name used in error messages.
    tol : float
        Largest accepted ``| ||p|| - 1 |``; default :data:`UNIT_NORM_TOL`.

    Returns
    -------
    p : ndarray, shape (..., 4), float64
        ``p / ||p||``; differs from the input by at most ``tol``.

    Raises
    ------
    ValueError
        If the shape is not (..., 4), an entry is not finite or the norm
        deviates from 1 by more than ``tol``.
    """
    arr = as_float_array(p, name)
    if arr.shape == (4,):  # one rotation: the same test on floats (invalid input falls through)
        p0, p1, p2, p3 = arr.tolist()
        n2 = p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3
        if abs(n2 - 1.0) <= 2.0 * tol + tol * tol:
            scale = 1.0 / math.sqrt(n2)
            return np.array((p0 * scale, p1 * scale, p2 * scale, p3 * scale))
    if arr.ndim < 1 or arr.shape[-1] != 4:
        raise ValueError(
            f"Expected `{name}` to have shape (..., 4), got shape {arr.shape}"
        )
    p0 = arr[..., 0]
    p1 = arr[..., 1]
    p2 = arr[..., 2]
    p3 = arr[..., 3]
    with np.errstate(over="ignore", under="ignore"):  # huge / tiny: rejected below
        n2 = p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3
    norm = np.sqrt(n2)
    # | ||p|| - 1 | <= tol, tested on the squared norm; NaN and infinity fail
    # this comparison too, so finiteness costs nothing on the valid path.
    ok = np.abs(n2 - 1.0) <= 2.0 * tol + tol * tol
    if not ok.all():
        check_finite(arr, name, 1)
        index = np.argwhere(~ok)[0] if ok.ndim else ()
        m, _, n = _scaled_norm(arr[tuple(index)])
        with np.errstate(over="ignore"):
            bad_norm = float(m * n)  # the true norm, inf only past float64
        raise ValueError(
            f"Expected `{name}` to be unit Euler parameters "
            f"(| |{name}| - 1 | <= {tol:g}), got norm "
            f"{bad_norm!r}{_index_str(index)}; "
            "use normalize_euler_parameters to renormalize"
        )
    return arr / norm[..., None]


def check_quaternion(q, name="q"):
    """Validate general (not necessarily unit) quaternions, scalar first.

    Returns
    -------
    q : ndarray, shape (..., 4), float64
    """
    return check_vector(q, name, 4)


def check_matrix(A, name="A", tol=ORTHOGONALITY_TOL):
    """Validate rotation matrices: shape, finiteness, orthogonality, det +1.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global).
    name : str
        Argument name used in error messages.
    tol : float
        Largest accepted entry of ``|A @ A.T - I|``; default
        :data:`ORTHOGONALITY_TOL`.

    Returns
    -------
    A : ndarray, shape (..., 3, 3), float64

    Raises
    ------
    ValueError
        If the shape is not (..., 3, 3), an entry is not finite, the matrix
        is not orthogonal within ``tol`` or its determinant is not +1.
    """
    arr = as_float_array(A, name)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(
            f"Expected `{name}` to have shape (..., 3, 3), got shape {arr.shape}"
        )
    with np.errstate(all="ignore"):
        dev, det = orthogonality_deviation(arr)
    ok = dev <= tol
    if not ok.all():
        check_finite(arr, name, 2)
        index = np.argwhere(~ok)[0] if ok.ndim else ()
        raise ValueError(
            f"Expected `{name}` to be orthogonal (max |{name} {name}^T - I| <= "
            f"{tol:g}), got deviation {float(dev[tuple(index)]):.3g}"
            f"{_index_str(index)}"
        )
    bad = det < 0.0
    if bad.any():
        index = np.argwhere(bad)[0] if bad.ndim else ()
        raise ValueError(
            f"Expected `{name}` to have determinant +1 (a proper rotation), got "
            f"determinant {float(det[tuple(index)]):.6g}{_index_str(index)}"
        )
    return arr


def orthogonality_deviation(arr):
    """Largest entry of ``|A A^T - I|`` and the determinant, per matrix.

    Parameters
    ----------
    arr : ndarray, shape (..., 3, 3)

    Returns
    -------
    dev : ndarray, shape (...)
        NaN where an entry is not finite.
    det : ndarray, shape (...)
    """
    a00 = arr[..., 0, 0]
    a01 = arr[..., 0, 1]
    a02 = arr[..., 0, 2]
    a10 = arr[..., 1, 0]
    a11 = arr[..., 1, 1]
    a12 = arr[..., 1, 2]
    a20 = arr[..., 2, 0]
    a21 = arr[..., 2, 1]
    a22 = arr[..., 2, 2]
    # Rows of an orthogonal matrix are orthonormal: the six distinct entries
    # of A A^T - I. NaN (also from infinity) propagates through np.maximum.
    dev = np.abs(a00 * a00 + a01 * a01 + a02 * a02 - 1.0)
    dev = np.maximum(dev, np.abs(a10 * a10 + a11 * a11 + a12 * a12 - 1.0))
    dev = np.maximum(dev, np.abs(a20 * a20 + a21 * a21 + a22 * a22 - 1.0))
    dev = np.maximum(dev, np.abs(a00 * a10 + a01 * a11 + a02 * a12))
    dev = np.maximum(dev, np.abs(a00 * a20 + a01 * a21 + a02 * a22))
    dev = np.maximum(dev, np.abs(a10 * a20 + a11 * a21 + a12 * a22))
    # For an orthogonal matrix det = (row0 x row1) . row2 = +-1.
    det = (
        (a01 * a12 - a02 * a11) * a20
        + (a02 * a10 - a00 * a12) * a21
        + (a00 * a11 - a01 * a10) * a22
    )
    return dev, det


def _sequence_table():
    """The 24 valid sequences and their parsed form (built once, read-only)."""
    table = {}
    for a in range(3):
        for b in range(3):
            for c in range(3):
                if a != b and b != c:
                    axes = (a, b, c)
                    letters = "".join(_AXES[i] for i in axes)
                    table[letters.upper()] = (axes, True)
                    table[letters] = (axes, False)
    return table


_SEQUENCES = MappingProxyType(_sequence_table())


def parse_seq(seq):
    """Parse an Euler-angle sequence.

    Parameters
    ----------
    seq : str
        Three letters from ``xyz`` (extrinsic, fixed axes) or ``XYZ``
        (intrinsic, moving axes), no two consecutive equal.

    Returns
    -------
    axes : tuple of int
        Axis indices (0, 1, 2) of the three rotations, in the order given.
    intrinsic : bool
    """
    if type(seq) is str:
        parsed = _SEQUENCES.get(seq)
        if parsed is not None:
            return parsed
    if not isinstance(seq, str) or len(seq) != 3:
        raise ValueError(
            f"Expected `seq` to be a string of 3 axes such as 'ZXZ', got {seq!r}"
        )
    if seq.isupper() and set(seq) <= set("XYZ"):
        intrinsic = True
    elif seq.islower() and set(seq) <= set("xyz"):
        intrinsic = False
    else:
        raise ValueError(
            "Expected `seq` axes all from 'XYZ' (intrinsic) or all from 'xyz' "
            f"(extrinsic), got {seq!r}"
        )
    if seq[0] == seq[1] or seq[1] == seq[2]:
        raise ValueError(
            f"Expected consecutive axes of `seq` to be different, got {seq!r}"
        )
    axes = tuple(_AXES.index(c) for c in seq.lower())
    return axes, intrinsic


def broadcast_batch(*triples):
    """Broadcast the batch shapes of arrays with given trailing ranks.

    Parameters
    ----------
    *triples : (str, ndarray, int)
        Argument name, array and number of trailing (representation) axes.

    Returns
    -------
    arrays : list of ndarray
        Arrays broadcast to a common batch shape (read-only views).
    batch : tuple
        The common batch shape.
    """
    shapes = [a.shape[: a.ndim - n] for _, a, n in triples]
    try:
        batch = np.broadcast_shapes(*shapes)
    except ValueError as exc:
        given = ", ".join(
            f"`{name}` batch {shape}" for (name, _, _), shape in zip(triples, shapes)
        )
        raise ValueError(
            f"Expected broadcastable batch shapes, got {given}"
        ) from exc
    out = [np.broadcast_to(a, batch + a.shape[a.ndim - n :]) for _, a, n in triples]
    return out, batch


def radians_in(x, name, degrees):
    """An angle argument in radians: ``x`` unless ``degrees`` (checked to be
    True or False), else ``x`` (degrees) converted once, with ``np.deg2rad``,
    after :func:`as_float_array` (so bad input names ``name``) and before the
    caller's own validation."""
    if not check_degrees(degrees):
        return x
    return np.deg2rad(as_float_array(x, name))
