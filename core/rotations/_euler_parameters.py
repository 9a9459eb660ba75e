"""Euler parameters: unit quaternions, scalar first (Eqs. 8.46-8.57).

Euler parameters ``p = (theta0, theta1, theta2, theta3)`` of a rotation by
``angle`` about the unit ``axis`` are ``theta0 = cos(angle / 2)`` and
``(theta1, theta2, theta3) = axis * sin(angle / 2)`` (Eq. 8.46). They are
scalar first, the same order as viser's ``wxyz``. ``p`` and ``-p`` describe
the same rotation; functions returning parameters from a matrix pick
``theta0 >= 0``.
"""

from __future__ import annotations

import math

import numpy as np

from ._batch import BLOCK, blocks, compiled
from ._validation import (
    check_degrees,
    degrees_out,
    radians_in,
    ORTHOGONALITY_TOL,
    NORMALIZED_TOL,
    UNIT_NORM2_TOL,
    as_float_array,
    broadcast_batch,
    check_euler_parameters,
    check_matrix,
    check_quaternion,
    check_scalar_array,
    check_unit_vector,
    check_vector,
    orthogonality_deviation,
    _index_str,
    _scaled_norm,
)


def _matrix_from_rows(comp, o, ws, squares_ready=False):
    """Write the matrices of unit parameters into ``o`` (m, 3, 3).

    ``comp`` (4, m) holds theta0..theta3 in contiguous rows; ``ws`` is a
    workspace of at least 13 rows of length m whose rows 3-6 already hold
    the squares of ``comp`` when ``squares_ready``. Row-stacked operations
    keep the number of numpy calls per block small.
    """
    add = np.add
    sub = np.subtract
    m = comp.shape[1]
    w = comp[0]
    # Doubling is exact in binary floating point, so X * y == 2 * (x * y)
    # bit for bit; it saves the multiplications by 2.
    XYZ = ws[0:3, :m]
    add(comp[1:], comp[1:], out=XYZ)
    X, Y, Z = XYZ
    squares = ws[3:7, :m]
    if not squares_ready:
        np.multiply(comp, comp, out=squares)
    ww, xx, yy, zz = squares
    # Symmetric parts (2xy, 2xz, 2yz) and skew parts (2zw, 2yw, 2xw).
    sym = ws[7:10, :m]
    np.multiply(X, comp[2:4], out=sym[0:2])
    np.multiply(Y, comp[3], out=sym[2])
    skw = ws[10:13, :m]
    np.multiply(ws[2::-1, :m], w, out=skw)
    xy, xz, yz = sym
    zw, yw, xw = skw
    sub(xy, zw, out=o[:, 0, 1])
    add(xy, zw, out=o[:, 1, 0])
    add(xz, yw, out=o[:, 0, 2])
    sub(xz, yw, out=o[:, 2, 0])
    sub(yz, xw, out=o[:, 1, 2])
    add(yz, xw, out=o[:, 2, 1])
    # Diagonal: theta0^2 + theta_i^2 - theta_j^2 - theta_k^2 (rows 7-8 of
    # ws are free again).
    a = ws[7, :m]
    b = ws[8, :m]
    sub(ww, zz, out=a)
    sub(xx, yy, out=b)
    add(a, b, out=o[:, 0, 0])
    sub(a, b, out=o[:, 1, 1])
    add(ww, zz, out=a)
    add(xx, yy, out=b)
    sub(a, b, out=o[:, 2, 2])


def _matrix_kernel(flat, ok):
    """Rotation matrices of Euler parameters ``flat`` (n, 4), block by block.

    Writes ``| ||p||^2 - 1 | <= UNIT_NORM2_TOL`` into ``ok`` (n,) (NaN and
    infinity fail it) and normalizes each block unless it is unit to
    rounding already. Every intermediate lives in one preallocated
    workspace, and each block is first copied to contiguous rows.
    """
    n = flat.shape[0]
    out = np.empty((n, 3, 3))
    ws = np.empty((19, min(n, BLOCK)))
    for s, e in blocks(n):
        m = e - s
        comp = ws[13:17, :m]
        np.copyto(comp, flat[s:e].T)
        # The squares serve both the norm and the matrix (rows 3-6 of ws).
        squares = ws[3:7, :m]
        np.multiply(comp, comp, out=squares)
        ww, xx, yy, zz = squares
        n2 = ws[17, :m]
        t = ws[18, :m]
        np.add(ww, xx, out=n2)
        n2 += yy
        n2 += zz
        np.subtract(n2, 1.0, out=t)
        np.abs(t, out=t)
        np.less_equal(t, UNIT_NORM2_TOL, out=ok[s:e])
        unit = t.max(initial=0.0) <= NORMALIZED_TOL
        if not unit:
            np.sqrt(n2, out=n2)
            comp /= n2
        _matrix_from_rows(comp, out[s:e], ws, squares_ready=unit)
    return out


def _matrices(flat):
    """Rotation matrices (n, 3, 3) of Euler parameters ``flat`` (n, 4), and
    whether every row passed the unit-norm test of check_euler_parameters.

    Batches of at least ``COMPILED_MIN`` rotations run the compiled kernel
    (which decides the normalization per rotation rather than per block),
    smaller ones :func:`_matrix_kernel`. Invalid rows give NaN or garbage
    silently; the caller decides what to do about them.
    """
    n = flat.shape[0]
    kernels = compiled(n)
    if kernels is not None:
        out = np.empty((n, 3, 3))
        bad = kernels.matrix_from_euler_parameters(
            np.ascontiguousarray(flat), out, UNIT_NORM2_TOL, NORMALIZED_TOL
        )
        return out, bad == 0
    ok = np.empty(n, dtype=bool)
    with np.errstate(all="ignore"):
        out = _matrix_kernel(flat, ok)
    return out, bool(ok.all())


def _matrix_from_unit_p(p):
    """Rotation matrices of unit Euler parameters (no validation)."""
    out, _ = _matrices(p.reshape(-1, 4))
    return out.reshape(p.shape[:-1] + (3, 3))


# ------------------------------------------------------------ one rotation
# A single rotation (no batch axes) is evaluated on Python floats: the same
# operations as the blocked kernels, in the same order, without the fixed
# cost of a dozen array operations on length-one arrays. Each ``_single``
# kernel returns None when its input fails validation; the caller then runs
# the batched path, which raises the error naming the argument.


def _matrix_single(w, x, y, z):
    """The arithmetic of :func:`_matrix_from_rows` for one rotation: (3, 3)."""
    X = x + x
    Y = y + y
    Z = z + z
    ww = w * w
    xx = x * x
    yy = y * y
    zz = z * z
    xy = X * y
    xz = X * z
    yz = Y * z
    zw = Z * w
    yw = Y * w
    xw = X * w
    a = ww - zz
    b = xx - yy
    c = ww + zz
    d = xx + yy
    return np.array(
        (a + b, xy - zw, xz + yw, xy + zw, a - b, yz - xw, xz - yw, yz + xw, c - d)
    ).reshape((3, 3))


def _matrix_from_p_single(w, x, y, z):
    """:func:`_matrix_kernel` for one rotation; None if ``p`` is not unit."""
    n2 = w * w + x * x + y * y + z * z
    t = abs(n2 - 1.0)
    if not t <= UNIT_NORM2_TOL:  # NaN and infinity fail too
        return None
    if t > NORMALIZED_TOL:
        norm = math.sqrt(n2)
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
    return _matrix_single(w, x, y, z)


def _unit_p_single(w, x, y, z):
    """:func:`check_euler_parameters` for one rotation: the normalized
    parameters as floats, or None if ``p`` is not unit."""
    n2 = w * w + x * x + y * y + z * z
    if not abs(n2 - 1.0) <= UNIT_NORM2_TOL:  # NaN and infinity fail too
        return None
    norm = math.sqrt(n2)
    return w / norm, x / norm, y / norm, z / norm


def _p_from_matrix_single(a00, a01, a02, a10, a11, a12, a20, a21, a22):
    """Validation and Shepperd's method (:func:`_shepperd_block`) for one
    rotation matrix given row by row: (4,), or None if ``A`` is not a
    rotation matrix."""
    # orthogonality_deviation: rows orthonormal and det > 0 (NaN fails).
    tol = ORTHOGONALITY_TOL
    if not (
        abs(a00 * a00 + a01 * a01 + a02 * a02 - 1.0) <= tol
        and abs(a10 * a10 + a11 * a11 + a12 * a12 - 1.0) <= tol
        and abs(a20 * a20 + a21 * a21 + a22 * a22 - 1.0) <= tol
        and abs(a00 * a10 + a01 * a11 + a02 * a12) <= tol
        and abs(a00 * a20 + a01 * a21 + a02 * a22) <= tol
        and abs(a10 * a20 + a11 * a21 + a12 * a22) <= tol
        and (a01 * a12 - a02 * a11) * a20
        + (a02 * a10 - a00 * a12) * a21
        + (a00 * a11 - a01 * a10) * a22
        > 0.0
    ):
        return None
    trace = a00 + a11 + a22
    d0 = 1.0 + trace
    e = 1.0 - trace
    d1 = e + 2.0 * a00
    d2 = e + 2.0 * a11
    d3 = e + 2.0 * a22
    s01 = a21 - a12
    s02 = a02 - a20
    s03 = a10 - a01
    # The first largest pivot, as np.argmax picks it.
    if d0 >= d1 and d0 >= d2 and d0 >= d3:
        q0, q1, q2, q3 = d0, s01, s02, s03
    elif d1 >= d2 and d1 >= d3:
        q0, q1, q2, q3 = s01, d1, a10 + a01, a02 + a20
    elif d2 >= d3:
        q0, q1, q2, q3 = s02, a10 + a01, d2, a21 + a12
    else:
        q0, q1, q2, q3 = s03, a02 + a20, a21 + a12, d3
    norm = math.copysign(math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3), q0)
    return np.array((q0 / norm, q1 / norm, q2 / norm, q3 / norm))


def _axis_and_angle_floats(axis, angle):
    """``(x, y, z, angle)`` as floats when ``axis`` is one vector (3,) and
    ``angle`` one number, else None (validation is left to the caller)."""
    if type(angle) is float or type(angle) is np.float64:
        a = float(angle)
    else:
        an = as_float_array(angle, "angle")
        if an.shape != ():
            return None
        a = float(an)
    ax = as_float_array(axis, "axis")
    if ax.shape != (3,):
        return None
    x, y, z = ax.tolist()
    return x, y, z, a


def matrix_from_euler_parameters(p):
    """Rotation matrix of Euler parameters (Eqs. 8.48-8.50).

    .. math::

        A = (2\\theta_0^2 - 1) I + 2 (\\theta \\theta^T + \\theta_0 \\tilde\\theta)

    evaluated in the equivalent form whose diagonal is
    ``theta0**2 + theta_i**2 - theta_j**2 - theta_k**2``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Euler parameters (theta0, theta1, theta2, theta3), scalar first;
        unit norm within :data:`UNIT_NORM_TOL`, normalized before use
        (unless already unit to rounding, ``| ||p||^2 - 1 | <= 4 eps``).

    Returns
    -------
    A : ndarray, shape (..., 3, 3)
        Active rotation matrix, body to global: ``u_global = A @ u_body``.
    """
    arr = as_float_array(p, "p")
    if arr.shape == (4,):
        out = _matrix_from_p_single(*arr.tolist())
        if out is not None:
            return out
    if arr.ndim < 1 or arr.shape[-1] != 4:
        check_euler_parameters(arr, "p")
    # The validation of check_euler_parameters is fused into the kernels;
    # invalid entries only produce NaN silently until they are reported
    # below, and nothing is returned unless every rotation passed.
    out, ok = _matrices(arr.reshape(-1, 4))
    if not ok:
        check_euler_parameters(arr, "p")  # raises, naming the batch index
    return out.reshape(arr.shape[:-1] + (3, 3))


def _shepperd_block(A, out):
    """Euler parameters with theta0 >= 0 of rotation matrices A (m, 3, 3)."""
    a00 = A[:, 0, 0]
    a11 = A[:, 1, 1]
    a22 = A[:, 2, 2]
    a01 = A[:, 0, 1]
    a10 = A[:, 1, 0]
    a02 = A[:, 0, 2]
    a20 = A[:, 2, 0]
    a12 = A[:, 1, 2]
    a21 = A[:, 2, 1]
    trace = a00 + a11 + a22
    # 4 theta_a theta_b for every pair (a, b) (Eqs. 8.48-8.50); the row of
    # the largest diagonal entry is the best conditioned (Shepperd's method).
    d0 = 1.0 + trace
    e = 1.0 - trace
    d1 = e + 2.0 * a00
    d2 = e + 2.0 * a11
    d3 = e + 2.0 * a22
    s01 = a21 - a12
    s02 = a02 - a20
    s03 = a10 - a01
    s12 = a10 + a01
    s13 = a02 + a20
    s23 = a21 + a12
    choice = np.argmax(np.stack([d0, d1, d2, d3]), axis=0)
    q0 = np.choose(choice, (d0, s01, s02, s03))
    q1 = np.choose(choice, (s01, d1, s12, s13))
    q2 = np.choose(choice, (s02, s12, d2, s23))
    q3 = np.choose(choice, (s03, s13, s23, d3))
    norm = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    # The norm with the sign of theta0, so that theta0 >= 0.
    np.copysign(norm, q0, out=norm)
    np.divide(q0, norm, out=out[:, 0])
    np.divide(q1, norm, out=out[:, 1])
    np.divide(q2, norm, out=out[:, 2])
    np.divide(q3, norm, out=out[:, 3])


def _p_from_matrix(A):
    """Euler parameters of rotation matrices (no validation), theta0 >= 0."""
    flat = A.reshape(-1, 3, 3)
    n = flat.shape[0]
    out = np.empty((n, 4))
    kernels = compiled(n)
    if kernels is not None:
        kernels.euler_parameters_from_matrix(
            np.ascontiguousarray(flat), out, ORTHOGONALITY_TOL
        )
    else:
        for s, e in blocks(n):
            _shepperd_block(flat[s:e], out[s:e])
    return out.reshape(A.shape[:-2] + (4,))


def euler_parameters_from_matrix(A):
    """Euler parameters of a rotation matrix (Eqs. 8.48-8.50).

    Uses Shepperd's method: of the four expressions ``4 theta_k**2``
    (``1 + tr A`` and ``1 - tr A + 2 A_kk``) the largest is used as pivot,
    so the result is accurate for every rotation including angles near pi.

    Parameters
    ----------
    A : array_like, shape (..., 3, 3)
        Rotation matrices (active, body to global), orthogonal within
        :data:`ORTHOGONALITY_TOL` with determinant +1.

    Returns
    -------
    p : ndarray, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar
        first, with ``theta0 >= 0``.
    """
    arr = as_float_array(A, "A")
    if arr.shape == (3, 3):
        out = _p_from_matrix_single(*arr.ravel().tolist())
        if out is not None:
            return out
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        check_matrix(arr, "A")
    flat = arr.reshape(-1, 3, 3)
    n = flat.shape[0]
    out = np.empty((n, 4))
    kernels = compiled(n)
    if kernels is not None:
        # The same validation and arithmetic in one compiled loop.
        if kernels.euler_parameters_from_matrix(
            np.ascontiguousarray(flat), out, ORTHOGONALITY_TOL
        ):
            check_matrix(arr, "A")  # raises, naming the batch index
        return out.reshape(arr.shape[:-2] + (4,))
    ok = np.empty(n, dtype=bool)
    # Invalid entries are only reported after the loop; until then they
    # may produce NaN silently.
    with np.errstate(all="ignore"):
        for s, e in blocks(n):
            b = flat[s:e]
            # The validation of check_matrix, fused into the block; NaN and
            # infinity fail it too. Nothing is returned unless every block
            # passed.
            dev, det = orthogonality_deviation(b)
            np.less_equal(dev, ORTHOGONALITY_TOL, out=ok[s:e])
            ok[s:e] &= det > 0.0
            _shepperd_block(b, out[s:e])
    if not ok.all():
        check_matrix(arr, "A")  # raises, naming the batch index
    return out.reshape(arr.shape[:-2] + (4,))


def euler_parameters_from_axis_angle(axis, angle, *, degrees=False):
    """Euler parameters of a rotation about an axis (Eq. 8.46).

    ``theta0 = cos(angle / 2)``, ``(theta1, theta2, theta3) = axis sin(angle / 2)``.

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Unit rotation axis (same components in body and global frame).
    angle : array_like, shape (...)
        Rotation angle in radians, right-hand rule about ``axis``. Any real
        value; for ``|angle| > pi`` theta0 is negative (no sign is changed).
    degrees : bool, keyword-only
        True: ``angle`` is in degrees.

    Returns
    -------
    p : ndarray, shape (..., 4)
        Euler parameters, scalar first; batch shape is the broadcast of the
        batch shapes of ``axis`` and ``angle``.
    """
    angle = radians_in(angle, "angle", degrees)
    single = _axis_and_angle_floats(axis, angle)
    if single is not None:
        x, y, z, a = single
        n2 = x * x + y * y + z * z
        if abs(n2 - 1.0) <= UNIT_NORM2_TOL and math.isfinite(a):
            norm = math.sqrt(n2)
            half = 0.5 * a
            s = math.sin(half)
            return np.array(
                (math.cos(half), x / norm * s, y / norm * s, z / norm * s)
            )
    axis = check_unit_vector(axis, "axis")
    angle = check_scalar_array(angle, "angle")
    (axis, angle), batch = broadcast_batch(("axis", axis, 1), ("angle", angle, 0))
    half = 0.5 * angle
    s = np.sin(half)
    out = np.empty(batch + (4,))
    out[..., 0] = np.cos(half)
    out[..., 1:] = axis * s[..., None]
    return out


def axis_angle_from_euler_parameters(p, *, degrees=False):
    """Axis and angle of Euler parameters (inverse of Eq. 8.46).

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    degrees : bool, keyword-only
        True: ``angle`` is returned in degrees.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit rotation axis; ``(0, 0, 1)`` where the rotation is the identity
        (any axis would do).
    angle : ndarray, shape (...)
        Rotation angle in ``[0, pi]`` (``p`` and ``-p`` give the same
        result).
    """
    check_degrees(degrees)
    arr = as_float_array(p, "p")
    if arr.shape == (4,):
        unit = _unit_p_single(*arr.tolist())
        if unit is not None:
            axis, angle = _axis_angle_from_p_single(*unit)
            return axis, degrees_out(angle, degrees)
    p = check_euler_parameters(arr, "p")
    axis, angle = _axis_angle_from_unit_p(p)
    return axis, degrees_out(angle, degrees)


def _axis_angle_from_p_single(w, x, y, z):
    """:func:`_axis_angle_from_unit_p` for one rotation."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.hypot(math.hypot(x, y), z)
    angle = np.float64(2.0 * math.atan2(s, w))
    if s == 0.0:
        return np.array((0.0, 0.0, 1.0)), angle
    m = max(abs(x), abs(y), abs(z))
    x, y, z = x / m, y / m, z / m
    n = math.hypot(math.hypot(x, y), z)
    return np.array((x / n, y / n, z / n)), angle


def _axis_angle_from_unit_p(p):
    p = np.where(p[..., :1] < 0.0, -p, p)
    vec = p[..., 1:]
    # hypot does not underflow for tiny vector parts (angles below 1e-150).
    s = np.hypot(np.hypot(vec[..., 0], vec[..., 1]), vec[..., 2])
    angle = 2.0 * np.arctan2(s, p[..., 0])
    zero = s == 0.0
    # The axis from the vector part scaled by its largest entry first:
    # dividing by s directly gives a non-unit axis for subnormal vector
    # parts (angles below 1e-307), whose hypot is rounded to the coarse
    # subnormal grid (hypot(5e-324, 5e-324) = 5e-324).
    m, scaled, n = _scaled_norm(vec)
    axis = scaled / np.where(zero, 1.0, n)[..., None]
    axis = np.where(zero[..., None], np.array([0.0, 0.0, 1.0]), axis)
    return axis, angle


def normalize_euler_parameters(p):
    """Renormalize Euler parameters to unit norm.

    For parameters that drifted during integration. Rejects only what
    cannot be normalized (zero norm, non-finite entries).

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Euler parameters (theta0, theta1, theta2, theta3), scalar first, of
        any non-zero norm.

    Returns
    -------
    p_unit : ndarray, shape (..., 4)
        ``p / ||p||``.
    """
    arr = as_float_array(p, "p")
    if arr.shape == (4,):
        w, x, y, z = arr.tolist()
        m = max(abs(w), abs(x), abs(y), abs(z))
        # Not zero, no NaN or infinity (a finite sum that overflows only
        # sends huge parameters to the batched path).
        if m > 0.0 and math.isfinite(w + x + y + z):
            # _scaled_norm; einsum sums the four squares pairwise.
            w, x, y, z = w / m, x / m, y / m, z / m
            norm = math.sqrt((w * w + y * y) + (x * x + z * z))
            return np.array((w / norm, x / norm, y / norm, z / norm))
    p = check_quaternion(arr, "p")
    # Scaled by the largest entry: exact for huge and tiny (non-zero) p,
    # whose squares would overflow or underflow.
    m, s, norm = _scaled_norm(p)
    zero = m == 0.0
    if zero.any():
        index = np.argwhere(zero)[0] if zero.ndim else ()
        raise ValueError(
            f"Expected `p` to have non-zero norm, got norm 0.0{_index_str(index)}"
        )
    return s / norm[..., None]


def canonical_euler_parameters(p):
    """Sign-canonical Euler parameters: ``theta0 >= 0``.

    Where theta0 is zero, the first non-zero of theta1..theta3 is made
    positive, so ``p`` and ``-p`` map to the same array.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters, scalar first.

    Returns
    -------
    p : ndarray, shape (..., 4)
    """
    arr = as_float_array(p, "p")
    if arr.shape == (4,):
        unit = _unit_p_single(*arr.tolist())
        if unit is not None:
            for c in unit:
                if c != 0.0:
                    break
            out = np.array(unit)
            return -out if c < 0.0 else out
    p = check_euler_parameters(arr, "p")
    flip = np.zeros(p.shape[:-1], dtype=bool)
    undecided = np.ones(p.shape[:-1], dtype=bool)
    for k in range(4):
        c = p[..., k]
        flip |= undecided & (c < 0.0)
        undecided &= c == 0.0
    return np.where(flip[..., None], -p, p)


def _G_from_p(p, sign):
    """3x4 matrices ``[-theta, sign * theta~ + theta0 I]``."""
    w = p[..., 0]
    x = p[..., 1]
    y = p[..., 2]
    z = p[..., 3]
    out = np.empty(p.shape[:-1] + (3, 4))
    out[..., 0, 0] = -x
    out[..., 1, 0] = -y
    out[..., 2, 0] = -z
    out[..., 0, 1] = w
    out[..., 1, 2] = w
    out[..., 2, 3] = w
    out[..., 0, 2] = -sign * z
    out[..., 0, 3] = sign * y
    out[..., 1, 1] = sign * z
    out[..., 1, 3] = -sign * x
    out[..., 2, 1] = -sign * y
    out[..., 2, 2] = sign * x
    return out


def euler_parameter_G(p):
    """Matrix G of Euler parameters (Eqs. 8.51-8.54): ``omega = 2 G p_dot``.

    .. math:: G = [-\\theta, \\; \\tilde\\theta + \\theta_0 I]

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.

    Returns
    -------
    G : ndarray, shape (..., 3, 4)
        Maps parameter rates to half the angular velocity in the global
        frame. Identities (Eqs. 8.55-8.56): ``G p = 0``, ``G G.T = I``,
        ``G.T G = I4 - p p.T``, ``A = G G_bar.T``.
    """
    return _G_from_p(check_euler_parameters(p, "p"), 1.0)


def euler_parameter_G_bar(p):
    """Matrix G_bar of Euler parameters (Eqs. 8.51-8.54): ``omega_body = 2 G_bar p_dot``.

    .. math:: \\bar G = [-\\theta, \\; -\\tilde\\theta + \\theta_0 I]

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.

    Returns
    -------
    G_bar : ndarray, shape (..., 3, 4)
        Maps parameter rates to half the angular velocity in the body
        frame. Identities (Eqs. 8.55-8.56): ``G_bar p = 0``,
        ``G_bar G_bar.T = I``, ``G_bar.T G_bar = I4 - p p.T``.
    """
    return _G_from_p(check_euler_parameters(p, "p"), -1.0)


def _p_and_vec(p, v, vname, size):
    p = check_euler_parameters(p, "p")
    v = check_vector(v, vname, size)
    (p, v), _ = broadcast_batch(("p", p, 1), (vname, v, 1))
    return p, v


def euler_parameter_rates(p, omega_body):
    """Euler parameter rates from the body angular velocity (Eqs. 8.51-8.54).

    ``p_dot = G_bar.T @ omega_body / 2``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    omega_body : array_like, shape (..., 3)
        Angular velocity in the body frame (the chapter's omega-bar), rad/s.

    Returns
    -------
    p_dot : ndarray, shape (..., 4)
        Time derivative of the Euler parameters; ``p . p_dot = 0``.
    """
    p, w = _p_and_vec(p, omega_body, "omega_body", 3)
    return 0.5 * np.einsum("...ji,...j->...i", _G_from_p(p, -1.0), w)


def euler_parameter_rates_from_omega(p, omega):
    """Euler parameter rates from the global angular velocity (Eqs. 8.51-8.54).

    ``p_dot = G.T @ omega / 2``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    omega : array_like, shape (..., 3)
        Angular velocity in the global frame, rad/s.

    Returns
    -------
    p_dot : ndarray, shape (..., 4)
    """
    p, w = _p_and_vec(p, omega, "omega", 3)
    return 0.5 * np.einsum("...ji,...j->...i", _G_from_p(p, 1.0), w)


def omega_from_euler_parameter_rates(p, p_dot):
    """Global angular velocity from Euler parameter rates (Eqs. 8.51-8.54).

    ``omega = 2 G @ p_dot``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    p_dot : array_like, shape (..., 4)
        Their time derivative.

    Returns
    -------
    omega : ndarray, shape (..., 3)
        Angular velocity in the global frame.
    """
    p, pd = _p_and_vec(p, p_dot, "p_dot", 4)
    return 2.0 * np.einsum("...ij,...j->...i", _G_from_p(p, 1.0), pd)


def omega_body_from_euler_parameter_rates(p, p_dot):
    """Body angular velocity from Euler parameter rates (Eqs. 8.51-8.54).

    ``omega_body = 2 G_bar @ p_dot``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters (theta0, theta1, theta2, theta3), scalar first.
    p_dot : array_like, shape (..., 4)
        Their time derivative.

    Returns
    -------
    omega_body : ndarray, shape (..., 3)
        Angular velocity in the body frame (omega-bar).
    """
    p, pd = _p_and_vec(p, p_dot, "p_dot", 4)
    return 2.0 * np.einsum("...ij,...j->...i", _G_from_p(p, -1.0), pd)


def alpha_from_euler_parameters(p, p_ddot):
    """Global angular acceleration from Euler parameters (Eq. 8.57).

    ``alpha = 2 G @ p_ddot`` (the term ``2 G_dot @ p_dot`` vanishes
    identically).

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters, scalar first.
    p_ddot : array_like, shape (..., 4)
        Their second time derivative.

    Returns
    -------
    alpha : ndarray, shape (..., 3)
        Angular acceleration in the global frame.
    """
    p, pdd = _p_and_vec(p, p_ddot, "p_ddot", 4)
    return 2.0 * np.einsum("...ij,...j->...i", _G_from_p(p, 1.0), pdd)


def alpha_body_from_euler_parameters(p, p_ddot):
    """Body angular acceleration from Euler parameters (Eq. 8.57).

    ``alpha_body = 2 G_bar @ p_ddot`` (``G_bar_dot @ p_dot`` vanishes).

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters, scalar first.
    p_ddot : array_like, shape (..., 4)
        Their second time derivative.

    Returns
    -------
    alpha_body : ndarray, shape (..., 3)
        Angular acceleration in the body frame.
    """
    p, pdd = _p_and_vec(p, p_ddot, "p_ddot", 4)
    return 2.0 * np.einsum("...ij,...j->...i", _G_from_p(p, -1.0), pdd)


def euler_parameter_accelerations(p, omega_body, alpha_body):
    """Second derivative of Euler parameters (Eq. 8.57 solved for p_ddot).

    ``p_ddot = G_bar.T @ alpha_body / 2 - |omega_body|**2 p / 4``, the
    unique solution of ``alpha_body = 2 G_bar p_ddot`` consistent with the
    second derivative of the unit-norm constraint ``p . p = 1``.

    Parameters
    ----------
    p : array_like, shape (..., 4)
        Unit Euler parameters, scalar first.
    omega_body : array_like, shape (..., 3)
        Angular velocity in the body frame.
    alpha_body : array_like, shape (..., 3)
        Angular acceleration in the body frame.

    Returns
    -------
    p_ddot : ndarray, shape (..., 4)
    """
    p = check_euler_parameters(p, "p")
    w = check_vector(omega_body, "omega_body", 3)
    a = check_vector(alpha_body, "alpha_body", 3)
    (p, w, a), _ = broadcast_batch(
        ("p", p, 1), ("omega_body", w, 1), ("alpha_body", a, 1)
    )
    w2 = np.einsum("...i,...i->...", w, w)
    Gb = _G_from_p(p, -1.0)
    return 0.5 * np.einsum("...ji,...j->...i", Gb, a) - 0.25 * w2[..., None] * p
