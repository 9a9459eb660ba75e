"""Work-precision benchmarks: pendulum chains against MuJoCo, Pinocchio and Exudyn; the free rigid body's integrators.

Run from the project root::

    .venv/bin/python bench/work_precision.py                         # both parts, chains first (~20 min)
    .venv/bin/python bench/work_precision.py --part chains --quick   # 2 and 10 links, fewer settings (< 5 min)
    .venv/bin/python bench/work_precision.py --part free-body        # the free body only (a few minutes)

``--part`` selects ``chains``, ``free-body`` or ``both`` (default: both,
the chains first); ``--quick`` shortens either part.

**Part "chains": pendulum chains against the peers.** Chains of 2, 10, 30
and 100 links (:func:`rigidlab.core.models.pendulum_chain`: uniform 1 m, 1 kg rods
on revolute joints about x, released at rest from the straight chain
tilted by 0.5 rad), T = 10 s, outputs at 60 Hz. Error = the largest
distance over the outputs of the chain's tip (the free end of the last
link) from the reference: :func:`rigidlab.core.models.pendulum_chain_reduced` (the
reduced Lagrange equations in the joint angles, DOP853 at rtol = atol =
1e-13; ``bench/multibody.py`` checks it against 1e-11 to ~1e-13 m). CPU
is ``time.process_time`` of the run (model building excluded), the best
of up to three runs for runs under 0.5 s. Curves (settings from coarse to
fine, a curve stops at an error below 1e-11 or when its next run would cost
more than :data:`CPU_CAP` seconds, quick: :data:`QUICK_CPU_CAP`):

* rigidlab ``System.simulate``: DOP853 (projection) at ``rtol`` 1e-3 ..
  1e-12, ``atol = rtol / 100``; ``"rk4"`` at ``dt`` = 1/(60 k) s;
* MuJoCo (hinge joints, minimal coordinates, contacts off): RK4 and
  ``implicitfast`` at ``timestep`` = 1/(60 k) s, positions read after
  ``mj_kinematics`` at every output (after an RK4 ``mj_step`` mjData holds
  the last stage's positions);
* Pinocchio: ``pin.aba`` (the same chain as a ``pin.Model`` of
  ``JointModelRX`` joints, same inertias and initial state) as the
  right-hand side of scipy's ``solve_ivp`` DOP853 at ``rtol`` 1e-3 ..
  1e-12, ``atol = rtol / 100``, outputs by ``t_eval``;
* Exudyn, its best paths (``bench/multibody.py`` shows its generalized-
  alpha in redundant coordinates, dense or sparse, far behind):
  ``ObjectKinematicTree`` (minimal coordinates) with RK44 at dt = 1/(60 k)
  s and with DOPRI5 at ``rtol = atol`` 1e-4 .. 1e-12 (stopped at every
  output: its adaptive steps do not end on them).

Prints every run, then the CPU at tip errors 1e-3, 1e-6 and 1e-9 per
curve and per engine (its cheapest curve) for every chain: log-log
interpolation along the curve's Pareto front (the runs no cheaper run
beats), or the cheapest run when every run is below the target ("<="),
or "not reached"; ratios are the engine's CPU over rigidlab's (its
cheaper curve) at the same error, measured in the same run (> 1: rigidlab
is faster). Writes ``bench/out/work_precision_chains.json`` and the figure
(tip error against CPU, log-log, one panel per chain):
``docs/img/work_precision_chains.png`` for the full run,
``bench/out/work_precision_chains.png`` with ``--quick``.

**Part "free-body": the free rigid body integrators against the exact
solution.** What it measures, all in one run:

1. **Work-precision, free asymmetric body** (moments 1, 2, 3; T = 1000 s,
   ~180 polhode periods): for every fixed-step method of
   :mod:`rigidlab.core.integrators` at several steps and scipy's RK45, DOP853 and
   LSODA at several tolerances, the CPU time (``time.process_time``) and
   the error against :func:`rigidlab.core.rigid_body.free_body_exact` at 101
   checkpoints (max over checkpoints of the orientation angle error in rad
   and the relative omega error).
2. **Stiff case**: spin about the major axis 1e3 times the transverse rates
   (omega_body0 = (1, 0.5, 1000) rad/s), T = 1 s (~160 turns).
3. **Cost per time point of the exact solution**, vectorized over 1e5
   points, and per displayed frame (one call per point).
4. **Ratios** at equal accuracy: CPU time of each method (log-log
   interpolated along its work-precision curve) over DOP853's, measured in
   the same run.
5. **Long run**: 1e6 steps of the Strang splitting, plain and compensated
   (``FreeBodyModel(..., compensated=True)``): max ``| |p| - 1 |`` and the
   energy error, with its maximum over the first and the last tenth of the
   run (no secular growth when they agree), against RK4 over the same
   horizon with 1e5 steps.
6. **Stress cases** of the exact solution: near the separatrix (offsets
   1e-2..1e-8 from the intermediate axis), nearly equal moments, a rod-like
   body (tiny I3), a huge spin: finite values, conservation of E, L and
   ``|p|`` over t <= 1e3, and the difference to DOP853 at rtol = 1e-13
   over t <= 20.

It writes ``bench/out/work_precision.png`` and
``bench/out/work_precision.json`` (bench/out/ is git-ignored); its
``--quick`` uses shorter horizons (~1 min).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rigidlab.core import integrators as itg  # noqa: E402
from rigidlab.core import rigid_body as rb  # noqa: E402

OUT = Path(__file__).resolve().parent / "out"
P0 = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])


def _cpu(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def _error(model, y0, run_t, states, scale):
    ex = model.exact(y0, run_t)
    ang = rb.rotation_angle_between(ex[:, :4], states[:, :4])
    dw = np.linalg.norm(ex[:, 4:] - states[:, 4:], axis=1) / scale
    return float(max(ang.max(), dw.max()))


def work_precision(label, inertia, w0, T, fixed, adaptive, n_check=100):
    """Rows (method, setting, cpu_s, error, |p|-1, rel energy error, steps)."""
    model = rb.FreeBodyModel(inertia)
    y0 = np.concatenate([P0, w0])
    t_check = np.linspace(0.0, T, n_check + 1)
    scale = float(np.linalg.norm(w0))
    rows = []
    for method, dts in fixed.items():
        for dt in dts:
            n = round(T / dt)
            save = max(1, n // n_check)
            try:
                run, cpu = _cpu(lambda: itg.integrate(model, y0, (0.0, T), method=method, dt=dt, save_every=save))
            except itg.IntegrationError as exc:
                print(f"  {label}: {method} dt={dt:g} failed: {str(exc)[:80]}")
                continue
            err = _error(model, y0, run.t, run.states, scale)
            rows.append(dict(case=label, method=method, setting=f"dt={dt:g}", cpu=cpu, error=err,
                             p_norm=run.drift.max_abs["p_norm"], energy=run.drift.max_rel["energy"],
                             steps=run.n_steps))
    for method, tols in adaptive.items():
        for tol in tols:
            try:
                run, cpu = _cpu(lambda: itg.integrate(model, y0, (0.0, T), method=method, rtol=tol,
                                                      atol=tol * 1e-2, t_eval=t_check))
            except itg.IntegrationError as exc:
                print(f"  {label}: {method} rtol={tol:g} failed: {str(exc)[:80]}")
                continue
            err = _error(model, y0, run.t, run.states, scale)
            rows.append(dict(case=label, method=method, setting=f"rtol={tol:g}", cpu=cpu, error=err,
                             p_norm=run.drift.max_abs["p_norm"], energy=run.drift.max_rel["energy"],
                             steps=run.n_steps))
    return rows


def cost_at(rows, method, target):
    """CPU time of ``method`` at error ``target`` (log-log interpolation; None if out of range)."""
    pts = sorted((r["error"], r["cpu"]) for r in rows if r["method"] == method and r["error"] > 0)
    if not pts:
        return None
    e = np.log10([p[0] for p in pts])
    c = np.log10([p[1] for p in pts])
    x = math.log10(target)
    if x < e.min() - 1e-9 or x > e.max() + 1e-9:
        return None
    return float(10 ** np.interp(x, e, c))


def exact_cost(inertia, w0, n_points):
    sol = rb.free_body_solution(inertia, w0, P0)
    t = np.linspace(0.0, 1000.0, n_points)
    sol.at(t[:10])
    _, cpu = _cpu(lambda: [sol.at(t) for _ in range(5)])
    per_point = cpu / (5 * n_points)
    ts = t[:2000]
    _, cpu1 = _cpu(lambda: [sol.at(x) for x in ts])
    _, cpu_build = _cpu(lambda: [rb.free_body_solution(inertia, w0, P0) for _ in range(200)])
    return per_point, cpu1 / ts.size, cpu_build / 200


def long_run(n_steps, dt, rk4_steps):
    J = np.array([1.0, 2.0, 3.0])
    model = rb.FreeBodyModel(J)
    y0 = np.concatenate([P0, [0.8, -0.5, 0.6]])
    T = n_steps * dt
    save = max(1, n_steps // 2000)
    run, cpu = _cpu(lambda: itg.integrate(model, y0, (0.0, T), method="splitting", dt=dt, save_every=save))
    inv = model.invariants(run.states)
    dE = np.abs(inv["energy"] / inv["energy"][0] - 1.0)
    dp = np.abs(inv["p_norm"] - 1.0)
    tenth = max(1, len(dE) // 10)
    comp_model = rb.FreeBodyModel(J, compensated=True)
    comp, comp_cpu = _cpu(lambda: itg.integrate(comp_model, y0, (0.0, T), method="splitting", dt=dt,
                                                save_every=save))
    c_inv = comp_model.invariants(comp.states)
    c_dE = np.abs(c_inv["energy"] / c_inv["energy"][0] - 1.0)
    c_dp = np.abs(c_inv["p_norm"] - 1.0)
    rk_save = max(1, rk4_steps // 2000)
    rk, rk_cpu = _cpu(lambda: itg.integrate(model, y0, (0.0, T), method="rk4", dt=T / rk4_steps, save_every=rk_save))
    rk_inv = model.invariants(rk.states)
    rk_dE = np.abs(rk_inv["energy"] / rk_inv["energy"][0] - 1.0)
    rk_tenth = max(1, len(rk_dE) // 10)
    return dict(
        steps=n_steps, dt=dt, T=T, cpu=cpu, p_norm_max=float(dp.max()), energy_max=float(dE.max()),
        energy_first_tenth=float(dE[:tenth].max()), energy_last_tenth=float(dE[-tenth:].max()),
        p_norm_first_tenth=float(dp[:tenth].max()), p_norm_last_tenth=float(dp[-tenth:].max()),
        rk4_steps=rk4_steps, rk4_dt=T / rk4_steps, rk4_cpu=rk_cpu,
        rk4_energy_first_tenth=float(rk_dE[:rk_tenth].max()), rk4_energy_last_tenth=float(rk_dE[-rk_tenth:].max()),
        rk4_p_norm_max=float(np.abs(rk_inv["p_norm"] - 1).max()),
        comp_cpu=comp_cpu, comp_p_norm_max=float(c_dp.max()), comp_energy_first_tenth=float(c_dE[:tenth].max()),
        comp_energy_last_tenth=float(c_dE[-tenth:].max()),
        comp_p_norm_first_tenth=float(c_dp[:tenth].max()), comp_p_norm_last_tenth=float(c_dp[-tenth:].max()),
    )


def stress_cases():
    cases = []
    for off in (1e-2, 1e-4, 1e-6, 1e-8):
        cases.append((f"separatrix offset {off:g}", [1.0, 2.0, 3.0], [off, 1.0, off]))
    cases += [
        ("separatrix exact", [3.0, 4.0, 6.0], [2.0, 0.5, 1.0]),
        ("equal moments gap 1e-6", [1.0, 1.0 + 1e-6, 2.0], [0.3, 0.5, 2.0]),
        ("equal moments gap 1e-12", [1.0, 1.0 + 1e-12, 2.0], [0.3, 0.5, 2.0]),
        ("rod-like I3 = 1e-4", [1e-4, 1.0, 1.001], [2.0, 0.3, 0.5]),
        ("huge spin 1e4 rad/s", [1.0, 2.0, 3.0], [0.3, 0.5, 1e4]),
    ]
    rows = []
    for name, J, w0 in cases:
        J, w0 = np.array(J), np.array(w0)
        sol = rb.free_body_solution(J, w0, P0)
        t = np.linspace(0.0, 1000.0 if "huge" not in name else 10.0, 20001)
        m = sol.at(t)
        finite = bool(np.all(np.isfinite(m.p)) and np.all(np.isfinite(m.omega_body)))
        E = rb.rotational_kinetic_energy(J, m.omega_body)
        L = rb.angular_momentum_global(J, m.omega_body, m.p)
        t_ref = np.linspace(0.0, 20.0 if "huge" not in name else 0.2, 201)
        model = rb.FreeBodyModel(J)
        ref = itg.integrate(model, np.concatenate([P0, w0]), (0.0, float(t_ref[-1])), method="DOP853",
                            rtol=1e-13, atol=1e-14 * np.linalg.norm(w0), t_eval=t_ref)
        ex = sol.at(t_ref)
        rows.append(dict(
            case=name, kind=sol.kind, finite=finite,
            energy=float(np.abs(E / E[0] - 1).max()),
            L=float(np.linalg.norm(L - L[0], axis=1).max() / np.linalg.norm(L[0])),
            p_norm=float(np.abs(np.linalg.norm(m.p, axis=1) - 1).max()),
            vs_dop853=float(max(rb.rotation_angle_between(ex.p, ref.states[:, :4]).max(),
                                (np.linalg.norm(ex.omega_body - ref.states[:, 4:], axis=1)
                                 / np.linalg.norm(w0)).max())),
        ))
    return rows


def _print_table(title, header, rows):
    print(f"\n{title}")
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print("  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))


def free_body_main(quick: bool) -> None:
    """Part "free-body": the free rigid body's integrators against the exact solution."""
    OUT.mkdir(exist_ok=True)

    T = 100.0 if quick else 1000.0
    J = np.array([1.0, 2.0, 3.0])
    w0 = np.array([0.8, -0.5, 0.6])
    fixed = {
        "rk4": [0.1, 0.05, 0.02] + ([] if quick else [0.01]),
        "midpoint": [0.05, 0.02] + ([] if quick else [0.01]),
        "splitting": [0.1, 0.05, 0.02] + ([] if quick else [0.01]),
        "splitting4": [0.2, 0.1, 0.05] + ([] if quick else [0.02, 0.01]),
        "splitting6": [0.5, 0.25, 0.1] + ([] if quick else [0.05, 0.025]),
        "splitting8": [1.0, 0.5, 0.25] + ([] if quick else [0.125]),
    }
    adaptive = {
        "RK45": [1e-5, 1e-7, 1e-9] if quick else [1e-4, 1e-6, 1e-8, 1e-10],
        "DOP853": [1e-5, 1e-7, 1e-9, 1e-11] if quick else [1e-5, 1e-6, 1e-8, 1e-10, 1e-12, 1e-13],
        "LSODA": [1e-6, 1e-9] if quick else [1e-6, 1e-8, 1e-10, 1e-12],
    }
    print(f"free asymmetric body, moments {J.tolist()}, omega_body0 {w0.tolist()}, T = {T:g} s")
    rows = work_precision("asymmetric", J, w0, T, fixed, adaptive)
    T_stiff = 0.2 if quick else 1.0
    w_stiff = np.array([1.0, 0.5, 1000.0])
    # the body-frame nutation is as fast as the spin (~1e3 rad/s): every
    # fixed-step method needs dt well below 1e-3
    fixed_stiff = {
        "rk4": [2e-4, 1e-4, 5e-5] + ([] if quick else [2.5e-5]),
        "midpoint": [1e-4, 5e-5],
        "splitting": [2e-4, 1e-4, 5e-5] + ([] if quick else [2.5e-5]),
        "splitting4": [4e-4, 2e-4, 1e-4] + ([] if quick else [5e-5, 2.5e-5]),
        "splitting6": [1e-3, 5e-4, 2.5e-4] + ([] if quick else [1.25e-4, 6.25e-5]),
        "splitting8": [2e-3, 1e-3, 5e-4] + ([] if quick else [2.5e-4]),
    }
    adaptive_stiff = {"RK45": [1e-6, 1e-8], "DOP853": [1e-5, 1e-7, 1e-9, 1e-11, 1e-13], "LSODA": [1e-7, 1e-10]}
    print(f"stiff case: omega_body0 {w_stiff.tolist()}, T = {T_stiff:g} s")
    rows_stiff = work_precision("stiff", J, w_stiff, T_stiff, fixed_stiff, adaptive_stiff)

    all_rows = rows + rows_stiff
    _print_table(
        "Work-precision (error = max over 101 checkpoints of orientation angle [rad] and |d omega| / |omega0|)",
        ["case", "method", "setting", "steps", "CPU s", "error", "max||p|-1|", "max|dE|/E"],
        [[r["case"], r["method"], r["setting"], str(r["steps"]), f"{r['cpu']:.3f}", f"{r['error']:.2e}",
          f"{r['p_norm']:.1e}", f"{r['energy']:.1e}"] for r in all_rows],
    )

    per_point, per_frame, build = exact_cost(J, w0, 100_000)
    n_frames = int(60 * T)
    exact_frames_cpu = per_point * n_frames
    _print_table(
        "Exact solution cost",
        ["quantity", "value"],
        [["vectorized, per time point (1e5 points)", f"{per_point * 1e6:.2f} us"],
         ["one call per time point (a displayed frame)", f"{per_frame * 1e6:.1f} us"],
         ["free_body_solution setup (once per parameter change)", f"{build * 1e6:.1f} us"],
         [f"all {n_frames} frames of T = {T:g} s at 60 fps, vectorized", f"{exact_frames_cpu * 1e3:.1f} ms"]],
    )

    per_point_stiff, _, build_stiff = exact_cost(J, w_stiff, 100_000)
    exact_total = {
        "asymmetric": build + exact_frames_cpu,
        "stiff": build_stiff + per_point_stiff * int(60 * T_stiff),
    }
    ratio_rows = []
    summary = {}
    for case, case_rows in (("asymmetric", rows), ("stiff", rows_stiff)):
        for target in (1e-6, 1e-9):
            base = cost_at(case_rows, "DOP853", target)
            for method in list(fixed) + list(adaptive):
                c = cost_at(case_rows, method, target)
                ratio = base / c if (base and c) else None
                ratio_rows.append([case, f"{target:g}", method, f"{c:.3f}" if c else "out of range",
                                   f"{ratio:.2f}x" if ratio else "-"])
                summary[f"{case}/{target:g}/{method}"] = ratio
            if base:
                # the exact solution is below 1e-11 everywhere; its cost is the
                # setup (once per parameter change) plus every 60 fps frame
                exact_cpu = exact_total[case]
                r = base / exact_cpu
                ratio_rows.append([case, f"{target:g}", "exact (setup + 60 fps frames)", f"{exact_cpu:.4f}",
                                   f"{r:.0f}x"])
                summary[f"{case}/{target:g}/exact"] = r
    _print_table("Cost at equal accuracy (ratio = DOP853 CPU / method CPU, same run; > 1 means cheaper)",
                 ["case", "error", "method", "CPU s", "vs DOP853"], ratio_rows)

    n_long = 100_000 if quick else 1_000_000
    lr = long_run(n_long, 0.01, n_long // 10)
    _print_table(
        f"Long run: Strang splitting, {lr['steps']:.0e} steps of dt = {lr['dt']:g} (T = {lr['T']:g} s), "
        f"vs RK4 with {lr['rk4_steps']:.0e} steps",
        ["quantity", "splitting", "splitting (compensated)", "rk4"],
        [["CPU s", f"{lr['cpu']:.1f}", f"{lr['comp_cpu']:.1f}", f"{lr['rk4_cpu']:.1f}"],
         ["max ||p| - 1|", f"{lr['p_norm_max']:.2e}", f"{lr['comp_p_norm_max']:.2e}", f"{lr['rk4_p_norm_max']:.2e}"],
         ["max |dE|/E, first tenth", f"{lr['energy_first_tenth']:.2e}", f"{lr['comp_energy_first_tenth']:.2e}",
          f"{lr['rk4_energy_first_tenth']:.2e}"],
         ["max |dE|/E, last tenth", f"{lr['energy_last_tenth']:.2e}", f"{lr['comp_energy_last_tenth']:.2e}",
          f"{lr['rk4_energy_last_tenth']:.2e}"],
         ["max ||p| - 1|, first / last tenth", f"{lr['p_norm_first_tenth']:.1e} / {lr['p_norm_last_tenth']:.1e}",
          f"{lr['comp_p_norm_first_tenth']:.1e} / {lr['comp_p_norm_last_tenth']:.1e}", "-"]],
    )

    st = stress_cases()
    _print_table(
        "Stress cases of the exact solution (E, L, |p| over t <= 1e3 s; vs DOP853 rtol 1e-13 over t <= 20 s)",
        ["case", "kind", "finite", "max|dE|/E", "max|dL|/|L|", "max||p|-1|", "vs DOP853"],
        [[r["case"], r["kind"], str(r["finite"]), f"{r['energy']:.1e}", f"{r['L']:.1e}", f"{r['p_norm']:.1e}",
          f"{r['vs_dop853']:.1e}"] for r in st],
    )

    (OUT / "work_precision.json").write_text(json.dumps(
        dict(quick=quick, rows=all_rows, exact_us_per_point=per_point * 1e6, exact_us_per_frame=per_frame * 1e6,
             ratios=summary, long_run=lr, stress=st), indent=1))
    _plot(rows, rows_stiff, exact_frames_cpu, T, T_stiff)
    print(f"\nwrote {OUT / 'work_precision.png'} and {OUT / 'work_precision.json'}")


def _plot(rows, rows_stiff, exact_cpu, T, T_stiff):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    markers = {"rk4": "o-", "midpoint": "s-", "splitting": "^-", "splitting4": "v-", "splitting6": "D-", "splitting8": "P-",
               "RK45": "x--", "DOP853": "+--", "LSODA": "*--"}
    for ax, case_rows, title in ((axes[0], rows, f"free asymmetric body, T = {T:g} s"),
                                 (axes[1], rows_stiff, f"stiff: spin 1e3 x transverse rate, T = {T_stiff:g} s")):
        for method, style in markers.items():
            pts = sorted((r["error"], r["cpu"]) for r in case_rows if r["method"] == method)
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, label=method)
        if case_rows is rows:
            ax.axhline(exact_cpu, color="k", lw=0.8, ls=":", label="exact, all 60 fps frames")
        ax.set_xlabel("error vs exact (max over checkpoints)")
        ax.set_ylabel("CPU time (s)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.invert_xaxis()
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT / "work_precision.png", dpi=120)
    plt.close(fig)


# ------------------------------------------------------------------ part "chains"
CHAIN_LINKS = (2, 10, 30, 100)
QUICK_CHAIN_LINKS = (2, 10)
CHAIN_T_END = 10.0
CHAIN_FPS = 60
CHAIN_TILT = 0.5
LINK_LENGTH = 1.0  # m, pendulum_chain's default
CHAIN_TARGETS = (1e-3, 1e-6, 1e-9)
#: CPU seconds above which the next run of a curve is not made (its finer errors are "not reached").
CPU_CAP = 20.0
QUICK_CPU_CAP = 5.0
#: A curve stops once a run is this accurate.
ERROR_FLOOR = 1e-11
REFERENCE_TOL = 1e-13
FIGURE = Path(__file__).resolve().parent.parent / "docs" / "img" / "work_precision_chains.png"


def _settings(quick: bool) -> dict:
    """Per curve: (engine, path label, list of knobs from coarse to fine)."""
    rtols = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
    ks = [1, 2, 4, 8, 16, 32, 64, 128, 256]
    if quick:
        rtols, ks = [1e-3, 1e-5, 1e-7, 1e-9, 1e-11], [1, 4, 16, 64]
    return {
        "rigidlab DOP853": ("rigidlab", "DOP853 rtol", rtols),
        "rigidlab rk4": ("rigidlab", "rk4 dt = 1/(60 k)", ks[:6] if not quick else ks[:3]),
        "MuJoCo RK4": ("MuJoCo", "RK4 dt = 1/(60 k)", ks),
        "MuJoCo implicitfast": ("MuJoCo", "implicitfast dt = 1/(60 k)", [k * 4 for k in ks][:7] if not quick
                                else [4, 16, 64, 256]),
        "Pinocchio DOP853": ("Pinocchio", "aba in solve_ivp DOP853 rtol", rtols),
        "Exudyn tree RK44": ("Exudyn", "ObjectKinematicTree RK44 dt = 1/(60 k)", ks),
        "Exudyn tree DOPRI5": ("Exudyn", "ObjectKinematicTree DOPRI5 rtol = atol", rtols[1:]),
    }


def _knob_text(curve: str, knob) -> str:
    return f"rtol {knob:g}" if "DOP" in curve else f"dt 1/{CHAIN_FPS * knob}"


class ChainCase:
    """The n-link chain: output times, reference tip, the rigidlab System and the tree for the peers."""

    def __init__(self, n: int):
        from multibody import chain_tree

        from rigidlab.core.models import pendulum_chain, pendulum_chain_reduced

        self.n = n
        self.t = np.linspace(0.0, CHAIN_T_END, round(CHAIN_T_END * CHAIN_FPS) + 1)
        t0 = time.process_time()
        ref = pendulum_chain_reduced(n, self.t, tilt=CHAIN_TILT, rtol=REFERENCE_TOL, atol=REFERENCE_TOL)
        self.reference_cpu = time.process_time() - t0
        # the tip from the reference's absolute angles, sum_k L e(phi_k)
        phi = ref.angles
        self.tip = LINK_LENGTH * np.stack([np.zeros_like(phi), np.sin(phi), -np.cos(phi)], axis=-1).sum(axis=1)
        self.system = pendulum_chain(n, tilt=CHAIN_TILT)
        self.tree = chain_tree(n, system=self.system, tilt=CHAIN_TILT)
        state = self.system.state
        last = self.system.bodies[-1]
        A = state.rotation_matrix(last)
        # body frame of the last link: its centre to its free end (uniform rod: the centre is mid-length)
        self.tip_body = A.T @ (state.position(last) - np.asarray(self.system.joints[-1].point, dtype=float))

    def error(self, tip: np.ndarray) -> float:
        return float(np.linalg.norm(tip - self.tip, axis=-1).max())


def _quat_matrix(p: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices of Euler parameters ``p`` (..., 4), scalar first."""
    w, x, y, z = np.moveaxis(p, -1, 0)
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def run_rigidlab(case: ChainCase, method: str, knob) -> tuple[np.ndarray, float]:
    """(tip (n_out, 3), CPU s) of ``System.simulate``."""
    if method == "DOP853":
        kwargs = {"method": "DOP853", "rtol": knob, "atol": knob * 1e-2}
    else:
        kwargs = {"method": "rk4", "dt": 1.0 / (CHAIN_FPS * knob)}
    t0 = time.process_time()
    traj = case.system.simulate(case.t, **kwargs)
    cpu = time.process_time() - t0
    n = case.n
    R = traj.q[:, 3 * (n - 1):3 * n]
    p = traj.q[:, 3 * n + 4 * (n - 1):7 * n]
    return R + _quat_matrix(p) @ case.tip_body, cpu


def run_mujoco(case: ChainCase, integrator: str, k: int) -> tuple[np.ndarray, float]:
    """(tip, CPU s) of MuJoCo at ``timestep`` 1/(60 k), positions after ``mj_kinematics`` at each output."""
    import mujoco
    from multibody import mujoco_model

    xml, qvel, names = mujoco_model(case.system, "chain", 1.0 / (CHAIN_FPS * k))
    xml = xml.replace('integrator="RK4"', f'integrator="{integrator}"')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[:] = qvel
    mujoco.mj_forward(m, d)
    last = m.body(names[-1]).id
    pos = np.empty((case.t.size, 3))
    rot = np.empty((case.t.size, 9))
    pos[0], rot[0] = d.xpos[last], d.xmat[last]
    t0 = time.process_time()
    for i in range(1, case.t.size):
        mujoco.mj_step(m, d, nstep=k)
        mujoco.mj_kinematics(m, d)
        pos[i], rot[i] = d.xpos[last], d.xmat[last]
    cpu = time.process_time() - t0
    return pos + rot.reshape(-1, 3, 3) @ case.tip_body, cpu  # body frame = rigidlab's (mujoco_model)


def run_pinocchio(case: ChainCase, rtol: float) -> tuple[np.ndarray, float]:
    """(tip, CPU s) of ``pin.aba`` as the right-hand side of ``solve_ivp`` DOP853."""
    import pinocchio as pin
    from multibody import chain_angles0, pinocchio_chain_model, tree_points
    from scipy.integrate import solve_ivp

    model, data = pinocchio_chain_model(pin, case.tree)
    n = case.n
    tau = np.zeros(n)
    aba = pin.aba

    def rhs(_t, y):
        return np.concatenate([y[n:], aba(model, data, y[:n], y[n:], tau)])

    y0 = np.concatenate([chain_angles0(n), np.zeros(n)])
    t0 = time.process_time()
    sol = solve_ivp(rhs, (case.t[0], case.t[-1]), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2, t_eval=case.t)
    cpu = time.process_time() - t0
    if not sol.success:
        raise RuntimeError(sol.message)
    return tree_points(case.tree, sol.y[:n].T)[1], cpu


def run_exudyn(case: ChainCase, solver: str, knob) -> tuple[np.ndarray, float]:
    """(tip, CPU s) of Exudyn's ObjectKinematicTree with RK44 (dt 1/(60 knob)) or DOPRI5 (rtol = atol = knob)."""
    import multibody as mb

    exu = mb._import_exudyn()
    _container, mbs, node = mb.exudyn_tree_model(exu, case.tree, mb.chain_angles0(case.n))
    settings_case = type("C", (), {"t": case.t})
    if solver == "RK44":
        from exudyn.utilities import SensorNode

        sensor = mbs.AddSensor(SensorNode(nodeNumber=node, storeInternal=True, writeToFile=False,
                                          outputVariableType=exu.OutputVariableType.Coordinates))
        mbs.Assemble()
        settings = mb._exudyn_settings(exu, settings_case, knob * (case.t.size - 1))
        t0 = time.process_time()
        mbs.SolveDynamic(settings, solverType=exu.DynamicSolverType.RK44)
        cpu = time.process_time() - t0
        data = mbs.GetSensorStoredData(sensor)
        rows = np.searchsorted(data[:, 0], case.t - 0.25 / (CHAIN_FPS * knob))
        q = data[np.minimum(rows, len(data) - 1), 1:]
        return mb.tree_points(case.tree, q)[1], cpu
    mbs.Assemble()
    settings = mb._exudyn_settings(exu, settings_case, case.t.size - 1)
    integration = settings.timeIntegration
    integration.solverType = exu.DynamicSolverType.DOPRI5
    integration.automaticStepSize = True
    integration.relativeTolerance = integration.absoluteTolerance = knob
    solver_ = exu.MainSolverExplicit()
    q = np.empty((case.t.size, case.n))
    t0 = time.process_time()
    solver_.InitializeSolver(mbs, settings)
    q[0] = mbs.systemData.GetODE2Coordinates()
    for i in range(1, case.t.size):
        solver_.it.endTime = float(case.t[i])
        solver_.SolveSteps(mbs, settings)
        q[i] = mbs.systemData.GetODE2Coordinates()
    solver_.FinalizeSolver(mbs, settings)
    cpu = time.process_time() - t0
    if abs(solver_.it.currentTime - case.t[-1]) > 1e-9:
        raise RuntimeError(f"DOPRI5 stopped at t = {solver_.it.currentTime:g} s")
    return mb.tree_points(case.tree, q)[1], cpu


RUNNERS = {
    "rigidlab DOP853": lambda c, k: run_rigidlab(c, "DOP853", k),
    "rigidlab rk4": lambda c, k: run_rigidlab(c, "rk4", k),
    "MuJoCo RK4": lambda c, k: run_mujoco(c, "RK4", k),
    "MuJoCo implicitfast": lambda c, k: run_mujoco(c, "implicitfast", k),
    "Pinocchio DOP853": run_pinocchio,
    "Exudyn tree RK44": lambda c, k: run_exudyn(c, "RK44", k),
    "Exudyn tree DOPRI5": lambda c, k: run_exudyn(c, "DOPRI5", k),
}
PEER_MODULES = {"MuJoCo": "mujoco", "Pinocchio": "pinocchio", "Exudyn": "exudyn"}


def _available(engine: str) -> bool:
    module = PEER_MODULES.get(engine)
    if module is None:
        return True
    try:
        if module == "exudyn":
            import multibody

            multibody._import_exudyn()
        else:
            __import__(module)
    except ImportError:
        return False
    return True


def _predicted_cpu(curve: str, knob, last: tuple | None) -> float:
    """CPU seconds of the next run predicted from the last one: fixed steps scale with k, DOP853 with
    rtol^(-1/8), DOPRI5 with rtol^(-1/5)."""
    if last is None:
        return 0.0
    k0, cpu0 = last
    if "DOP853" in curve:
        return cpu0 * (k0 / knob) ** (1 / 8)
    if "DOPRI5" in curve:
        return cpu0 * (k0 / knob) ** (1 / 5)
    return cpu0 * knob / k0


def chain_curves(case: ChainCase, settings: dict, cap: float, log=print) -> list[dict]:
    """Every run of every curve on ``case``: dicts (curve, engine, path, knob, setting, cpu, error)."""
    runs = []
    for curve, (engine, path, knobs) in settings.items():
        if not _available(engine):
            log(f"  {curve}: not installed, skipped")
            continue
        last = None
        for knob in knobs:
            predicted = _predicted_cpu(curve, knob, last)
            if predicted > cap:
                log(f"  {curve} {_knob_text(curve, knob)}: skipped (predicted {predicted:.0f} s CPU > cap {cap:g} s)")
                runs.append(dict(curve=curve, engine=engine, path=path, knob=knob, setting=_knob_text(curve, knob),
                                 cpu=None, error=None, note="over the CPU cap"))
                break
            try:
                tip, cpu = RUNNERS[curve](case, knob)
                error = case.error(tip)
                if cpu < 0.5:  # best of up to three short runs
                    cpu = min([cpu] + [RUNNERS[curve](case, knob)[1] for _ in range(2)])
            except Exception as exc:  # a peer's solver failing at a coarse step
                log(f"  {curve} {_knob_text(curve, knob)}: failed: {(str(exc) or type(exc).__name__)[:80]}")
                runs.append(dict(curve=curve, engine=engine, path=path, knob=knob, setting=_knob_text(curve, knob),
                                 cpu=None, error=None, note="failed"))
                continue
            if not math.isfinite(error):
                error = math.inf
            runs.append(dict(curve=curve, engine=engine, path=path, knob=knob, setting=_knob_text(curve, knob),
                             cpu=cpu, error=error, note=""))
            log(f"  {curve} {_knob_text(curve, knob)}: tip error {error:.2e} m, CPU {cpu:.3f} s", flush=True)
            last = (knob, cpu)
            if error < ERROR_FLOOR:
                break
    return runs


def cpu_at(runs: list[dict], target: float) -> tuple[float | None, str]:
    """(CPU s, how) of one curve at tip error ``target``: log-log interpolation on its Pareto front,
    the cheapest run when every run is below the target ("<="), or (None, "not reached")."""
    pts = sorted((r["cpu"], r["error"]) for r in runs if r["cpu"] is not None and math.isfinite(r["error"])
                 and r["error"] > 0)
    front = []
    for cpu, error in pts:  # cheaper first: keep the runs more accurate than every cheaper one
        if not front or error < front[-1][1]:
            front.append((cpu, error))
    if not front or front[-1][1] > target:
        return None, "not reached"
    if front[0][1] <= target:
        return front[0][0], "<="
    for (c0, e0), (c1, e1) in zip(front, front[1:], strict=False):
        if e1 <= target <= e0:
            w = math.log(target / e0) / math.log(e1 / e0)
            return math.exp(math.log(c0) + w * math.log(c1 / c0)), "interpolated"
    return None, "not reached"


def chains_table(results: dict[int, list[dict]]) -> tuple[list[list[str]], list[dict]]:
    """Rows (text) and records of CPU at each target per curve and per engine, ratios against rigidlab."""
    rows, records = [], []
    for n, runs in results.items():
        curves = list(dict.fromkeys(r["curve"] for r in runs))
        for target in CHAIN_TARGETS:
            at = {c: cpu_at([r for r in runs if r["curve"] == c], target) for c in curves}
            engines = list(dict.fromkeys(r["engine"] for r in runs))
            best = {}
            for e in engines:
                reached = [(at[c][0], c) for c in curves if c.startswith(e) and at[c][0] is not None]
                best[e] = min(reached) if reached else (None, None)
            base = best.get("rigidlab", (None, None))[0]
            for e in engines:
                cpu, curve = best[e]
                ratio = cpu / base if (cpu is not None and base) else None
                per_curve = "; ".join(
                    f"{c.split(' ', 1)[1]} {'-' if at[c][0] is None else ('<= ' if at[c][1] == '<=' else '') + f'{at[c][0]:.3g}'}"
                    for c in curves if c.startswith(e))
                rows.append([str(n), f"{target:g}", e, "-" if curve is None else curve.split(" ", 1)[1],
                             "not reached" if cpu is None else f"{cpu:.3g}",
                             "-" if ratio is None or e == "rigidlab" else f"{ratio:.2f}", per_curve])
                records.append(dict(links=n, target=target, engine=e, path=curve, cpu_s=cpu, ratio=ratio,
                                    curves={c: at[c][0] for c in curves if c.startswith(e)}))
    return rows, records


def _plot_chains(results: dict[int, list[dict]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = {"rigidlab DOP853": ("k", "o-"), "rigidlab rk4": ("k", "s--"), "MuJoCo RK4": ("tab:blue", "^-"),
              "MuJoCo implicitfast": ("tab:blue", "v--"), "Pinocchio DOP853": ("tab:orange", "D-"),
              "Exudyn tree RK44": ("tab:green", "P-"), "Exudyn tree DOPRI5": ("tab:green", "x--")}
    ncols = 2
    nrows = math.ceil(len(results) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(9, 3.4 * nrows), squeeze=False)
    for ax, (n, runs) in zip(axes.flat, results.items(), strict=False):
        for curve, (color, style) in styles.items():
            pts = [(r["error"], r["cpu"]) for r in runs if r["curve"] == curve and r["cpu"] is not None
                   and math.isfinite(r["error"])]
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, color=color, label=curve, ms=4, lw=1)
        for target in CHAIN_TARGETS:
            ax.axvline(target, color="0.8", lw=0.6, zorder=0)
        ax.set_title(f"{n} links, T = {CHAIN_T_END:g} s", fontsize=9)
        ax.set_xlabel("tip error (m)", fontsize=8)
        ax.set_ylabel("CPU (s)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="major", alpha=0.3)
        ax.invert_xaxis()
    for ax in list(axes.flat)[len(results):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6.5, loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def chains_main(quick: bool) -> None:
    """Part "chains": tip error against CPU for pendulum chains, rigidlab and its peers."""
    import multibody

    started = time.perf_counter()
    links = QUICK_CHAIN_LINKS if quick else CHAIN_LINKS
    cap = QUICK_CPU_CAP if quick else CPU_CAP
    settings = _settings(quick)
    revision, machine, versions = multibody.git_revision(), multibody._machine(), multibody._versions()
    print(f"# work-precision, pendulum chains{' (quick)' if quick else ''}, {datetime.date.today().isoformat()}, "
          f"rigidlab {revision}")
    print(f"{machine}; " + ", ".join(f"{k} {v}" for k, v in versions.items()))
    print(f"T = {CHAIN_T_END:g} s, outputs at {CHAIN_FPS} Hz; tip error = largest distance of the last link's end "
          f"from the reference; CPU = process time; cap {cap:g} s per run\n")
    from rigidlab.core._warm import warm

    # compile or load the kernels before any run is timed (a stale cache would put a compile in the first point)
    print(f"kernels ready ({warm():.1f} s of CPU, not counted below)\n", flush=True)
    results = {}
    references = {}
    for n in links:
        case = ChainCase(n)
        references[n] = case.reference_cpu
        print(f"[{n} links] reference: reduced angles, DOP853 rtol {REFERENCE_TOL:g}, CPU {case.reference_cpu:.1f} s",
              flush=True)
        results[n] = chain_curves(case, settings, cap)
    rows, records = chains_table(results)
    _print_table("CPU (s) at equal tip error (ratio = engine / rigidlab, same run; > 1: rigidlab is faster; "
                 "'<=': every run of the curve is below the target, its cheapest)",
                 ["links", "tip error", "engine", "best path", "CPU s", "vs rigidlab", "per path (CPU s)"], rows)
    figure = OUT / "work_precision_chains.png" if quick else FIGURE
    _plot_chains(results, figure)
    elapsed = time.perf_counter() - started
    OUT.mkdir(exist_ok=True)
    (OUT / "work_precision_chains.json").write_text(json.dumps(dict(
        date=datetime.date.today().isoformat(), rigidlab=revision, machine=machine, versions=versions, quick=quick,
        t_end=CHAIN_T_END, fps=CHAIN_FPS, cpu_cap_s=cap, targets=list(CHAIN_TARGETS), reference_cpu_s=references,
        runs={str(n): r for n, r in results.items()}, table=records, wall_s=elapsed), indent=1))
    print(f"\n(part chains wall time {elapsed:.0f} s)\nwrote {OUT / 'work_precision_chains.json'} and {figure}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("both", "chains", "free-body"), default="both",
                        help="which benchmark: the pendulum chains, the free body, or both (default, chains first)")
    parser.add_argument("--quick", action="store_true",
                        help="chains: 2 and 10 links, fewer settings; free body: shorter horizons")
    args = parser.parse_args(argv)
    if args.part in ("both", "chains"):
        chains_main(args.quick)
    if args.part in ("both", "free-body"):
        free_body_main(args.quick)


if __name__ == "__main__":
    main()
