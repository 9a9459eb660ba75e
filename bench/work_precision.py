"""Work-precision benchmark of the free rigid body integrators against the exact solution.

Run from the project root::

    .venv/bin/python bench/work_precision.py           # full run (a few minutes)
    .venv/bin/python bench/work_precision.py --quick   # shorter horizons (~1 min)

What it measures, all in one run:

1. **Work-precision, free asymmetric body** (moments 1, 2, 3; T = 1000 s,
   ~180 polhode periods): for every fixed-step method of
   :mod:`core.integrators` at several steps and scipy's RK45, DOP853 and
   LSODA at several tolerances, the CPU time (``time.process_time``) and
   the error against :func:`core.rigid_body.free_body_exact` at 101
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

Prints tables and writes ``bench/out/work_precision.png`` and
``bench/out/work_precision.json`` (bench/out/ is git-ignored).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from core import integrators as itg
from core import rigid_body as rb

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


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter horizons and fewer settings (~1 min)")
    args = parser.parse_args(argv)
    quick = args.quick
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


if __name__ == "__main__":
    main()
