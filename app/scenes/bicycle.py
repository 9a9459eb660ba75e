"""Bicycle scene: the Whipple bicycle of Meijaard et al. (2007) steering itself upright.

The bicycle of :func:`core.models.whipple_bicycle`: four rigid bodies (rear
wheel, rear frame with the rider, front fork with the handlebar, front
wheel), three revolute joints and two knife-edge wheels rolling without slip
on the ground (``System.add_contact(..., rolling=True)``). The speed is the
scene's slider; *Push* gives the rear frame a lateral impulse
(:func:`core.models.whipple_push`, the constrained impulse response) at the
displayed instant. Between the weave and capsize speeds the bicycle steers
into its lean and recovers; slower, the steering overshoots (weave) and it
falls; faster, it falls slowly into a tightening turn (capsize).

The scene holds no physics and does no long work on the loop thread:

* the ride is computed on the app's executor in chunks of 0.5 s of
  simulated time ahead of the display clock (:class:`app.jobs.ChunkTimeline`,
  sequential): the job :func:`_compute_chunk` rebuilds the System in the
  worker, puts it in the last state of the previous chunk (or of the
  displayed instant, pushed) and runs :func:`core.models.whipple_ride`,
  which stops at a fall; a push starts a new *segment* of chunks from the
  displayed state;
* the modes at the current speed (:func:`_modes_job`: ``linearize``, then
  :func:`core.models.whipple_modes`) and, one speed at a time while the ride
  has a chunk in hand, the eigenvalues against speed (the same job on a
  grid of 0-10 m/s) for the plot of the paper's figure, drawn as SVG with the
  self-stable band (where every real part is negative, interpolated on the
  grid) and the current speed.

Per frame the loop thread interpolates one sample and streams five poses:
the four bodies under a *world* frame whose position keeps the bicycle in
view, and the ground grid shifted by the same offset modulo its cells (so
it moves under the wheels). The rear and front wheels' tracks are rings of
small line-segment chunks whose newest chunk is sent ten times a second (a
finished chunk is never sent again), and their newest six metres, up to the
wheels, rings of equal sticks placed by poses only
(:class:`app.scenes._trail.StickHead`): the page draws poses in the frame it
receives them and new line points a frame later, so a track stretched to the
wheel every frame ended a page frame of motion behind it (metres at the 2-4
fps of a software-rendered page). The lean and steer plot is refreshed at
about 5 Hz.
"""

from __future__ import annotations

import dataclasses
import functools
import html
import math
import os
import time
from typing import Any, ClassVar

import numpy as np
import trimesh

from app.controls import Button, Slider, Toggle
from app.nodes import set_pose
from app.readout import PRESENTER_FONT_SCALE, PRESENTER_TABLE_SCALE
from app.scenes._playback import Playback, PlaybackRequests
from app.scenes._plots import History, Legend, PlotRefresh, Table
from app.scenes._trail import ChunkedTrail, StickHead
from app.scenes.base import Scene
from app.jobs import ChunkTimeline
from core.models import (
    MEIJAARD_2007,
    WHIPPLE_FALL_LEAN,
    whipple_bicycle,
    whipple_modes,
    whipple_push,
    whipple_ride,
    whipple_speed_model,
)

__all__ = [
    "BicycleScene",
    "CSV_HEADER",
    "PRESETS",
    "SWEEP_SPEEDS",
    "ModeRow",
    "Reference",
    "Segment",
    "eigenvalue_svg",
    "stable_band",
    "svg_background",
    "svg_current",
    "svg_dots",
]

_PARAMETERS = MEIJAARD_2007
_CHUNK_SIM_TIME = 0.5  # s of simulated time per chunk
_SAMPLE_RATE = 40  # samples per simulated second (the frames interpolate between them)
_CHUNKS_KEPT = 8
_JOBS_AFTER = 1.0  # s of ride shown after which the curves and modes go to the workers even if the ride is not ahead
_RTOL, _ATOL = 1e-5, 1e-7  # the ride's DOP853 tolerances (a display: lean to about 1e-5 rad)
_WINDOW = 10.0  # s of lean and steer in the plot
_REFRESH_PERIOD = 0.2  # s of wall time between plot / readout refreshes
_TRACK_PERIOD = 0.1  # s of wall time between track updates
_TRACK_CAPACITY = 500  # segments per wheel track
_TRACK_MIN_STEP = 0.04  # m between track points
_HEAD_STICK = 0.2  # m: the chords of each track's newest stretch, drawn by poses
_HEAD_STICKS = 32  # chords in that stretch (6.4 m: 1.3 s at 5 m/s)
_GRID_CELL = 0.5  # m
_GRID_SECTION = 2.0  # m
#: Speeds (m/s) of the eigenvalue plot: every 0.25 m/s from 0 to 10, coarse first.
SWEEP_SPEEDS = tuple(float(x) for x in np.round(np.arange(0.0, 10.0001, 0.25), 6))
_SWEEP_ORDER = tuple(sorted(range(len(SWEEP_SPEEDS)), key=lambda i: (i % 8 != 0, i % 4 != 0, i % 2 != 0, i)))
#: Presets: speed (m/s) and the push (N s) given at t = 0.
PRESETS = {
    "Self-stable: 5 m/s, push": (5.0, 40.0),
    "Weave: 2 m/s, push": (2.0, 20.0),
    "Capsize: 8 m/s, push": (8.0, 60.0),
    "Upright at 5 m/s": (5.0, 0.0),
}

#: Header of the exported CSV (one line: column names with units).
CSV_HEADER = "t (s),lean (deg),steer (deg),yaw (deg),rear contact x (m),rear contact y (m),speed (m/s)"

# Colours: none of them the red, green or blue of frame axes.
_FRAME_COLOR = (40, 90, 160)
_FORK_COLOR = (200, 110, 30)
_TIRE_COLOR = (45, 45, 50)
_RIDER_COLOR = (120, 120, 130)
_SPOKE_COLOR = (210, 60, 130)  # one marked spoke per wheel: the wheels' turn shows
_REAR_TRACK = (25, 25, 35)
_FRONT_TRACK = (230, 140, 0)
_SERIES = {"weave": "#1d4ed8", "capsize": "#c2410c", "castering": "#15803d", "current": "#7e22ce",
           "band": "#dcfce7"}


# -- the jobs (run in the worker processes) ------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Segment:
    """Where a stretch of chunks starts: the display time, the state and the push given there.

    Attributes
    ----------
    index : counts the segments since the last restart
    speed : forward speed of the model (m/s)
    t0 : display time at the start (s)
    q, v : the state to start from (None: upright and straight at ``speed``)
    impulse : lateral push (N s, positive to the right) given at the start
    """

    index: int
    speed: float
    t0: float
    q: tuple[float, ...] | None = None
    v: tuple[float, ...] | None = None
    impulse: float = 0.0


@dataclasses.dataclass(frozen=True)
class _Chunk:
    """Samples of one chunk of a segment (read-only arrays; times are display times)."""

    segment: Segment
    k: int
    t: np.ndarray  # (n,) s
    poses: np.ndarray  # (n, 4, 7): per body R (3) and Euler parameters (4), engine frame
    angles: np.ndarray  # (n, 3) lean, steer, yaw (rad, the paper's signs)
    contacts: np.ndarray  # (n, 2, 3) rear and front contact points (m)
    states: np.ndarray  # (n, 52) the System's q (28) and v (24) at the samples
    table: Table
    fallen: bool
    end: str
    cpu_seconds: float
    worker: int

    @property
    def final(self) -> bool:
        return self.fallen

    @property
    def q_end(self) -> np.ndarray:
        return self.states[-1, :28]

    @property
    def v_end(self) -> np.ndarray:
        return self.states[-1, 28:]


def _continuous(P: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    """Euler parameters (n, 4, 4) with signs chosen along the samples (for interpolation)."""
    P = np.array(P)
    if previous is not None:
        flip = np.einsum("bi,bi->b", P[0], previous) < 0.0
        P[0, flip] *= -1.0
    for i in range(1, P.shape[0]):
        flip = np.einsum("bi,bi->b", P[i], P[i - 1]) < 0.0
        P[i, flip] *= -1.0
    return P


class _Systems:
    """The System of the segment a worker process computed last, kept between its chunks.

    A chunk ``k > 0`` that the same process follows with chunk ``k + 1``
    continues with the same System, whose contacts start from the surface
    parameters of the end of chunk ``k`` (a rebuilt System would search
    for both contact points afresh). Chunk 0 of a segment always gets a
    new System: its contact warm starts must not come from another motion.
    """

    def __init__(self) -> None:
        self._kept: tuple[Segment, int, Any] | None = None

    def get(self, segment: Segment, k: int) -> Any:
        kept = self._kept
        if k > 0 and kept is not None and kept[0] == segment and kept[1] == k - 1:
            return kept[2]
        return whipple_bicycle(segment.speed, _PARAMETERS)

    def keep(self, segment: Segment, k: int, system: Any) -> None:
        self._kept = (segment, k, system)


_SYSTEMS = _Systems()  # one per worker process (and one for a scene's own thread)


def _compute_chunk(segment: Segment, k: int, previous: _Chunk | None) -> _Chunk:
    """Chunk ``k`` of ``segment`` (runs on the executor; never on the loop thread).

    Chunk 0 starts from the segment's state (a new System), pushed by its
    impulse; chunk ``k > 0`` from the last state of chunk ``k - 1`` (the
    same System when this process computed that chunk, else a new one). A
    chunk after a fall holds the fallen state.
    """
    cpu0 = time.thread_time()
    if k > 0 and (previous is None or previous.k != k - 1):
        raise ValueError(f"previous: chunk {k} continues from chunk {k - 1}, which was not given")
    if previous is not None and previous.final:
        return dataclasses.replace(previous, k=k, t=previous.t[-1:].repeat(2) + np.array([0.0, 1e-9]),
                                   poses=previous.poses[-1:].repeat(2, axis=0),
                                   angles=previous.angles[-1:].repeat(2, axis=0),
                                   contacts=previous.contacts[-1:].repeat(2, axis=0),
                                   states=previous.states[-1:].repeat(2, axis=0),
                                   table=Table.build(previous.t[-1:], previous.table.columns[-1:]),
                                   cpu_seconds=time.thread_time() - cpu0, worker=os.getpid())
    system = _SYSTEMS.get(segment, k)
    t_local = np.linspace(k * _CHUNK_SIM_TIME, (k + 1) * _CHUNK_SIM_TIME,
                          int(round(_CHUNK_SIM_TIME * _SAMPLE_RATE)) + 1)
    state = system.state
    if previous is not None:
        system.set_state(dataclasses.replace(state, t=float(t_local[0]), q=previous.q_end, v=previous.v_end))
    elif segment.q is not None:
        system.set_state(dataclasses.replace(state, t=0.0, q=np.array(segment.q), v=np.array(segment.v)))
    if k == 0 and segment.impulse:
        system.set_state(whipple_push(system, segment.impulse))
    ride = whipple_ride(system, t_local, parameters=_PARAMETERS, lean_limit=WHIPPLE_FALL_LEAN, rtol=_RTOL,
                        atol=_ATOL)
    _SYSTEMS.keep(segment, k, system)
    n = ride.t.size
    R = ride.q[:, :12].reshape(n, 4, 3)
    P = _continuous(ride.q[:, 12:].reshape(n, 4, 4), previous.poses[-1, :, 3:] if previous is not None else None)
    poses = np.concatenate([R, P], axis=2)
    angles = np.stack([ride.lean, ride.steer, ride.yaw], axis=1)
    contacts = np.stack([ride.rear_contact, ride.front_contact], axis=1)
    t = segment.t0 + ride.t
    states = np.concatenate([ride.q, ride.v], axis=1)
    if n == 1:  # the ride could not go on at all: hold the start
        t, poses, angles, contacts, states = (np.concatenate([a, a]) for a in (t, poses, angles, contacts, states))
        t = t + np.array([0.0, 1e-9])
    speed = np.linalg.norm(ride.v[:, 0:3], axis=1)
    columns = np.column_stack([np.degrees(ride.lean), np.degrees(ride.steer), np.degrees(ride.yaw),
                               ride.rear_contact[:, 0], ride.rear_contact[:, 1], speed])
    for name, a in (("poses", poses), ("angles", angles)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: the ride left the finite range near t = {t[0]:.3g} s")
    ground = poses[:, [0, 3], :3] * np.array([1.0, 1.0, 0.0])  # below the hubs, where no contact point is known
    contacts = np.where(np.isfinite(contacts), contacts, ground)
    for a in (t, poses, angles, contacts, states):
        a.setflags(write=False)
    return _Chunk(segment, k, t, poses, angles, contacts, states, Table.build(segment.t0 + ride.t, columns),
                  bool(ride.fallen), ride.end, time.thread_time() - cpu0, os.getpid())


@dataclasses.dataclass(frozen=True)
class ModeRow:
    """One mode of the linearized bicycle at a speed (picklable; see :func:`core.models.whipple_modes`)."""

    name: str
    eigenvalue: complex
    lean: complex
    steer: complex


def _modes_job(speed: float) -> tuple[float, tuple[ModeRow, ...]]:
    """``(speed, modes)``: the bicycle linearized at ``speed`` and its four modes named (on the executor).

    The linear model comes from :func:`core.models.whipple_speed_model`,
    equal to ``linearize(whipple_bicycle(speed))`` to round-off: a worker
    linearizes the System twice (at rest and at 10 m/s) for its first job,
    then every speed costs one eigenvalue problem (a few ms).
    """
    model = whipple_speed_model(_PARAMETERS).linear_model(speed)
    modes = whipple_modes(model, _PARAMETERS)
    return speed, tuple(ModeRow(m.name, m.eigenvalue, m.lean, m.steer) for m in modes)


# -- the eigenvalue plot ---------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Reference:
    """The paper's equations from the parameters over 0-10 m/s (lines of the plot) and its stable band.

    Attributes
    ----------
    speeds : (n,) m/s
    curves : (5, n) real parts of the weave (larger, smaller), the weave's imaginary part (0 while
        real), capsize, castering (1/s)
    band : (v_w, v_c) m/s, where every real part is negative (Brent on the paper's equations)
    """

    speeds: np.ndarray
    curves: np.ndarray
    band: tuple[float, float]


def _reference_job() -> Reference:
    """The paper's eigenvalues against speed (its Appendix A equations; on the executor, about 50 ms)."""
    from core.models import whipple_bicycle_reference, whipple_mode_names

    ref = whipple_bicycle_reference(_PARAMETERS)
    speeds = np.linspace(0.0, 10.0, 201)
    curves = np.full((5, speeds.size), np.nan)
    for i, v in enumerate(speeds):
        s = ref.eigenvalues(v)
        curves[:, i] = _columns(s, whipple_mode_names(s))
    b = ref.stability_boundaries((0.0, 10.0))
    for a in (speeds, curves):
        a.setflags(write=False)
    return Reference(speeds, curves, (float(b[0]), float(b[1])))


def _columns(s: Any, names: Any) -> np.ndarray:
    """(5,) weave real parts (larger, smaller), weave |Im|, capsize, castering of one speed's eigenvalues."""
    weave = [complex(x) for x, n in zip(s, names) if n == "weave"]
    out = np.full(5, np.nan)
    out[0] = max(x.real for x in weave)
    out[1] = min(x.real for x in weave)
    out[2] = max(abs(x.imag) for x in weave)
    for x, n in zip(s, names):
        if n == "capsize":
            out[3] = complex(x).real
        elif n == "castering":
            out[4] = complex(x).real
    return out


def stable_band(points: dict[float, tuple[ModeRow, ...]]) -> tuple[float, float] | None:
    """``(v_w, v_c)`` from the engine's eigenvalues at the speeds of ``points``: where the largest real
    part turns negative and positive again, interpolated linearly (None before a stable speed is seen)."""
    speeds = sorted(points)
    if len(speeds) < 2:
        return None
    top = [max(m.eigenvalue.real for m in points[v]) for v in speeds]
    lo = hi = None
    for i in range(len(speeds) - 1):
        a, b = top[i], top[i + 1]
        if (a > 0) != (b > 0):
            v = speeds[i] + (speeds[i + 1] - speeds[i]) * a / (a - b)
            if a > 0 and lo is None:
                lo = v
            elif a <= 0 and lo is not None and hi is None:
                hi = v
    if lo is None:
        return None
    return lo, hi if hi is not None else speeds[-1]


_W, _H = 560.0, 330.0
_L, _R, _T, _B = 46.0, 12.0, 10.0, 38.0
_Y_RANGE = (-10.0, 10.0)
_CURVE_COLORS = ("weave", "weave", "weave", "capsize", "castering")
_CLIP = "rigidlab-bicycle-plot"


def _x(v: float) -> float:
    return _L + (v / 10.0) * (_W - _L - _R)


def _y(s: float) -> float:
    lo, hi = _Y_RANGE
    s = min(max(s, lo - 100.0), hi + 100.0)  # drawn clipped to the plot area
    return _T + (hi - s) / (hi - lo) * (_H - _T - _B)


def _polyline(speeds: np.ndarray, values: np.ndarray, color: str, *, dash: str = "", width: float = 2.0) -> str:
    parts, run = [], []
    for v, s in zip(speeds.tolist(), values.tolist()):
        if math.isfinite(s):
            run.append(f"{_x(v):.1f},{_y(s):.1f}")
        elif run:
            parts.append(run)
            run = []
    if run:
        parts.append(run)
    style = f" stroke-dasharray='{dash}'" if dash else ""
    return "".join(f"<polyline points='{' '.join(r)}' fill='none' stroke='{color}' stroke-width='{width}'"
                   f"{style} clip-path='url(#{_CLIP})'/>" for r in parts if len(r) > 1)


def eigenvalue_svg(reference: Reference | None, points: dict[float, tuple[ModeRow, ...]],
                   current: tuple[float, tuple[ModeRow, ...]] | None, *, font: float = 11.0) -> str:
    """SVG of the eigenvalues against speed, the paper's figure.

    Lines: the paper's equations from the parameters (real parts solid, the
    weave's imaginary part dashed); dots: the engine's linearized System at
    the speeds of ``points``; the self-stable band of the lines shaded; the
    current speed and its eigenvalues (``current``) in purple. The parts are
    :func:`svg_background`, :func:`svg_dots` per speed and :func:`svg_current`.
    """
    dots = "".join(svg_dots(v, points[v]) for v in sorted(points))
    return svg_background(reference, font) + dots + svg_current(current) + "</svg>"


def svg_background(reference: Reference | None, font: float) -> str:
    """The opening of the plot: axes, grid, the band and the reference's lines (no closing tag)."""
    lo, hi = _Y_RANGE
    bottom = _H - _B
    out = [f"<svg viewBox='0 0 {_W:.0f} {_H:.0f}' width='100%' xmlns='http://www.w3.org/2000/svg' "
           f"font-family='sans-serif' font-size='{font:.1f}'>",
           f"<defs><clipPath id='{_CLIP}'><rect x='{_L}' y='{_T}' width='{_W - _L - _R}' height='{bottom - _T}'/>"
           "</clipPath></defs>",
           f"<rect x='{_L}' y='{_T}' width='{_W - _L - _R}' height='{bottom - _T}' fill='white' stroke='#c8ccd4'/>"]
    if reference is not None:
        x0, x1 = _x(reference.band[0]), _x(reference.band[1])
        out.append(f"<rect x='{x0:.1f}' y='{_T}' width='{x1 - x0:.1f}' height='{bottom - _T}' "
                   f"fill='{_SERIES['band']}'/>")
        out.append(f"<text x='{(x0 + x1) / 2:.1f}' y='{_T + 14:.1f}' text-anchor='middle' fill='#166534'>"
                   "self-stable</text>")
    for s in range(int(lo), int(hi) + 1, 5):
        y = _y(s)
        out.append(f"<line x1='{_L}' x2='{_W - _R}' y1='{y:.1f}' y2='{y:.1f}' stroke='#e5e7eb'/>")
        out.append(f"<text x='{_L - 5}' y='{y + 4:.1f}' text-anchor='end'>{s}</text>")
    out.append(f"<line x1='{_L}' x2='{_W - _R}' y1='{_y(0.0):.1f}' y2='{_y(0.0):.1f}' stroke='#6b7280'/>")
    for v in range(0, 11, 2):
        x = _x(v)
        out.append(f"<line x1='{x:.1f}' x2='{x:.1f}' y1='{_T}' y2='{bottom}' stroke='#e5e7eb'/>")
        out.append(f"<text x='{x:.1f}' y='{bottom + 15:.1f}' text-anchor='middle'>{v}</text>")
    out.append(f"<text x='{(_L + _W - _R) / 2:.1f}' y='{_H - 6:.1f}' text-anchor='middle'>speed v (m/s)</text>")
    mid = (_T + bottom) / 2
    out.append(f"<text x='12' y='{mid:.1f}' text-anchor='middle' transform='rotate(-90 12 {mid:.1f})'>"
               "eigenvalue s (1/s)</text>")
    if reference is not None:
        for k, key in enumerate(_CURVE_COLORS):
            values = reference.curves[k]
            if k == 2:
                out.append(_polyline(reference.speeds, np.where(values > 0, values, np.nan), _SERIES[key],
                                     dash="5 4", width=1.5))
            else:
                out.append(_polyline(reference.speeds, values, _SERIES[key]))
    return "".join(out)


def svg_dots(speed: float, rows: tuple[ModeRow, ...]) -> str:
    """The engine's eigenvalues (real parts) at one speed, as dots coloured by mode."""
    lo, hi = _Y_RANGE
    x = _x(speed)
    return "".join(f"<circle cx='{x:.1f}' cy='{_y(m.eigenvalue.real):.1f}' r='2.6' fill='{_SERIES[m.name]}' "
                   "stroke='white' stroke-width='0.6'/>" for m in rows if lo <= m.eigenvalue.real <= hi)


def svg_current(current: tuple[float, tuple[ModeRow, ...]] | None) -> str:
    """The current speed (a line) and its eigenvalues (filled: real parts; hollow: the weave's frequency)."""
    if current is None:
        return ""
    lo, hi = _Y_RANGE
    v, modes = current
    x = _x(v)
    color = _SERIES["current"]
    out = [f"<line x1='{x:.1f}' x2='{x:.1f}' y1='{_T}' y2='{_H - _B}' stroke='{color}' stroke-width='1.5'/>"]
    for m in modes:
        s = m.eigenvalue
        if lo <= s.real <= hi:
            out.append(f"<circle cx='{x:.1f}' cy='{_y(s.real):.1f}' r='4.5' fill='{color}'/>")
        if m.name == "weave" and 0 < s.imag <= hi:
            out.append(f"<circle cx='{x:.1f}' cy='{_y(s.imag):.1f}' r='4.5' fill='white' stroke='{color}' "
                       "stroke-width='1.5'/>")
    return "".join(out)


def _mode_table(speed: float, modes: tuple[ModeRow, ...], *, presenter: bool) -> str:
    """HTML table of the modes at ``speed``: eigenvalue, frequency, halving or doubling time, lean : steer."""
    size = f"{PRESENTER_FONT_SCALE:.2f}em" if presenter else "0.85em"
    # presenter view: the title at the readouts' size, the table smaller (as a readout's, PRESENTER_TABLE_SCALE)
    # and its cells may wrap ("½ in" over "1.23 s"): at full size the last two columns were cut off
    table_size = f";font-size:{PRESENTER_TABLE_SCALE:g}em" if presenter else ""
    pad = "padding:0.1em 0.35em" + ("" if presenter else ";white-space:nowrap")
    heads = (("mode", "left"), ("s (1/s)", "right"), ("f (Hz)", "right"), ("½ / ×2 in", "right"),
             ("φ : δ", "right"))
    head = "".join(f"<th style='{pad};text-align:{a};border-bottom:1px solid #c8ccd4'>{h}</th>" for h, a in heads)
    rows = []
    for m in modes:
        s = m.eigenvalue
        if m.name == "weave" and s.imag < 0:
            continue  # the pair is one row
        eig = f"{s.real:+.3f} ±\u00a0{s.imag:.3f}i" if s.imag > 0 else f"{s.real:+.3f}"  # (wraps before the ±)
        freq = f"{s.imag / (2 * math.pi):.3f}" if s.imag > 0 else "–"
        if s.real < 0:
            when = f"½ in {math.log(2) / -s.real:.2f}\u00a0s"
            color = "#15803d"
        elif s.real > 0:
            when = f"×2 in {math.log(2) / s.real:.2f}\u00a0s"
            color = "#c2410c"
        else:
            when, color = "neutral", "#374151"
        ratio = f"{abs(m.lean):.2f}\u00a0:\u00a0{abs(m.steer):.2f}"
        cells = (html.escape(m.name), eig, freq, f"<span style='color:{color}'>{when}</span>", ratio)
        rows.append("<tr>" + "".join(f"<td style='{pad};text-align:{a}'>{c}</td>" for c, (_, a) in zip(cells, heads))
                    + "</tr>")
    title = f"Modes at {speed:.2f} m/s (the System linearized, Eqs. 8.110-8.131)"
    return (f"<div style='font-size:{size};padding:0 0.75em 0.4em 0.75em'>"
            f"<div style='margin-bottom:0.2em'>{html.escape(title)}</div>"
            f"<table style='border-collapse:collapse;font-variant-numeric:tabular-nums{table_size}'>"
            f"<thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table></div>")


def _hex_rgb(color: str) -> tuple[int, int, int]:
    return int(color[1:3], 16), int(color[3:5], 16), int(color[5:7], 16)


# -- meshes ----------------------------------------------------------------------------------
def _tube(a: Any, b: Any, radius: float) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([a, b], dtype=float), sections=12)


def _wheel_mesh(radius: float) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """(tire and spokes, one marked spoke) of a wheel centred at its body origin, axle along y."""
    tire = trimesh.creation.torus(radius - 0.018, 0.018, major_sections=64, minor_sections=10)
    tire.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))
    parts = [tire, trimesh.creation.cylinder(radius=0.03, height=0.1, sections=16,
                                             transform=trimesh.transformations.rotation_matrix(math.pi / 2,
                                                                                               [1, 0, 0]))]
    for k in range(1, 8):
        a = k * math.pi / 4
        parts.append(_tube((0, 0, 0), (radius * math.cos(a), 0, radius * math.sin(a)), 0.004))
    marked = _tube((0, 0, 0), (radius - 0.02, 0, 0), 0.012)
    return trimesh.util.concatenate(parts), marked


def _steer_point(height: float) -> np.ndarray:
    """The steer axis at ``height`` above the ground (engine frame, reference configuration)."""
    p = _PARAMETERS
    lam = p.steer_axis_tilt
    return np.array([p.wheelbase + p.trail - height * math.tan(lam), 0.0, height])


@functools.cache  # one set per process, shared by every session: read them, never modify them
def _meshes() -> dict[str, trimesh.Trimesh]:
    """Meshes in each body's frame (origin at its centre of mass, axes global at the reference)."""
    p = _PARAMETERS
    rR, rF, w = p.rear_radius, p.front_radius, p.wheelbase
    com_frame = np.array([p.frame_position[0], 0.0, -p.frame_position[1]])
    com_fork = np.array([p.fork_position[0], 0.0, -p.fork_position[1]])
    hub_r = np.array([0.0, 0.0, rR])
    hub_f = np.array([w, 0.0, rF])
    bb = np.array([0.42, 0.0, 0.28])
    seat = np.array([0.3, 0.0, 0.88])
    head_lo, head_hi = _steer_point(0.62), _steer_point(0.86)
    frame = [_tube(hub_r, bb, 0.014), _tube(bb, seat, 0.02), _tube(seat, head_hi, 0.018), _tube(bb, head_lo, 0.022),
             _tube(hub_r, seat, 0.012), _tube(head_lo, head_hi, 0.026)]
    for side in (-0.05, 0.05):
        frame.append(_tube(hub_r + (0, side, 0), bb + (0, side * 0.5, 0), 0.008))
    rider = [
        _tube(seat + (0, 0, 0.05), (0.5, 0.0, 1.42), 0.13),  # torso
        trimesh.creation.icosphere(subdivisions=2, radius=0.11).apply_translation((0.56, 0.0, 1.6)),
    ]
    for side in (-0.11, 0.11):
        knee = np.array([0.58, side, 0.62])
        rider.append(_tube(seat + (0, side, 0.02), knee, 0.06))
        rider.append(_tube(knee, bb + (0.05, side * 1.5, 0.0), 0.045))
        rider.append(_tube((0.48, side * 1.6, 1.36), _steer_point(0.98) + (0.0, side * 2.2, 0.0), 0.035))
    bar_top = _steer_point(0.98)
    fork = [_tube(head_lo - (0, 0, 0.02), bar_top, 0.016),
            _tube(bar_top + (0, -0.28, 0), bar_top + (0, 0.28, 0), 0.014)]
    for side in (-0.045, 0.045):
        fork.append(_tube(head_lo + (0, side, 0), hub_f + (0, side, 0), 0.01))
    rear, rear_mark = _wheel_mesh(rR)
    front, front_mark = _wheel_mesh(rF)
    frame_mesh = trimesh.util.concatenate(frame).apply_translation(-com_frame)
    rider_mesh = trimesh.util.concatenate(rider).apply_translation(-com_frame)
    fork_mesh = trimesh.util.concatenate(fork).apply_translation(-com_fork)
    return {"rear_wheel": rear, "rear_mark": rear_mark, "front_wheel": front, "front_mark": front_mark,
            "frame": frame_mesh, "rider": rider_mesh, "fork": fork_mesh}


@dataclasses.dataclass
class _Gui:
    readout: Any
    legend: Legend
    plot_angles: Any
    modes_html: Any
    eigen_plot: Any
    plot_legend: Legend


class BicycleScene(PlaybackRequests, Scene):
    """The Whipple bicycle: self-stability between the weave and capsize speeds."""

    name: ClassVar[str] = "bicycle"
    title: ClassVar[str] = "Bicycle (self-stability)"
    order: ClassVar[int] = 90
    help: ClassVar[str] = (
        "The benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab (2007) built from the "
        "general engine: four rigid bodies (rear wheel, rear frame with the rider, fork with the "
        "handlebar, front wheel), three revolute joints, and two knife-edge wheels whose rims (tori "
        "of minor radius 0) roll without slip on the ground plane: the five contact constraints "
        "of each (Eqs. 8.90-8.94) reduced to the normal-force row (Eqs. 8.105-8.107), plus two "
        "rolling rows. No bicycle equation is written anywhere.\n\n"
        "- **Ride**: DOP853 on the augmented equations of the System, in chunks of 0.5 s. *Push* "
        "gives the rear frame a lateral impulse (positive: to the right) at the instant shown: "
        "the velocities jump by the constrained impulse response. The ride stops when the lean "
        "passes 60° or a wheel leaves the ground.\n"
        "- **Modes**: the System linearized about the straight run at the chosen speed "
        "(Eqs. 8.110-8.112, the rolling rows of a moving reference included) and its state-space "
        "eigenvalues (Eqs. 8.117-8.124) with six structural zeros (place, heading, wheel angles, "
        "speed) split off; named weave (oscillating: lean and steer), capsize (slow, mostly lean) "
        "and castering (fast, mostly steer). They agree with the paper's table to 11-15 digits.\n"
        "- **Plot of the eigenvalues against speed** (the paper's figure): real parts solid, the "
        "weave's frequency (imaginary part) dashed, the self-stable band shaded (every real part "
        "negative, between the weave speed 4.29 and the capsize speed 6.02 m/s), the current "
        "speed in purple.\n"
        "- **Tracks**: the rear (dark) and front (orange) contact points on the ground; the "
        "ground grid moves under the bicycle, which the view follows. *Download CSV* exports "
        "lean, steer, yaw and the rear contact of the plotted window."
    )
    # From the left and behind, the bicycle left of the GUI panel.
    camera_position: ClassVar[tuple[float, float, float]] = (-0.55, -3.0, 1.45)
    camera_look_at: ClassVar[tuple[float, float, float]] = (1.75, 0.75, 0.55)

    def __init__(self, target: Any, notify: Any, *, context: Any = None) -> None:
        super().__init__(target, notify, context=context)
        self.playback = Playback(tuple(PRESETS), controls=self.controls)
        self.segment = Segment(0, 5.0, 0.0)
        self.timeline = ChunkTimeline(self.executor, functools.partial(_compute_chunk, self.segment),
                                      chunk_time=_CHUNK_SIM_TIME, sequential=True, capacity=_CHUNKS_KEPT)
        self.history = History()
        self._refresh = PlotRefresh(("window", "readout", "angles"), _REFRESH_PERIOD)
        # Owned by update() (the session loop thread).
        self.speed: float | None = None
        self.sim_time = 0.0  # display time (s) since the last restart
        self.local_time = 0.0  # time in the segment (the timeline's clock)
        self.waiting = False
        self.fallen = False
        self.fall_text = ""
        self.lean = self.steer = self.yaw = 0.0
        self.center = np.zeros(2)  # the world offset: the bicycle's place on the ground (m)
        self.last_chunk: _Chunk | None = None
        self.modes: tuple[float, tuple[ModeRow, ...]] | None = None  # at the current speed
        self.sweep_points: dict[float, tuple[ModeRow, ...]] = {}
        self.reference: Reference | None = None
        self._reference_job: Any = None
        self._reference_reported = False
        self._modes_job: Any = None
        self._modes_pending: float | None = None
        self._sweep_job: Any = None
        self._sweep_next = 0
        self._svg_due = True
        self._svg_since = math.inf
        self._svg_background: tuple[Any, str] = (None, "")
        self._svg_dots: dict[float, str] = {}
        self._table_due = True
        self._since_track = math.inf
        self._drawn: tuple[float, int, int] | None = None
        self._refreshed_time = -1.0
        self._plot_window: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros((0, 0)))
        self._error_reported = False
        self._fall_reported = False
        self.pushes = 0
        self._start_impulse = 0.0  # the push the ride shown started with at t = 0 (N s)
        self._push_request: float | None = None
        self.gui: _Gui | None = None

    # -- build ----------------------------------------------------------------------------
    def build(self) -> None:
        scene = self.target.scene
        root = self.root
        self.make_root()
        self.grid = self.add_ground_grid(width=24.0, height=24.0, position=(0.0, 0.0, 0.0), cell_size=_GRID_CELL,
                                         section_size=_GRID_SECTION)
        self.world = scene.add_frame(f"{root}/world", show_axes=False)
        meshes = _meshes()
        colors = {"rear_wheel": _TIRE_COLOR, "frame": _FRAME_COLOR, "fork": _FORK_COLOR, "front_wheel": _TIRE_COLOR}
        self.bodies = []
        for name in ("rear_wheel", "frame", "fork", "front_wheel"):
            node = scene.add_frame(f"{root}/world/{name}", show_axes=False)
            mesh = meshes[name]
            scene.add_mesh_simple(f"{root}/world/{name}/mesh", mesh.vertices, mesh.faces, color=colors[name])
            self.bodies.append(node)
        for wheel, mark in (("rear_wheel", "rear_mark"), ("front_wheel", "front_mark")):
            scene.add_mesh_simple(f"{root}/world/{wheel}/mark", meshes[mark].vertices, meshes[mark].faces,
                                  color=_SPOKE_COLOR)
        self.rider = scene.add_mesh_simple(f"{root}/world/frame/rider", meshes["rider"].vertices,
                                           meshes["rider"].faces, color=_RIDER_COLOR, opacity=0.55)
        self.tracks = [
            ChunkedTrail(self, f"{root}/world/{name}", color, thickness=3.0, thickness_units="screen",
                         capacity=_TRACK_CAPACITY, min_step=_TRACK_MIN_STEP)
            for name, color in (("rear_track", _REAR_TRACK), ("front_track", _FRONT_TRACK))
        ]
        # each track's newest stretch up to the wheel's contact point now, placed by poses: the page draws
        # it in the frame that moves the bicycle (the chunks' points reach the screen a frame later)
        self.track_heads = [
            StickHead(self, f"{root}/world/{name}_head", color, thickness=3.0, thickness_units="screen",
                      length=_HEAD_STICK, count=_HEAD_STICKS)
            for name, color in (("rear_track", _REAR_TRACK), ("front_track", _FRONT_TRACK))
        ]
        gui = self.target.gui
        with self.make_folder():
            self.playback.add_gui()
            self.controls.add(Slider("speed", "Speed (m/s)", min=0.0, max=10.0, step=0.1, default=5.0,
                                     hint="Forward speed of the straight run; the ride restarts upright"))
            self.controls.add(Slider("impulse", "Push (N s)", min=-80.0, max=80.0, step=1.0, default=40.0,
                                     hint="Lateral impulse on the rear frame; positive pushes to the right"))
            self.controls.add(Button("push", "Push", hint="Push the rear frame sideways now"))
            readout = self.add_readout("Computing the ride…")
            eigen_plot = gui.add_html("")
            plot_legend = Legend(gui, (
                (_hex_rgb(_SERIES["weave"]), "weave: Re s solid, Im s dashed"),
                (_hex_rgb(_SERIES["capsize"]), "capsize"), (_hex_rgb(_SERIES["castering"]), "castering"),
                (_hex_rgb(_SERIES["current"]), "the current speed's modes"),
            ), "Lines: the paper's equations; dots: the linearized System.", presenter=self.presenter)
            x_scale = {"x": {"time": False}}
            plot_angles = self.add_plot(
                (np.zeros(2), np.zeros(2), np.zeros(2)),
                ({"label": "t (s)"}, {"label": "lean φ (deg)", "stroke": "#1d4ed8", "width": 2},
                 {"label": "steer δ (deg)", "stroke": "#c2410c", "width": 2}),
                title="lean and steer (positive: right)", scales=x_scale, aspect=1.6,
            )
            modes_html = gui.add_html("")
            legend = Legend(gui, (
                (_FRAME_COLOR, "rear frame (with the rider)"), (_FORK_COLOR, "front fork and handlebar"),
                (_REAR_TRACK, "rear wheel track"), (_FRONT_TRACK, "front wheel track"),
            ), "", presenter=self.presenter)
            self.playback.add_preset_buttons()
            with gui.add_folder("Show"):
                self.controls.add(Toggle("show_tracks", "Wheel tracks", default=True))
                self.controls.add(Toggle("show_rider", "Rider", default=True))
            self.add_download("download_csv", "Download CSV", "bicycle.csv", self.csv_bytes,
                              hint="t, lean, steer, yaw, rear contact, speed of the plotted window")
        self.gui = _Gui(readout, legend, plot_angles, modes_html, eigen_plot, plot_legend)

    def on_presenter(self, on: bool) -> None:
        if self.gui is not None:
            self.gui.legend.set_presenter(on)
            self.gui.plot_legend.set_presenter(on)
            self._table_due = True
            self._svg_due = True

    # -- requests (tests, notebooks) ----------------------------------------------------------
    def request_push(self, impulse: float | None = None) -> None:
        """Push at the next frame (``impulse`` N s, default the slider's)."""
        self._push_request = impulse if impulse is not None else float(self.controls.value("impulse"))

    # -- restarts and pushes -------------------------------------------------------------------
    def _restart(self, impulse: float = 0.0) -> None:
        """Upright at the current speed from t = 0, pushed by ``impulse`` (N s) at the start (which Reset
        replays)."""
        self._start_impulse = impulse
        speed = float(self.speed if self.speed is not None else 5.0)
        self._start_segment(Segment(0, speed, 0.0, impulse=impulse))
        self.sim_time = 0.0
        self.history.clear()
        for track in (*self.tracks, *self.track_heads):
            track.clear()
        self._refreshed_time = -1.0
        self._refresh.force()
        self._error_reported = False

    def _start_segment(self, segment: Segment) -> None:
        self.segment = segment
        self.timeline.reset(functools.partial(_compute_chunk, segment))
        self.local_time = 0.0
        self.fallen = False
        self.fall_text = ""
        self._fall_reported = False
        self._drawn = None
        if segment.impulse:
            self.pushes += 1

    def _push(self, impulse: float) -> None:
        """A new segment from the state shown now, pushed by ``impulse``."""
        chunk = self.last_chunk
        if chunk is None or chunk.segment != self.segment:
            self._restart(impulse)
            return
        if self.fallen:
            self.notify("The bicycle has fallen", "Press Reset (or move the speed) to ride again, then push.",
                        "info")
            return
        j = self._sample_index(chunk)
        state = chunk.states[j]
        segment = Segment(self.segment.index + 1, self.segment.speed, float(chunk.t[j]),
                          tuple(float(x) for x in state[:28]), tuple(float(x) for x in state[28:]), impulse)
        self.sim_time = float(chunk.t[j])
        self._start_segment(segment)

    def _sample_index(self, chunk: _Chunk) -> int:
        """The sample of ``chunk`` at or just before the display time."""
        return int(min(max(np.searchsorted(chunk.t, self.sim_time + 1e-9, side="right") - 1, 0), chunk.t.size - 1))

    # -- update ------------------------------------------------------------------------------------
    def update(self, dt: float) -> None:
        assert self.gui is not None
        preset = self.playback.take_preset()
        changed = self.controls.take_changes()
        clicks = self.controls.take_clicks(["push"])
        push, self._push_request = self._push_request, None
        if clicks:
            push = float(self.controls.value("impulse"))
        if preset is not None:
            speed, impulse = PRESETS[preset]
            self.controls.set("speed", speed)
            self.speed = speed
            self.playback.set_playing(True)
            self._restart(impulse)
            self._ask_modes(speed)
            push = None
        elif self.speed is None or "speed" in changed:
            first = self.speed is None  # the first ride starts with a push: the recovery shows at once
            self.speed = float(self.controls.value("speed"))
            self._restart(float(self.controls.value("impulse")) if first else 0.0)
            self._ask_modes(self.speed)
        tick = self.playback.tick(dt)
        if tick.reset:  # the ride again from its start, with the push it started with (a preset's demo)
            self._restart(self._start_impulse)
        if push is not None:
            self._push(push)
        self._collect_jobs()
        step = 0.0 if self.fallen else tick.step
        self.timeline.chunk_at(self.local_time, ahead=0.0)
        self.local_time, chunk, self.waiting = self.timeline.advance(self.local_time, step)
        if self.timeline.error is not None and not self._error_reported:
            self._error_reported = True
            self.playback.set_playing(False)
            error = self.timeline.error
            self.notify("Ride stopped", f"{type(error).__name__}: {error}. Press Reset or move the speed.",
                        "warning")
        self._background_jobs()
        if chunk is not None and chunk.segment == self.segment:
            self._draw(chunk, dt)
        self._refresh_panels(dt)

    def _draw(self, chunk: _Chunk, dt: float) -> None:
        assert self.gui is not None
        self.sim_time = self.segment.t0 + self.local_time
        if chunk.fallen and self.sim_time >= float(chunk.t[-1]):
            self.sim_time = float(chunk.t[-1])
            self.local_time = self.sim_time - self.segment.t0
            self.fallen = True
            self.fall_text = chunk.end
            if not self._fall_reported:
                self._fall_reported = True
                self.notify("The bicycle fell", f"{chunk.end}. Press Reset, move the speed or choose a preset.",
                            "info")
        due = self._refresh.due(dt, moving=self.sim_time != self._refreshed_time)
        key = (self.sim_time, chunk.k, self.segment.index)
        show_tracks = bool(self.controls.value("show_tracks"))
        if key == self._drawn:
            if due is not None:
                with self.target.atomic():
                    self._refresh_one(due)
            return
        self._drawn = key
        self.last_chunk = chunk
        self.history.add(self.segment.index * 100000 + chunk.k, chunk.table)
        t = chunk.t
        x = (self.sim_time - float(t[0])) / max(float(t[1] - t[0]), 1e-12)
        j = min(max(int(x), 0), t.size - 2)
        w = min(max(x - j, 0.0), 1.0)
        pose = chunk.poses[j] + w * (chunk.poses[j + 1] - chunk.poses[j])
        angles = chunk.angles[j] + w * (chunk.angles[j + 1] - chunk.angles[j])
        contacts = chunk.contacts[j] + w * (chunk.contacts[j + 1] - chunk.contacts[j])
        self.lean, self.steer, self.yaw = (float(a) for a in angles)
        center = 0.5 * (contacts[0, :2] + contacts[1, :2])
        self.center = center
        grid_shift = -(center - _GRID_SECTION * np.round(center / _GRID_SECTION))
        for i, (track, head) in enumerate(zip(self.tracks, self.track_heads)):
            track.add(contacts[i] + (0.0, 0.0, 0.003))
            head.add(contacts[i] + (0.0, 0.0, 0.003))
        self._since_track += dt
        send_tracks = show_tracks and any(t.pending for t in self.tracks) and self._since_track >= _TRACK_PERIOD
        with self.target.atomic():
            set_pose(self.world, position=(-float(center[0]), -float(center[1]), 0.0))
            set_pose(self.grid, position=(float(grid_shift[0]), float(grid_shift[1]), 0.0))
            for b, node in enumerate(self.bodies):
                P = pose[b, 3:]
                set_pose(node, position=pose[b, :3], wxyz=P / math.sqrt(float(P @ P)))
            for track in (*self.tracks, *self.track_heads):
                if track.visible != show_tracks:
                    track.visible = show_tracks
            show_rider = bool(self.controls.value("show_rider"))
            if self.rider.visible != show_rider:
                self.rider.visible = show_rider
            if send_tracks:
                for track in self.tracks:
                    track.flush()  # the newest chunk only
                self._since_track = 0.0
            if show_tracks:
                for head in self.track_heads:
                    head.draw()  # poses of the new sticks and of the tip
            if due is not None:
                self._refresh_one(due)

    # -- background jobs: modes at the current speed and the sweep ------------------------------
    def _ask_modes(self, speed: float) -> None:
        self._modes_pending = float(speed)
        self._table_due = True

    def _collect_jobs(self) -> None:
        job = self._reference_job
        if job is not None and job.done() and self.reference is None:
            if not job.cancelled() and job.exception() is None:
                self.reference = job.result()
                self._svg_due = True
            elif job.cancelled():
                self._reference_job = None  # asked again
            elif not self._reference_reported:
                self._reference_reported = True  # not asked again: the plot shows the dots only
                self.notify("Reference curves not computed", f"{type(job.exception()).__name__}: {job.exception()}",
                            "warning")
        job = self._modes_job
        if job is not None and job.done():
            self._modes_job = None
            if not job.cancelled() and job.exception() is None:
                speed, rows = job.result()
                if round(speed, 6) in SWEEP_SPEEDS:
                    self.sweep_points.setdefault(round(speed, 6), rows)
                    self._svg_due = True
                if self.speed is not None and abs(speed - self.speed) < 1e-12:
                    self.modes = (speed, rows)
                    self._table_due = self._svg_due = True
            elif not job.cancelled():
                self.notify("Modes not computed", f"{type(job.exception()).__name__}: {job.exception()}", "warning")
        job = self._sweep_job
        if job is not None and job.done():
            self._sweep_job = None
            if not job.cancelled() and job.exception() is None:
                speed, rows = job.result()
                self.sweep_points[round(speed, 6)] = rows
                self._svg_due = True

    def _background_jobs(self) -> None:
        """The paper's curves, then the modes at the current speed, then a sweep speed.

        Each waits until the ride has its next chunk in hand (or is not
        riding), so that a (re)started ride's first chunks come first on the
        workers and the ride moves at once; the curves and the modes wait
        at most until the ride has shown :data:`_JOBS_AFTER` (a worker that
        never gets ahead of the clock still computes them), the sweep always.
        """
        ahead = not self.timeline.busy and (
            self.timeline.ready(self.timeline.index(self.local_time) + 1) or self.fallen or not self.playing
            or self.timeline.error is not None)
        if not ahead and self.sim_time < _JOBS_AFTER:
            return
        if self._reference_job is None:
            self._reference_job = self.executor.submit(_reference_job)
        if self._modes_job is None and self._modes_pending is not None:
            speed, self._modes_pending = self._modes_pending, None
            self._modes_job = self.executor.submit(_modes_job, speed)
            return
        if self._modes_job is not None or self._sweep_job is not None or not ahead:
            return
        while self._sweep_next < len(_SWEEP_ORDER):
            speed = SWEEP_SPEEDS[_SWEEP_ORDER[self._sweep_next]]
            self._sweep_next += 1
            if speed not in self.sweep_points:
                self._sweep_job = self.executor.submit(_modes_job, speed)
                return

    @property
    def sweep_complete(self) -> bool:
        return len(self.sweep_points) >= len(SWEEP_SPEEDS)

    # -- panels --------------------------------------------------------------------------------------
    def _refresh_panels(self, dt: float) -> None:
        assert self.gui is not None
        self._svg_since += dt
        if self._table_due and self.modes is not None:
            self._table_due = False
            self.gui.modes_html.content = _mode_table(self.modes[0], self.modes[1], presenter=self.presenter)
        elif self._svg_due and self._svg_since >= 0.25:
            self._svg_due = False
            self._svg_since = 0.0
            font = 11.0 * (PRESENTER_FONT_SCALE / 0.875 if self.presenter else 1.0)
            key = (self.reference is not None, font)
            if self._svg_background[0] != key:  # built again only when the lines or the font change
                self._svg_background = (key, svg_background(self.reference, font))
            for v in self.sweep_points.keys() - self._svg_dots.keys():
                self._svg_dots[v] = svg_dots(v, self.sweep_points[v])
            self.gui.eigen_plot.content = (self._svg_background[1] + "".join(self._svg_dots.values())
                                           + svg_current(self.modes) + "</svg>")

    def _window_start(self) -> float:
        return max(0.0, self.sim_time - _WINDOW)

    def _refresh_one(self, what: str) -> None:
        assert self.gui is not None
        if what == "window":
            self._refreshed_time = self.sim_time
            self._plot_window = self.history.trimmed_window(self._window_start(), self.sim_time)
            return
        if what == "readout":
            self.gui.readout.content = self._readout()
            return
        t, columns = self._plot_window
        if t.size == 0:
            return
        if what == "angles":
            self.gui.plot_angles.data = (t, columns[:, 0], columns[:, 1])

    def _readout(self) -> str:
        band = stable_band(self.sweep_points) if self.sweep_complete else None
        ref = self.reference
        lines = [f"**t** = {self.sim_time:.2f} s · **v** = {self.segment.speed:.2f} m/s · "
                 f"lean φ = {math.degrees(self.lean):+.2f}° · steer δ = {math.degrees(self.steer):+.2f}°"]
        if self.fallen:
            lines.append(f"**Fallen**: {self.fall_text}.")
        elif self.waiting and self.playing:
            lines.append("*computing the next chunk…*")
        if ref is not None:
            lines.append(f"Self-stable from v_w = {ref.band[0]:.4f} to v_c = {ref.band[1]:.4f} m/s (the paper's "
                         "equations, lines of the plot).")
        if band is not None:
            lines.append(f"The engine's eigenvalues (dots, every 0.25 m/s) cross zero at about {band[0]:.3f} and "
                         f"{band[1]:.3f} m/s (interpolated).")
        else:
            lines.append(f"The engine's eigenvalues (dots): {len(self.sweep_points)} of {len(SWEEP_SPEEDS)} speeds "
                         "computed.")
        return "\n\n".join(lines)

    def csv_bytes(self) -> bytes:
        """The CSV of the ride in the plot window, up to the displayed time."""
        return self.history.csv(CSV_HEADER, self._window_start(), self.sim_time)

