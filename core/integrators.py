"""Time steppers with one interface, and a per-run report of invariant drift.

Every method integrates a *model*: any object with

``state_size : int``
    Length ``m`` of the flat state vector.
``rhs(t, state) -> state_dot``
    The first-order equations, ``(m,) -> (m,)``; must not mutate ``state``.
``invariants(states) -> dict[str, ndarray]`` (optional)
    Quantities that the exact flow conserves (or that the user wants
    watched), vectorized over leading axes: ``(..., m) -> (..., k)`` or
    ``(...,)``. Their drift is reported for each run and a blow-up stops
    the run with :class:`DivergenceError`.
``conserves_invariants : bool`` (optional, default True)
    False when the invariants are only watched (e.g. a body under applied
    loads): their drift is still reported but does not stop the run.
``split_flows``, ``to_split_state(state)``, ``from_split_state(z)`` (optional)
    For the splitting methods only: a tuple of exact flows
    ``flow(z, h) -> z`` of the pieces of a split Hamiltonian, acting on an
    internal state ``z`` (see :class:`rigidlab.core.rigid_body.FreeBodyModel`).
``split_run(z, h, gammas, n_steps) -> z`` (optional)
    A fast equivalent of ``n_steps`` steps of the composition of Strang
    steps with stage weights ``gammas``; :func:`integrate` uses it between
    recorded states when present.
``project(t, state) -> state`` (optional)
    A map back onto the model's invariant manifold (e.g. the constraints
    of :mod:`rigidlab.core.multibody`), applied by :func:`integrate` after every
    step (not to ``state0``): after each ``rk4`` or ``midpoint`` step;
    for ``RK45`` and ``DOP853`` after each accepted step of scipy's
    solver, which then continues from the projected state (its stored
    derivative is re-evaluated there unless the projection moved the
    state by less than 1e-3 of the error tolerance ``atol + rtol |y|``,
    where the stale derivative changes the next step by far less than the
    local error), and to every dense-output state at ``t_eval``. The
    splitting methods and ``LSODA`` (which keep internal state that a
    projection would invalidate) refuse a model with ``project``.
``euler_parameter_slice : slice`` (optional)
    Where the model's state holds Euler parameters (e.g. ``slice(3, 7)``
    for :class:`rigidlab.core.rigid_body.EulerParameterModel`): :func:`integrate`
    refuses a ``state0`` whose parameters there have norm 0 or differ from
    1 by ``max_drift`` or more (a run stops as diverged once ``|p|`` has
    moved that far), so a norm 0 or 2 is an error, not a silent run; a
    smaller drift, what a previous run ended in, is continued as it is.
``stop_time(t0, y0, t1, y1, dense) -> float | None`` (optional)
    An event check after every (projected) step of ``rk4``, ``midpoint``,
    ``RK45`` and ``DOP853``: ``dense(t)`` gives the (projected) state at a
    time within the step (scipy's dense output; for the fixed-step methods
    one step of the method from ``y0``). When it returns a time ``te`` in
    ``[t0, t1]`` the run ends there: states are recorded up to ``te``
    only, and :class:`Trajectory` reports ``stop_time = te`` and
    ``stop_state = dense(te)`` (e.g. a contact of :mod:`rigidlab.core.multibody`
    whose normal force crosses zero).

Single steps are pure functions ``step(model, state, dt, *, t=0.0) -> state``
(:func:`rk4_step`, :func:`implicit_midpoint_step`, :func:`splitting_step`,
:func:`splitting4_step`, :func:`splitting6_step`, :func:`splitting8_step`);
inputs are never mutated.
:func:`integrate` runs any method (fixed step or scipy's adaptive
``solve_ivp``) and returns a frozen :class:`Trajectory` with a
:class:`DriftReport`.

Every step function and :func:`integrate` validate their inputs: the state
must be a finite real vector (complex input is refused, not cast), ``dt`` a
finite number > 0 and ``t`` a finite real number; a :class:`ValueError`
names the argument. An adaptive run stops with :class:`DivergenceError`
at the first non-finite derivative ``model.rhs`` returns (naming its time).
A run is limited to :data:`MAX_STEPS` steps (fixed-step
methods, checked before the run starts) or right-hand-side evaluations
(adaptive methods, checked as they are made): a step of 1e-12 s over 1000 s
is refused at once instead of filling memory for hours, and an adaptive
run whose pace after :data:`PACE_CHECK_CALLS` evaluations (or any doubling
of them) needs more than :data:`PACE_MARGIN` times the limit stops then.
``integrate(..., max_steps=n)`` raises the limit. ``rtol`` is at least
:data:`MIN_RTOL` (100 machine epsilons).

Methods (``integrate(..., method=name)``):

============== ====== ===================================================
name           order  notes
============== ====== ===================================================
``rk4``        4      classical Runge-Kutta, explicit, 4 rhs calls/step
``midpoint``   2      implicit midpoint; symplectic, conserves every
                      quadratic invariant (``|p|``, energy, ``|L|`` of a
                      free body) to the iteration tolerance
``splitting``  2      Strang splitting into exact flows (planar
                      rotations for the free body); symplectic, keeps
                      ``|p| = 1`` to round-off with no renormalization
``splitting4`` 4      Suzuki's 5-stage composition of ``splitting``
``splitting6`` 6      Kahan & Li's 9-stage composition of ``splitting``
``splitting8`` 8      Kahan & Li's 15-stage composition of ``splitting``
``RK45``       5(4)   scipy ``solve_ivp``, adaptive (``rtol``, ``atol``)
``DOP853``     8(5,3) scipy ``solve_ivp``, adaptive
``LSODA``      1-12   scipy ``solve_ivp``, adaptive stiff/non-stiff switch
============== ====== ===================================================
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from rigidlab.core._constants import DEFAULT_ATOL, DEFAULT_RTOL
from rigidlab.core._validation import float_array, positive_integer, real_number, short_repr

__all__ = [
    "ADAPTIVE_METHODS",
    "DEFAULT_ATOL",
    "DEFAULT_RTOL",
    "FIXED_STEP_METHODS",
    "MAX_STEPS",
    "METHOD_ORDERS",
    "MIN_RTOL",
    "DivergenceError",
    "DriftReport",
    "IntegrationError",
    "Trajectory",
    "drift_report",
    "implicit_midpoint_step",
    "integrate",
    "rk4_step",
    "splitting4_step",
    "splitting6_step",
    "splitting8_step",
    "splitting_step",
]


#: Largest number of steps of a fixed-step run (and of right-hand-side
#: evaluations of an adaptive run) that :func:`integrate` takes without being
#: asked for more with ``max_steps``. Ten million steps of a 7-state model
#: record 0.5 GB of states (``save_every=1``) and take minutes with the
#: pure-Python steppers; a run that needs more is almost always a mistake in
#: ``dt`` or ``t_span``.
MAX_STEPS = 10_000_000

#: Smallest relative tolerance ``rtol`` of the adaptive methods: 100 machine
#: epsilons (2.2e-14), below which scipy's ``RK45``, ``DOP853`` and ``LSODA``
#: would raise it to this value anyway (with a warning) while a run that asked
#: for less accuracy than round-off allows crawls through a long span.
MIN_RTOL = 100.0 * float(np.finfo(float).eps)


#: What a failed run's exception carries within its process (see :func:`attach_partial`): left out when the
#: exception is pickled (a worker process hands it to the app): a trajectory holds its System, which holds locks.
RUN_ATTRIBUTES = ("partial", "trajectory")


class RunFailure(Exception):
    """Mixin of the exceptions a run raises when it cannot go on (:class:`IntegrationError`,
    ``rigidlab.core.contact.ContactError``): they carry the outputs before the failure (``partial``, ``trajectory``)
    and pickle without them."""

    def __reduce__(self):
        state = {k: v for k, v in self.__dict__.items() if k not in RUN_ATTRIBUTES}
        return (_rebuild, (type(self), self.args, state))


def _rebuild(cls: type, args: tuple, state: dict) -> BaseException:
    exc = cls.__new__(cls, *args)
    exc.args = args
    exc.__dict__.update(state)
    return exc


class IntegrationError(RunFailure, ValueError):
    """A run could not continue; ``step`` and ``t`` say where it stopped."""

    def __init__(self, message: str, *, step: int | None = None, t: float | None = None):
        super().__init__(message)
        self.step = step
        self.t = t


class DivergenceError(IntegrationError):
    """The state became non-finite or an invariant blew up."""


# ---------------------------------------------------------------- results
@dataclass(frozen=True)
class DriftReport:
    """Drift of each invariant over the recorded times of one run.

    Attributes
    ----------
    initial : mapping name -> (k,) or () array
        Value at the first recorded state.
    max_abs : mapping name -> float
        ``max_t |I(t) - I(t0)|`` (Euclidean norm for vector invariants).
    max_rel : mapping name -> float
        ``max_abs / |I(t0)|`` (``inf`` when ``I(t0) = 0`` and it moved).
    final_abs : mapping name -> float
        ``|I(t_end) - I(t0)|``.
    """

    initial: Mapping[str, np.ndarray] = field(default_factory=dict)
    max_abs: Mapping[str, float] = field(default_factory=dict)
    max_rel: Mapping[str, float] = field(default_factory=dict)
    final_abs: Mapping[str, float] = field(default_factory=dict)

    def __str__(self) -> str:
        lines = [f"{'invariant':<28}{'max |dI|':>12}{'max |dI|/|I0|':>15}"]
        for name in self.max_abs:
            lines.append(f"{name:<28}{self.max_abs[name]:>12.3e}{self.max_rel[name]:>15.3e}")
        return "\n".join(lines)


@dataclass(frozen=True)
class Trajectory:
    """Result of :func:`integrate` (read-only arrays).

    Attributes
    ----------
    t : (n,) recorded times.
    states : (n, m) recorded states, ``states[i]`` at ``t[i]``.
    method : name of the method.
    n_steps : accepted steps taken.
    n_rhs : right-hand-side evaluations (0 for splitting methods, which call
        exact flows instead).
    drift : :class:`DriftReport` of the model's invariants (empty when the
        model has none).
    stop_time : float or None
        The time at which the model's ``stop_time`` check ended the run
        (None: the run reached ``t1``).
    stop_state : (m,) or None
        The state at ``stop_time``.
    """

    t: np.ndarray  # (n,)
    states: np.ndarray  # (n, m)
    method: str
    n_steps: int
    n_rhs: int
    drift: DriftReport
    stop_time: float | None = None
    stop_state: np.ndarray | None = None  # (m,)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def drift_report(model: Any, states: np.ndarray) -> DriftReport:
    """Drift of ``model.invariants`` along ``states`` (n, m); empty if none."""
    inv = getattr(model, "invariants", None)
    if inv is None:
        return DriftReport()
    states = float_array(states, "states", expected="an (n, m) array of states")
    values = inv(states)
    initial, max_abs, max_rel, final_abs = {}, {}, {}, {}
    for name, val in values.items():
        val = np.asarray(val, dtype=float).reshape(len(states), -1)
        d = np.linalg.norm(val - val[0], axis=-1)
        ref = float(np.linalg.norm(val[0]))
        m = float(d.max()) if d.size else 0.0
        initial[name] = val[0].copy() if val.shape[1] > 1 else np.float64(val[0, 0])
        max_abs[name] = m
        max_rel[name] = m / ref if ref > 0 else (0.0 if m == 0 else math.inf)
        final_abs[name] = float(d[-1]) if d.size else 0.0
    return DriftReport(initial, max_abs, max_rel, final_abs)


# ---------------------------------------------------------------- steps
def _check_step(model: Any, state: Any, dt: Any, t: Any) -> tuple[np.ndarray, float, float]:
    """Validated ``(state, dt, t)`` of a public step function.

    ``state`` must be a finite real (m,) vector (m = ``model.state_size``
    when the model states it), ``dt`` a finite number > 0 and ``t`` a
    finite real number.
    """
    y = float_array(state, "state", expected="an (m,) state vector of real numbers")
    size = getattr(model, "state_size", None)
    if y.ndim != 1 or (size is not None and y.shape != (int(size),)):
        want = f"({int(size)},)" if size is not None else "(m,)"
        raise ValueError(f"state: expected shape {want}, got {y.shape}")
    finite = np.isfinite(y)
    if not finite.all():
        i = int(np.argmin(finite))
        raise ValueError(f"state: expected finite values, got {float(y[i])!r} at index {i}")
    dt = real_number(dt, "dt", expected="a finite step dt > 0")
    if not dt > 0.0:
        raise ValueError(f"dt: expected a finite step dt > 0, got {dt!r}")
    t = real_number(t, "t", expected="a finite time")
    return y, dt, t


def rk4_step(model: Any, state: np.ndarray, dt: float, *, t: float = 0.0) -> np.ndarray:
    """One step of the classical fourth-order Runge-Kutta method.

    Parameters
    ----------
    model : object with ``rhs(t, state) -> (m,)``.
    state : (m,) finite real state at time ``t`` (not modified).
    dt : finite step size > 0.
    t : finite time of ``state`` (keyword).

    Returns
    -------
    (m,) state at ``t + dt``.

    Raises
    ------
    ValueError
        For a non-finite, complex or wrongly shaped ``state``, or a ``dt``
        that is not a finite number > 0 (NaN, infinity, zero, negative).
    """
    y, dt, t = _check_step(model, state, dt, t)
    return _rk4(model, y, dt, t)


def _rk4(model: Any, y: np.ndarray, dt: float, t: float) -> np.ndarray:
    """:func:`rk4_step` without validation (the loop of :func:`integrate`)."""
    f = model.rhs
    k1 = f(t, y)
    k2 = f(t + 0.5 * dt, y + (0.5 * dt) * k1)
    k3 = f(t + 0.5 * dt, y + (0.5 * dt) * k2)
    k4 = f(t + dt, y + dt * k3)
    return y + (dt / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def implicit_midpoint_step(
    model: Any,
    state: np.ndarray,
    dt: float,
    *,
    t: float = 0.0,
    tol: float = 4e-16,
    max_iter: int = 100,
) -> np.ndarray:
    """One step of the implicit midpoint rule ``y1 = y0 + dt f(t + dt/2, (y0 + y1)/2)``.

    Symplectic and symmetric, order 2; conserves every quadratic invariant
    of the model exactly (up to the fixed-point tolerance). For the rigid
    body in Euler parameters, ``p_dot = G_bar(p).T omega_body / 2``
    (Eq. 8.54) is linear and skew in ``p``, so ``|p|`` is such an invariant,
    as are the kinetic energy and ``|L|`` of a free body.

    The nonlinear equation is solved by fixed-point iteration started from
    an explicit Euler predictor, until the update is below
    ``tol * (1 + |y|)`` (or stops decreasing at round-off).

    Parameters
    ----------
    model : object with ``rhs(t, state) -> (m,)``.
    state : (m,) finite real state at time ``t`` (not modified).
    dt : finite step size > 0.
    t : finite time of ``state`` (keyword).
    tol : finite relative tolerance >= 0 of the fixed-point iteration
        (keyword; 0 iterates until the update stops decreasing).
    max_iter : largest number of fixed-point iterations, an integer >= 1
        (keyword).

    Returns
    -------
    (m,) state at ``t + dt``.

    Raises
    ------
    ValueError
        For a bad ``state``, ``dt``, ``t``, ``tol`` or ``max_iter``.
    IntegrationError
        If the iteration does not converge in ``max_iter`` iterations (the
        step is too large for the problem's stiffness).
    """
    y0, dt, t = _check_step(model, state, dt, t)
    tol = real_number(tol, "tol", expected="a finite tolerance >= 0")
    if tol < 0.0:
        raise ValueError(f"tol: expected a finite tolerance >= 0, got {tol!r}")
    max_iter = positive_integer(max_iter, "max_iter")
    return _midpoint(model, y0, dt, t, tol, max_iter)


def _midpoint(
    model: Any, y0: np.ndarray, dt: float, t: float, tol: float = 4e-16, max_iter: int = 100
) -> np.ndarray:
    """:func:`implicit_midpoint_step` without validation."""
    th = t + 0.5 * dt
    f = model.rhs
    y1 = y0 + dt * f(th, y0)
    scale = 1.0 + float(np.max(np.abs(y0)))
    prev = math.inf
    for _ in range(max_iter):
        y_new = y0 + dt * f(th, 0.5 * (y0 + y1))
        delta = float(np.max(np.abs(y_new - y1)))
        y1 = y_new
        if delta <= tol * scale or (delta <= 1e-12 * scale and delta >= prev):
            return y1
        prev = delta
    raise IntegrationError(
        f"implicit midpoint: fixed-point iteration did not converge in {max_iter} "
        f"iterations at t={t:.6g} with dt={dt:.3g} (last update {delta:.3e}); "
        "reduce dt",
        t=t,
    )


def _require_split(model: Any, method: str) -> None:
    if not all(hasattr(model, a) for a in ("split_flows", "to_split_state", "from_split_state")):
        raise ValueError(
            f"method '{method}' needs a model with split_flows, to_split_state and "
            f"from_split_state (e.g. core.rigid_body.FreeBodyModel); got {type(model).__name__}"
        )


def _strang(flows: tuple[Callable[[Any, float], Any], ...], z: Any, h: float) -> Any:
    """Symmetric (Strang) composition f1(h/2) ... f_{n-1}(h/2) f_n(h) f_{n-1}(h/2) ... f1(h/2)."""
    *outer, last = flows
    half = 0.5 * h
    for fl in outer:
        z = fl(z, half)
    z = last(z, h)
    for fl in reversed(outer):
        z = fl(z, half)
    return z


# Suzuki's fourth-order 5-stage composition (p, p, 1 - 4p, p, p).
_P4 = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))
_SUZUKI4 = (_P4, _P4, 1.0 - 4.0 * _P4, _P4, _P4)


def _symmetric(half: tuple[float, ...]) -> tuple[float, ...]:
    """Stage weights (w1..wk, w_mid, wk..w1) with w_mid = 1 - 2 sum(w)."""
    return (*half, 1.0 - 2.0 * sum(half), *reversed(half))


# Kahan & Li (Math. Comp. 66, 1997): sixth order with 9 stages (s9odr6a) and
# eighth order with 15 stages (s15odr8), symmetric compositions of Strang steps.
_KAHAN_LI6 = _symmetric((0.39216144400731413928, 0.33259913678935943860, -0.70624617255763935981,
                         0.082213596293550800230))
_KAHAN_LI8 = _symmetric((0.74167036435061295345, -0.40910082580003159400, 0.19075471029623837995,
                         -0.57386247111608226666, 0.29906418130365592384, 0.33462491824529818378,
                         0.31529309239676659663))
_COMPOSITIONS = {"splitting": (1.0,), "splitting4": _SUZUKI4, "splitting6": _KAHAN_LI6, "splitting8": _KAHAN_LI8}


def _split_advance(model: Any, z: Any, h: float, gammas: tuple[float, ...]) -> Any:
    flows = model.split_flows
    for g in gammas:
        z = _strang(flows, z, g * h)
    return z


def splitting_step(model: Any, state: np.ndarray, dt: float, *, t: float = 0.0) -> np.ndarray:
    """One Strang-splitting step (order 2) built from the model's exact flows.

    For the free rigid body (:class:`rigidlab.core.rigid_body.FreeBodyModel`) the
    flows are exact rotations, so the Euler-parameter norm stays 1 to
    round-off and the method is symplectic. ``t`` is accepted for the common
    interface; split models are autonomous. ``state``, ``dt`` and ``t`` are
    validated as in :func:`rk4_step`.
    """
    _require_split(model, "splitting")
    y, dt, t = _check_step(model, state, dt, t)
    z = model.to_split_state(y)
    return model.from_split_state(_split_advance(model, z, dt, _COMPOSITIONS["splitting"]))


def splitting4_step(model: Any, state: np.ndarray, dt: float, *, t: float = 0.0) -> np.ndarray:
    """Fourth-order step: Suzuki's composition of five Strang steps."""
    _require_split(model, "splitting4")
    y, dt, t = _check_step(model, state, dt, t)
    z = model.to_split_state(y)
    return model.from_split_state(_split_advance(model, z, dt, _SUZUKI4))


def splitting6_step(model: Any, state: np.ndarray, dt: float, *, t: float = 0.0) -> np.ndarray:
    """Sixth-order step: Kahan & Li's composition of nine Strang steps (s9odr6a)."""
    _require_split(model, "splitting6")
    y, dt, t = _check_step(model, state, dt, t)
    z = model.to_split_state(y)
    return model.from_split_state(_split_advance(model, z, dt, _KAHAN_LI6))


def splitting8_step(model: Any, state: np.ndarray, dt: float, *, t: float = 0.0) -> np.ndarray:
    """Eighth-order step: Kahan & Li's composition of fifteen Strang steps (s15odr8)."""
    _require_split(model, "splitting8")
    y, dt, t = _check_step(model, state, dt, t)
    z = model.to_split_state(y)
    return model.from_split_state(_split_advance(model, z, dt, _KAHAN_LI8))


# The loop of integrate() validates once and then calls these, which skip
# the per-step validation of the public step functions.
_STEPPERS: Mapping[str, Callable[[Any, np.ndarray, float, float], np.ndarray]] = {
    "rk4": _rk4,
    "midpoint": _midpoint,
}

FIXED_STEP_METHODS: Mapping[str, Callable[..., np.ndarray]] = {
    "rk4": rk4_step,
    "midpoint": implicit_midpoint_step,
    "splitting": splitting_step,
    "splitting4": splitting4_step,
    "splitting6": splitting6_step,
    "splitting8": splitting8_step,
}
ADAPTIVE_METHODS: tuple[str, ...] = ("RK45", "DOP853", "LSODA")
METHOD_ORDERS: Mapping[str, int] = {
    "rk4": 4,
    "midpoint": 2,
    "splitting": 2,
    "splitting4": 4,
    "splitting6": 6,
    "splitting8": 8,
    "RK45": 5,
    "DOP853": 8,
}


# ---------------------------------------------------------------- runs
class _BudgetExceeded(IntegrationError):
    """Raised inside a solver's rhs call when a run used up its budget of ``max_calls`` evaluations, or
    (``projected``: the evaluations the whole run needs at its pace so far, after ``calls`` for the fraction
    ``done`` of its span) cannot end within it. The runners turn it into the error of :func:`_budget_error`
    (naming the method); one raised where no runner catches it (a compiled loop calling
    ``_CountingModel._warn_long``) is an :class:`IntegrationError` with a message of its own."""

    def __init__(self, t: float, *, projected: float | None = None, calls: int = 0, done: float = 0.0,
                 t1: float = math.nan, max_calls: float = math.inf):
        if projected is None:
            message = f"the run stopped at t={t:.6g}: it used its budget of right-hand-side evaluations"
        else:
            message = (f"the run stopped at t={t:.6g} before t1={t1:g}: at its pace so far ({calls:,} right-hand-side "
                       f"evaluations for {100.0 * done:.3g} % of the time span) it needs about {projected:.3g}, more "
                       f"than {PACE_MARGIN:g} x max_steps={max_calls:.0f} (core.integrators.MAX_STEPS = {MAX_STEPS}); "
                       "shorten the time span, loosen rtol/atol, or pass a larger max_steps")
        super().__init__(message, t=t)
        self.projected = projected
        self.calls = calls
        self.done = done


#: An adaptive run looks at its pace after this many right-hand sides and again at every doubling of the
#: count: when, at the pace so far, it needs more than ``PACE_MARGIN`` times its ``max_steps`` to reach its end
#: (a horizon of 1e300 s, tolerances at round-off over a long span, a stiff force), it stops with
#: :class:`IntegrationError` then, not after ``max_steps`` evaluations (ten million: up to hours for a
#: multibody model at 0.04-1 ms each).
PACE_CHECK_CALLS = 10_000
#: See :data:`PACE_CHECK_CALLS`: the slack granted to a run whose pace may still improve (steps that grow after
#: a transient).
PACE_MARGIN = 2.0


#: An adaptive run warns (RuntimeWarning, once) when it has used this many right-hand sides and, at the pace
#: it went so far, would need ten times as many to reach its end: a stiff or runaway model that ``max_steps``
#: (ten million) would stop only after most of an hour.
LONG_RUN_CALLS = 1_000_000


class _CountingModel:
    """Wraps a model to count rhs calls, optionally at most ``max_calls`` (internal); ``span``: the run's
    ``(t0, t1)``, for the warning of :data:`LONG_RUN_CALLS`; ``finite``: raise :class:`DivergenceError` for a
    non-finite derivative (the adaptive methods: scipy's step control does not stop on NaN, see
    :func:`_check_derivative`)."""

    def __init__(self, model: Any, max_calls: float = math.inf, span: tuple[float, float] | None = None, *,
                 finite: bool = False):
        self._model = model
        self.calls = 0
        self._max_calls = max_calls
        self._span = span
        self._finite = finite

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        self.calls += 1
        if self.calls > self._max_calls:
            raise _BudgetExceeded(float(t))
        if self._span is not None:
            if self.calls == LONG_RUN_CALLS:
                self._warn_long(float(t))
            if self.calls % PACE_CHECK_CALLS == 0 and self._max_calls < math.inf:
                k = self.calls // PACE_CHECK_CALLS
                if k & (k - 1) == 0:  # at PACE_CHECK_CALLS times a power of two
                    self._check_pace(float(t))
        f = self._model.rhs(t, y)
        if self._finite:
            _check_derivative(t, y, f)
        return f

    def _check_pace(self, t: float, calls: int | None = None) -> None:
        """Raise :class:`_BudgetExceeded` when the run, at its pace so far (``calls`` evaluations to reach
        ``t``, default the count of this wrapper), cannot end within its budget."""
        calls = self.calls if calls is None else calls
        t0, t1 = self._span
        done = (t - t0) / (t1 - t0) if t1 != t0 else 1.0
        projected = calls / done if done > 0.0 else math.inf
        if not projected <= PACE_MARGIN * self._max_calls:
            raise _BudgetExceeded(t, projected=projected, calls=calls, done=done, t1=t1, max_calls=self._max_calls)

    def _warn_long(self, t: float) -> None:
        """At :data:`LONG_RUN_CALLS` evaluations: warn of a run that needs ten times as many, and stop one that
        cannot end within its budget (:meth:`_check_pace`; compiled loops call this too)."""
        t0, t1 = self._span
        done = (t - t0) / (t1 - t0) if t1 != t0 else 1.0
        if done > 0.1:
            return
        self._warn_long_message(t, done)
        if self._max_calls < math.inf:
            try:
                self._check_pace(t, LONG_RUN_CALLS)
            except _BudgetExceeded as exc:  # (a plain IntegrationError where no runner names the method)
                raise IntegrationError(str(exc), t=exc.t) from None

    def _warn_long_message(self, t: float, done: float) -> None:
        t1 = self._span[1]
        need = f"about {LONG_RUN_CALLS / done:.1e}" if done > 0.0 else "far more"
        warnings.warn(
            f"this run has used {LONG_RUN_CALLS:,} right-hand sides to reach t={t:.6g} of t1={t1:g} "
            f"({100.0 * done:.2g} %): at that pace it needs {need} in all (max_steps stops it at "
            f"{self._max_calls:,.0f}); a stiff force or a runaway motion? Shorten the time span, loosen rtol, "
            "or pass a smaller max_steps", RuntimeWarning, stacklevel=2)


def _check_derivative(t: float, y: np.ndarray, f: Any) -> None:
    """Raise :class:`DivergenceError` when a right-hand side ``f`` (at time ``t``, state ``y``) is not finite.

    scipy's adaptive steppers do not stop on it: a NaN error estimate rejects
    the step and shrinks it until the step is below the spacing of floats (an
    ``IntegrationError`` far from the cause), and a NaN derivative at the
    start gives a NaN first step, after which ``DOP853`` and ``RK45`` loop
    without end at ``t = nan``.
    """
    with np.errstate(invalid="ignore"):
        ok = bool(np.all(np.isfinite(f)))
    if ok:
        return
    t = float(t)
    where = "a non-finite state" if not np.all(np.isfinite(y)) else "a finite state"
    raise DivergenceError(
        f"run diverged: the model's right-hand side returned a non-finite derivative at t={t:.6g} (at {where}); "
        "a force or a motion law that is not finite there, or a run that blew up: reduce the time span or "
        "tighten the tolerances",
        t=t,
    )


def _check_finite_and_drift(
    model: Any, y: np.ndarray, inv0: dict[str, np.ndarray] | None, max_drift: float, step: int, t: float
) -> None:
    if not np.all(np.isfinite(y)):
        raise DivergenceError(
            f"run diverged: non-finite state at step {step} (t={t:.6g}); reduce the step "
            "or tighten the tolerances",
            step=step,
            t=t,
        )
    if inv0 is None:
        return
    with np.errstate(over="ignore", invalid="ignore"):  # a blown-up run may overflow here
        now = model.invariants(y[None, :])
    for name, v0 in inv0.items():
        v = np.asarray(now[name], dtype=float).reshape(-1)
        ref = float(np.linalg.norm(v0))
        with np.errstate(over="ignore", invalid="ignore"):
            d = float(np.linalg.norm(v - v0))
        if not math.isfinite(d) or d > max_drift * max(ref, 1e-300):
            raise DivergenceError(
                f"run diverged: invariant '{name}' drifted by {d:.3e} (relative "
                f"{d / max(ref, 1e-300):.3e} > max_drift={max_drift:g}) at step {step} "
                f"(t={t:.6g}); reduce the step or tighten the tolerances",
                step=step,
                t=t,
            )


def _check_saved_drift(
    model: Any, out: np.ndarray, inv0: dict[str, np.ndarray], max_drift: float, save_idx: list[int], t0: float,
    h: float,
) -> None:
    with np.errstate(over="ignore", invalid="ignore"):  # a blown-up run may overflow here
        vals = model.invariants(out)
        dists = {
            name: np.linalg.norm(np.asarray(vals[name], dtype=float).reshape(len(out), -1) - v0, axis=-1)
            for name, v0 in inv0.items()
        }
    for name, v0 in inv0.items():
        d = np.where(np.isfinite(dists[name]), dists[name], np.inf)
        lim = max_drift * max(float(np.linalg.norm(v0)), 1e-300)
        if np.any(d > lim):
            i = int(np.argmax(d > lim))
            k = save_idx[i]
            raise DivergenceError(
                f"run diverged: invariant '{name}' drifted by {d[i]:.3e} (relative "
                f"{d[i] / max(float(np.linalg.norm(v0)), 1e-300):.3e} > max_drift={max_drift:g}) at step {k} "
                f"(t={t0 + k * h:.6g}); reduce the step or tighten the tolerances",
                step=k,
                t=t0 + k * h,
            )


def integrate(
    model: Any,
    state0: np.ndarray,
    t_span: tuple[float, float],
    *,
    method: str = "rk4",
    dt: float | None = None,
    save_every: int = 1,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    t_eval: np.ndarray | None = None,
    max_drift: float = 1.0,
    max_steps: int = MAX_STEPS,
) -> Trajectory:
    """Integrate ``model`` from ``state0`` over ``t_span`` with one method.

    Parameters
    ----------
    model : object with ``state_size``, ``rhs(t, y)`` and optionally
        ``invariants(states)``, split flows and ``project(t, y)``, applied
        after every step (see the module docstring).
    state0 : (m,) initial state (not modified).
    t_span : (t0, t1) with t1 > t0.
    method : one of ``FIXED_STEP_METHODS`` (``rk4``, ``midpoint``,
        ``splitting``, ``splitting4``, ``splitting6``, ``splitting8``) or
        ``ADAPTIVE_METHODS`` (``RK45``, ``DOP853``, ``LSODA``).
    dt : fixed-step methods: nominal step; the run takes
        ``n = ceil((t1 - t0) / dt)`` equal steps of ``(t1 - t0) / n``.
    save_every : fixed-step methods: record every ``save_every``-th step
        (and always the first and last state).
    rtol, atol : adaptive methods: scipy's tolerances, > 0; ``rtol >=
        MIN_RTOL`` (2.2e-14).
    t_eval : adaptive methods: times to record (default: scipy's steps).
    max_drift : a run stops with :class:`DivergenceError` when an invariant
        moves by more than ``max_drift`` times its initial magnitude.
    max_steps : largest number of steps of a fixed-step run, refused before
        it starts when ``ceil((t1 - t0) / dt)`` exceeds it, and of
        right-hand-side evaluations of an adaptive run, which stops with
        :class:`IntegrationError` when it has made that many, or earlier,
        after :data:`PACE_CHECK_CALLS` (ten thousand) evaluations or any
        doubling of them, when at its pace so far it needs more than
        :data:`PACE_MARGIN` (2) times as many to reach ``t1`` (a horizon of
        1e300 s stops after ten thousand); default :data:`MAX_STEPS` (ten
        million).

    Returns
    -------
    Trajectory
        ``t`` (n,), ``states`` (n, m), step and rhs counts and the drift
        report of the model's invariants.

    Raises
    ------
    ValueError
        For an unknown method, a bad ``t_span``, ``dt``, ``rtol`` below
        :data:`MIN_RTOL`, ``state0`` (shape,
        non-finite or complex entries; Euler parameters at the model's
        ``euler_parameter_slice`` of norm 0 or off 1 by ``max_drift`` or
        more) or option that does not apply to the method, and for a
        fixed-step run of more than ``max_steps`` steps.
    DivergenceError
        When the state becomes non-finite or an invariant blows up (the
        message names the step and time), and for the adaptive methods as
        soon as ``model.rhs`` returns a non-finite derivative, at a trial
        stage too (the message names its time): scipy's step control would
        shrink the step to nothing, or loop at ``t = nan`` when it happens
        at the start.
    IntegrationError
        When scipy's solver or the implicit iteration fails, or an adaptive
        run reaches ``max_steps`` right-hand-side evaluations or shows that
        it would (see ``max_steps``).
    """
    y0 = float_array(state0, "state0", expected="an (m,) state vector of real numbers", copy=True)
    m = int(getattr(model, "state_size", y0.size))
    if y0.shape != (m,):
        raise ValueError(f"state0: expected shape ({m},), got {y0.shape}")
    if not np.all(np.isfinite(y0)):
        raise ValueError(f"state0: expected finite values, got {y0}")
    try:
        t0, t1 = t_span
    except (TypeError, ValueError):
        raise ValueError(f"t_span: expected (t0, t1), got {short_repr(t_span)}") from None
    if any(isinstance(v, (complex, np.complexfloating)) for v in (t0, t1)):
        raise ValueError(f"t_span: expected real numbers, got complex {t_span!r}")
    if not all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) for v in (t0, t1)):
        raise ValueError(f"t_span: expected (t0, t1) of real numbers, got {short_repr(t_span)}")
    t0, t1 = float(t0), float(t1)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0 and math.isfinite(t1 - t0)):
        raise ValueError(f"t_span: expected finite t0 < t1, got {t_span!r}")
    if isinstance(max_drift, (bool, np.bool_)) or not isinstance(max_drift, numbers.Real) or not max_drift > 0:
        raise ValueError(f"max_drift: expected a real number > 0 (inf: never stop), got {max_drift!r}")
    max_steps = positive_integer(max_steps, "max_steps")
    p_slice = getattr(model, "euler_parameter_slice", None)
    if p_slice is not None:
        _check_state0_euler_parameters(y0, p_slice, max_drift)
    inv0 = None
    if getattr(model, "invariants", None) is not None and getattr(model, "conserves_invariants", True):
        inv0 = {k: np.asarray(v, dtype=float).reshape(-1) for k, v in model.invariants(y0[None, :]).items()}

    if method in FIXED_STEP_METHODS:
        needs = f"dt: method '{method}' needs a finite step dt > 0"
        if dt is None:
            raise ValueError(f"{needs}, got None")
        dt = real_number(dt, "dt", expected=f"a finite step dt > 0 for method '{method}'")
        if not dt > 0:
            raise ValueError(f"{needs}, got {dt!r}")
        if t_eval is not None:
            raise ValueError(f"t_eval: applies to adaptive methods only, got it with method '{method}'")
        save_every = positive_integer(save_every, "save_every")
        steps = (t1 - t0) / dt - 1e-9  # inf when dt underflows the span
        if not steps <= max_steps:
            raise ValueError(
                f"dt: t_span ({t0:g}, {t1:g}) with dt={dt:g} needs {steps:.4g} steps, more than "
                f"max_steps={max_steps} (core.integrators.MAX_STEPS = {MAX_STEPS}); use a larger dt "
                "or a shorter t_span, or pass a larger max_steps"
            )
        n = max(1, math.ceil(steps))
        h = (t1 - t0) / n
        return _run_fixed(model, y0, t0, h, n, method, save_every, inv0, max_drift)

    if method in ADAPTIVE_METHODS:
        if dt is not None:
            raise ValueError(f"dt: adaptive method '{method}' takes rtol/atol, not dt (got dt={dt!r})")
        return _run_adaptive(model, y0, t0, t1, method, rtol, atol, t_eval, inv0, max_drift, max_steps)

    raise ValueError(
        f"method: expected one of {sorted(FIXED_STEP_METHODS) + list(ADAPTIVE_METHODS)}, got {method!r}"
    )


def _check_state0_euler_parameters(y0: np.ndarray, where: slice, max_drift: float) -> None:
    """Refuse a ``state0`` whose Euler parameters ``y0[where]`` are no orientation.

    Their norm must differ from 1 by less than ``max_drift``, the relative
    change of an invariant (``|p|`` is one for every Euler-parameter model)
    at which a run stops as diverged: norm 0 (no orientation) or 2 is
    refused with the default ``max_drift = 1``, and norm 0 with any. A
    state a previous run ended in carries that run's drift of ``|p|``
    (chained runs continue from it), which is why the unit-norm tolerance
    of user input, ``rigidlab.core.rotations.UNIT_NORM_TOL``, is not applied here.
    """
    p = y0[where]
    norm = math.sqrt(float(p @ p))
    if not (norm > 0.0 and abs(norm - 1.0) < max_drift):
        lo, hi = where.start, where.stop
        raise ValueError(
            f"state0: expected Euler parameters state0[{lo}:{hi}] of norm within max_drift={max_drift:g} of 1 "
            f"(a run stops as diverged once |p| has moved that far; a norm 0 is no orientation), got norm "
            f"{norm!r}; pack the state with core.rigid_body.euler_parameter_state or free_body_state, which "
            "normalize unit Euler parameters (within rigidlab.core.rotations.UNIT_NORM_TOL)"
        )


def _run_fixed(
    model: Any,
    y0: np.ndarray,
    t0: float,
    h: float,
    n: int,
    method: str,
    save_every: int,
    inv0: dict[str, np.ndarray] | None,
    max_drift: float,
) -> Trajectory:
    save_idx = list(range(0, n + 1, save_every))
    if save_idx[-1] != n:
        save_idx.append(n)
    out = np.empty((len(save_idx), y0.size))
    out[0] = y0
    k_out = 1
    if method.startswith("splitting"):
        _require_split(model, method)
        if getattr(model, "project", None) is not None:
            raise ValueError(
                f"method: '{method}' advances the model's exact flows and cannot apply model.project; "
                "use rk4, midpoint, RK45 or DOP853"
            )
        gammas = _COMPOSITIONS[method]
        z = model.to_split_state(y0)
        fast = getattr(model, "split_run", None)
        for k_out in range(1, len(save_idx)):
            k_prev, k = save_idx[k_out - 1], save_idx[k_out]
            if fast is not None:
                z = fast(z, h, gammas, k - k_prev)
            else:
                for _ in range(k - k_prev):
                    z = _split_advance(model, z, h, gammas)
            y = model.from_split_state(z)
            # exact flows cannot blow up an invariant; only finiteness is
            # checked here, the drift once at the end (vectorized)
            _check_finite_and_drift(model, y, None, max_drift, k, t0 + k * h)
            out[k_out] = y
        if inv0 is not None:
            _check_saved_drift(model, out, inv0, max_drift, save_idx, t0, h)
        n_rhs = 0
    else:
        counter = _CountingModel(model)
        step = _STEPPERS[method]
        project = getattr(model, "project", None)
        check = getattr(model, "stop_time", None)
        y = y0
        check_inv = inv0 if inv0 is not None else None
        for k in range(1, n + 1):
            tk = t0 + (k - 1) * h
            y_prev = y
            try:
                y = step(counter, y, h, tk)
            except IntegrationError as e:
                raise type(e)(f"step {k}: {e}", step=k, t=tk) from e
            if project is not None:
                y = project(tk + h, y)
            if check is not None:

                def dense(te, y_prev=y_prev, tk=tk):
                    if te <= tk:
                        return np.array(y_prev)
                    z = step(counter, y_prev, te - tk, tk)
                    return project(te, z) if project is not None else z

                te = check(tk, y_prev, tk + h, y, dense)
                if te is not None:
                    t_done = t0 + h * np.asarray(save_idx[:k_out], dtype=float)
                    out_done = out[:k_out]
                    return Trajectory(_frozen(t_done), _frozen(out_done), method, k, counter.calls,
                                      drift_report(model, out_done), float(te), _frozen(dense(float(te))))
            saving = k == save_idx[k_out]
            if saving:
                _check_finite_and_drift(model, y, check_inv, max_drift, k, tk + h)
                out[k_out] = y
                k_out += 1
            elif not np.isfinite(y).all():
                _check_finite_and_drift(model, y, None, max_drift, k, tk + h)
        n_rhs = counter.calls
    t = t0 + h * np.asarray(save_idx, dtype=float)
    return Trajectory(_frozen(t), _frozen(out), method, n, n_rhs, drift_report(model, out))


def _run_adaptive(
    model: Any,
    y0: np.ndarray,
    t0: float,
    t1: float,
    method: str,
    rtol: float,
    atol: float,
    t_eval: np.ndarray | None,
    inv0: dict[str, np.ndarray] | None,
    max_drift: float,
    max_steps: int = MAX_STEPS,
) -> Trajectory:
    tols = [rtol, atol]
    for k, value in enumerate(tols):
        if isinstance(value, (complex, np.complexfloating)):
            raise ValueError(f"rtol, atol: expected real numbers, got complex rtol={rtol!r}, atol={atol!r}")
        try:
            tols[k] = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"rtol, atol: expected > 0, got rtol={rtol!r}, atol={atol!r}") from None
    if not (tols[0] > 0 and tols[1] > 0):
        raise ValueError(f"rtol, atol: expected > 0, got rtol={rtol!r}, atol={atol!r}")
    if not tols[0] >= MIN_RTOL:
        raise ValueError(f"rtol: expected a relative tolerance >= core.integrators.MIN_RTOL = {MIN_RTOL:.3g} (100 "
                         f"machine epsilons: a smaller one asks for digits that round-off does not keep), got "
                         f"{rtol!r}")
    rtol, atol = tols
    if t_eval is not None:
        t_eval = float_array(t_eval, "t_eval", expected="sorted 1-D times within t_span")
        if t_eval.ndim != 1 or np.any(t_eval < t0) or np.any(t_eval > t1) or np.any(np.diff(t_eval) < 0):
            raise ValueError(f"t_eval: expected sorted 1-D times within t_span, got shape {t_eval.shape}")
    if getattr(model, "project", None) is not None or getattr(model, "stop_time", None) is not None:
        return _run_adaptive_projected(model, y0, t0, t1, method, rtol, atol, t_eval, inv0, max_drift, max_steps)
    counter = _CountingModel(model, max_calls=max_steps, span=(float(t0), float(t1)), finite=True)
    # t_eval is served from scipy's dense output (what solve_ivp itself does
    # for t_eval), so the accepted steps stay countable.
    try:
        sol = solve_ivp(
            counter.rhs, (t0, t1), y0, method=method, rtol=rtol, atol=atol, dense_output=t_eval is not None
        )
    except _BudgetExceeded as stop:
        raise _budget_error(method, stop, t1, max_steps) from None
    if not sol.success:
        tf = float(sol.t[-1]) if sol.t.size else t0
        raise IntegrationError(
            f"{method} failed at step {sol.t.size} (t={tf:.6g}): {sol.message}", step=sol.t.size, t=tf
        )
    n_steps = int(sol.t.size - 1)
    if t_eval is None:
        t_out, states = sol.t, sol.y.T
    else:
        t_out, states = t_eval, sol.sol(t_eval).T
    return _adaptive_result(model, method, t_out, states, n_steps, counter.calls, inv0, max_drift)


def _budget_error(method: str, stop: _BudgetExceeded, t1: float, max_steps: int) -> IntegrationError:
    """The error of an adaptive run that used its ``max_steps`` right-hand sides before ``t1``, or whose pace
    shows that it would (see :data:`PACE_CHECK_CALLS`)."""
    if stop.projected is not None:
        return IntegrationError(
            f"{method} stopped at t={stop.t:.6g} before t1={t1:g}: at its pace so far ({stop.calls:,} "
            f"right-hand-side evaluations for {100.0 * stop.done:.3g} % of the time span) it needs about "
            f"{stop.projected:.3g}, more than {PACE_MARGIN:g} x max_steps={max_steps} "
            f"(core.integrators.MAX_STEPS = {MAX_STEPS}); shorten t_span, loosen rtol/atol, or pass a larger "
            "max_steps",
            t=stop.t,
        )
    return IntegrationError(
        f"{method} stopped at t={stop.t:.6g} before t1={t1:g}: it used max_steps={max_steps} "
        f"right-hand-side evaluations (core.integrators.MAX_STEPS = {MAX_STEPS}); loosen rtol/atol, "
        "shorten t_span or pass a larger max_steps",
        t=stop.t,
    )


# Below this fraction of the error tolerance a projection leaves scipy's
# stored derivative f(t, y) in place (see the module docstring).
_STALE_DERIVATIVE_TOL = 1e-3


#: Retries of an adaptive step whose trial stage the model could not evaluate (see
#: :func:`_run_adaptive_projected`).
STAGE_RETRIES = 12


def _solver_state(solver: Any) -> tuple:
    """What a step of scipy's explicit Runge-Kutta solver changes (to undo it, :func:`_restore_solver_state`)."""
    K = getattr(solver, "K_extended", solver.K)
    y_old = None if solver.y_old is None else solver.y_old.copy()
    return (solver.t, solver.y.copy(), solver.f.copy(), solver.h_abs, solver.t_old, solver.h_previous, K.copy(),
            y_old)


def _restore_solver_state(solver: Any, saved: tuple, factor: float) -> None:
    """Put the solver back to ``saved`` with ``factor`` times the step size it had then."""
    t, y, f, h_abs, t_old, h_previous, K, y_old = saved
    solver.t, solver.y, solver.f, solver.t_old, solver.h_previous = t, y.copy(), f.copy(), t_old, h_previous
    solver.y_old = None if y_old is None else y_old.copy()
    solver.status = "running"  # (the undone step may have reached t_bound)
    solver.h_abs = h_abs * factor
    getattr(solver, "K_extended", solver.K)[...] = K


def attach_partial(exc: BaseException, t_rec: list, y_rec: list) -> None:
    """Keep the outputs a run had recorded when it failed with ``exc`` (a :class:`RunFailure`):
    ``exc.partial = (times, states)``, the first entry the run's start (unless an inner run attached its own
    already). Other exceptions (a user's callable that raised, say) are left as they are."""
    if isinstance(exc, RunFailure) and getattr(exc, "partial", None) is None:
        exc.partial = (list(t_rec), [np.array(y) for y in y_rec])


def _model_failure(model: Any, t: float, y: np.ndarray, exc: BaseException | None) -> BaseException | None:
    """The error to raise for a run that failed after its last accepted state ``(t, y)``: ``exc``, or what
    ``model.failure(t, y, exc)`` makes of it when the model has that hook (a mechanism at a dead point).
    ``exc`` None: the run has not failed, but its steps shrank below :data:`STALLED_STEP` of its span (an error
    or None)."""
    hook = getattr(model, "failure", None)
    return exc if hook is None else hook(t, y, exc)


#: An accepted step shorter than this fraction of the run's span asks the model whether it has stalled at a
#: singular state (``model.failure(t, y, None)``): DOP853 driven into a mechanism's dead point reached it to
#: 1e-8 s in 0.4 s of CPU, then crawled 17 s more before its step fell below the spacing of floats.
STALLED_STEP = 1e-9


def _run_adaptive_projected(
    model: Any,
    y0: np.ndarray,
    t0: float,
    t1: float,
    method: str,
    rtol: float,
    atol: float,
    t_eval: np.ndarray | None,
    inv0: dict[str, np.ndarray] | None,
    max_drift: float,
    max_steps: int,
) -> Trajectory:
    """Adaptive run that applies ``model.project`` (and ``model.stop_time``) after every accepted step."""
    from scipy.integrate import DOP853, RK45

    solvers = {"RK45": RK45, "DOP853": DOP853}
    if method not in solvers:
        raise ValueError(
            f"method: '{method}' keeps internal state that model.project would invalidate; "
            "use RK45, DOP853, rk4 or midpoint"
        )
    counter = _CountingModel(model, max_calls=max_steps, span=(float(t0), float(t1)), finite=True)
    project = getattr(model, "project", None)
    if project is None:  # stepped one accepted step at a time for the model's stop_time check

        def project(t, y):
            return y

    t_rec: list[float] = []
    y_rec: list[np.ndarray] = []
    if t_eval is None:
        t_rec.append(t0)
        y_rec.append(y0.copy())
        pending = np.zeros(0)
    else:
        first = t_eval <= t0
        for _ in range(int(first.sum())):
            t_rec.append(t0)
            y_rec.append(y0.copy())
        pending = t_eval[~first]
    k_next = 0
    n_steps = 0
    check = getattr(model, "stop_time", None)
    stopped = None
    t_prev, y_prev = t0, y0.copy()
    try:  # (a failure keeps the outputs recorded before it: attach_partial)
        try:
            solver = solvers[method](counter.rhs, t0, y0, t1, rtol=rtol, atol=atol)
            while solver.status == "running":
                # A right-hand side that raises an exception with a true ``retry_shorter`` attribute (a trial
                # stage, or a stage of the step's interpolant, that the model cannot evaluate: a contact pressed
                # in deeper than its surfaces allow, far from the accepted states) rejects the step: it is undone
                # and retried at a quarter of its size, at most STAGE_RETRIES times, after
                # ``model.stage_rejected()`` (when the model has it) dropped what it kept of the failed stages.
                # The step after a retried one starts no longer, as after a step the solver rejected itself.
                for attempt in range(STAGE_RETRIES + 1):
                    saved = _solver_state(solver)
                    try:
                        message = solver.step()
                        dense = None  # of the unprojected step (solver.y and .f are reset below)
                        if solver.status != "failed" and (
                                check is not None or (k_next < pending.size and pending[k_next] < float(solver.t))):
                            dense = solver.dense_output()
                    except Exception as exc:
                        if not getattr(exc, "retry_shorter", False) or attempt == STAGE_RETRIES:
                            raise
                        _restore_solver_state(solver, saved, 0.25)
                        forget = getattr(model, "stage_rejected", None)
                        if forget is not None:
                            forget()
                        continue
                    if attempt and solver.h_previous is not None:
                        solver.h_abs = min(solver.h_abs, abs(solver.h_previous))
                    break
                if solver.status == "failed":
                    raise _model_failure(model, t_prev, y_prev, IntegrationError(
                        f"{method} failed at step {n_steps + 1} (t={solver.t:.6g}): {message}", step=n_steps + 1,
                        t=solver.t
                    ))
                n_steps += 1
                t_new = float(solver.t)
                y_raw = solver.y
                try:
                    y_new = project(t_new, y_raw)
                except IntegrationError as exc:
                    err = _model_failure(model, t_prev, y_prev, exc)
                    if err is exc:
                        raise
                    raise err from exc
                if not np.all(np.isfinite(y_new)):
                    raise DivergenceError(
                        f"run diverged: non-finite state at step {n_steps} (t={t_new:.6g}); tighten the tolerances",
                        step=n_steps,
                        t=t_new,
                    )
                if check is not None:

                    def dense_state(te, dense=dense, t_new=t_new, y_new=y_new):
                        return np.array(y_new) if te == t_new else project(te, dense(te))

                    te = check(t_prev, y_prev, t_new, np.array(y_new), dense_state)
                    if te is not None:
                        te = float(te)
                        y_stop = dense_state(te)
                        if t_eval is None:
                            t_rec.append(te)
                            y_rec.append(np.array(y_stop))
                        while t_eval is not None and k_next < pending.size and pending[k_next] <= te:
                            tq = float(pending[k_next])
                            t_rec.append(tq)
                            y_rec.append(dense_state(tq))
                            k_next += 1
                        stopped = (te, y_stop)
                        break
                if t_new - t_prev < STALLED_STEP * abs(t1 - t0):
                    err = _model_failure(model, t_new, y_new, None)
                    if err is not None:
                        raise err
                t_prev, y_prev = t_new, np.array(y_new)  # (the last accepted state: the check's and a failure's)
                if t_eval is None:
                    t_rec.append(t_new)
                    y_rec.append(np.array(y_new))
                else:
                    while k_next < pending.size and pending[k_next] <= t_new:
                        te = float(pending[k_next])
                        t_rec.append(te)
                        y_rec.append(np.array(y_new) if te == t_new else project(te, dense(te)))
                        k_next += 1
                change = np.max(np.abs(y_new - y_raw) / (atol + rtol * np.maximum(np.abs(y_raw), np.abs(y_new))))
                if change > 0.0:
                    solver.y = np.array(y_new)
                    if change > _STALE_DERIVATIVE_TOL:
                        solver.f = solver.fun(t_new, solver.y)
        except _BudgetExceeded as stop:
            raise _budget_error(method, stop, t1, max_steps) from None
    except Exception as exc:
        attach_partial(exc, t_rec, y_rec)
        raise
    while stopped is None and t_eval is not None and len(t_rec) < t_eval.size:  # times equal to t1 after the last step
        t_rec.append(float(t_eval[len(t_rec)]))
        y_rec.append(np.array(y_rec[-1]))
    states = np.array(y_rec).reshape(len(y_rec), y0.size)
    result = _adaptive_result(model, method, np.array(t_rec), states, n_steps, counter.calls, inv0, max_drift)
    if stopped is None:
        return result
    return Trajectory(result.t, result.states, result.method, result.n_steps, result.n_rhs, result.drift,
                      stopped[0], _frozen(stopped[1]))


def _adaptive_result(
    model: Any,
    method: str,
    t_out: np.ndarray,
    states: np.ndarray,
    n_steps: int,
    n_rhs: int,
    inv0: dict[str, np.ndarray] | None,
    max_drift: float,
) -> Trajectory:
    bad = ~np.all(np.isfinite(states), axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise DivergenceError(
            f"run diverged: non-finite state at output {i} (t={t_out[i]:.6g})", step=i, t=float(t_out[i])
        )
    if inv0 is not None:
        vals = model.invariants(states)
        for name, v0 in inv0.items():
            v = np.asarray(vals[name], dtype=float).reshape(len(states), -1)
            d = np.linalg.norm(v - v0, axis=-1)
            lim = max_drift * max(float(np.linalg.norm(v0)), 1e-300)
            if np.any(d > lim):
                i = int(np.argmax(d > lim))
                raise DivergenceError(
                    f"run diverged: invariant '{name}' drifted by {d[i]:.3e} > max_drift="
                    f"{max_drift:g} times its initial size at output {i} (t={t_out[i]:.6g})",
                    step=i,
                    t=float(t_out[i]),
                )
    return Trajectory(_frozen(t_out), _frozen(states), method, n_steps, n_rhs, drift_report(model, states))
