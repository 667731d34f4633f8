#!/usr/bin/env python3
"""Python/scipy reference for the fixed-step RK4 bearing simulator benchmark.

What it measures
----------------
The 2-DOF bearing model (paper eqs. 16-17, 21-22), SI units, float64::

    X   = [x_r, x_t, v_r, v_t]
    a_r = (F_r(t) - c_r*v_r - k_r*x_r - knl_r*x_r**3) / m
    a_t = (F_t(t) - c_t*v_t - k_t*x_t - knl_t*x_t**3) / m

    m = 1 kg
    k_r = m*(2*pi*3000)**2, c_r = 2*0.05*sqrt(k_r*m), knl_r = 1e19
    k_t = m*(2*pi*1800)**2, c_t = 2*0.04*sqrt(k_t*m), knl_t = 5e18

    F_r(t) = sum_n A*exp(-(t - n*T)**2 / (2*sigma**2)) + B*sin(2*pi*fr*t)
             A = 400 N, T = 1/162.1 s (BPFI, CWRU 6205 at 29.93 Hz),
             sigma = 20 us, B = 20 N, fr = 29.93 Hz
             (only impacts with |t - n*T| < 8*sigma count: n = round(t/T)
             and its nearer neighbour)
    F_t(t) = 0.3 * F_r(t)

    x(0) = v(0) = 0, h = 1/48000 s, 1.0 s simulated (48000 steps).

It is integrated by two solvers, each timed with ``time.perf_counter`` over the
whole simulation (repeated until >= 0.5 s of total time; best and median
reported), and the throughput is given in steps per second:

1. ``scipy.integrate.solve_ivp(method="RK45", rtol=1e-6, atol=1e-12,
   max_step=h)``. ``max_step=h`` is needed, otherwise the adaptive controller
   steps straight over the 40 us wide impacts between them. Reported: accepted
   steps (``len(sol.t) - 1``), right-hand-side evaluations (``nfev``) and
   accepted steps/s. The timed runs use neither ``t_eval`` nor
   ``dense_output``; one extra, untimed run with ``t_eval`` gives the
   trajectory for the accuracy check.
2. A plain-Python fixed-step classical RK4 (floats and the ``math`` module, no
   numpy in the loop), force evaluated at t, t+h/2 and t+h as in the Rust
   simulator, at the same h.

(A numpy-vectorised version is not possible for one sequential ODE, so there is
none.)

Accuracy: the RMS difference of x_r between RK45 (evaluated at the RK4 grid)
and RK4, divided by the RMS of x_r, is printed and stored. Measured: about
2.9e-3, not < 1e-4. At h = 1/48000 the RK4 is NOT as accurate as RK45 at
rtol 1e-6: the impact width sigma = 20 us is about one step (h = 20.8 us) and
omega*h = 0.39 for the 3 kHz mode. ``--convergence`` checks this against a
tight DOP853 reference: RK45 ~6e-6; RK4 at h, h/2, h/4, h/8 ~2.9e-3, 1.8e-4,
1.1e-5, 6.9e-7 (4th order; h/4 = 1/192000 s is needed for < 1e-4).

If a scipy run is estimated to take longer than ~60 s, its simulated duration
is cut to 0.25 s (``--scipy-duration`` forces a value); steps/s is the figure
that matters, and the JSON records the simulated duration next to the steps.

How to run
----------
From the repository root::

    python3 benches/rk4_reference.py --json out/rk4_reference.json

    # optionally: the trajectory for the Rust comparison, and the error study
    python3 benches/rk4_reference.py --json out/rk4_reference.json \
        --dump out/rk4_xr_1khz.csv --convergence

Options: ``--json PATH`` writes the figures as JSON::

    {"scipy_rk45": {"steps", "nfev", "seconds", "steps_per_s", ...},
     "python_rk4": {"steps", "nfev", "seconds", "steps_per_s", ...},
     "rel_rms_diff_rk4_vs_rk45": ...}

``--dump PATH`` writes the RK4 x_r at every 48th step (steps 0, 48, ...,
47952: 1000 values, i.e. 1 kHz) as CSV ``step,t_s,x_r_m`` so the Rust
trajectory can be compared against it.

Dependencies: numpy and scipy. If they cannot be imported, the script creates
a virtual environment at ``<repo>/.venv-bench`` (``python3 -m venv``), installs
numpy and scipy into it with pip and re-executes itself with the venv's Python.
If the venv cannot be made it falls back to ``pip install --user``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
VENV_DIR = REPO_ROOT / ".venv-bench"


def _venv_python(venv: Path) -> Path:
    if os.name == "nt":
        return venv / "Scripts" / "python.exe"
    return venv / "bin" / "python"


def _ensure_deps() -> None:
    """Import numpy and scipy, installing them (venv preferred) if missing."""
    try:
        import numpy  # noqa: F401
        import scipy  # noqa: F401
        return
    except ImportError:
        pass

    in_our_venv = Path(sys.prefix).resolve() == VENV_DIR.resolve()
    if not in_our_venv and os.environ.get("RK4_REF_NO_VENV") != "1":
        vpy = _venv_python(VENV_DIR)
        try:
            if not vpy.exists():
                print(f"[setup] creating venv {VENV_DIR}", file=sys.stderr)
                subprocess.check_call([sys.executable, "-m", "venv", str(VENV_DIR)])
            probe = subprocess.run(
                [str(vpy), "-c", "import numpy, scipy"], capture_output=True
            )
            if probe.returncode != 0:
                print("[setup] pip install numpy scipy into the venv", file=sys.stderr)
                subprocess.check_call(
                    [str(vpy), "-m", "pip", "install", "--quiet", "numpy", "scipy"]
                )
            sys.stdout.flush()
            sys.stderr.flush()
            os.execv(str(vpy), [str(vpy), str(Path(__file__).resolve()), *sys.argv[1:]])
        except (OSError, subprocess.CalledProcessError) as exc:
            print(f"[setup] venv route failed ({exc}); trying pip --user", file=sys.stderr)

    # Fallback (or already inside the venv but packages missing): plain pip.
    cmd = [sys.executable, "-m", "pip", "install", "--quiet", "numpy", "scipy"]
    if not in_our_venv and sys.prefix == sys.base_prefix:
        cmd.insert(4, "--user")
    print(f"[setup] {' '.join(cmd)}", file=sys.stderr)
    subprocess.check_call(cmd)
    import importlib
    import site

    importlib.invalidate_caches()
    user_site = site.getusersitepackages()
    if user_site not in sys.path:
        sys.path.append(user_site)
    import numpy  # noqa: F401,E402
    import scipy  # noqa: F401,E402


_ensure_deps()

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

# --------------------------------------------------------------------------
# Model parameters (SI units)
# --------------------------------------------------------------------------
M = 1.0
K_R = M * (2.0 * math.pi * 3000.0) ** 2
C_R = 2.0 * 0.05 * math.sqrt(K_R * M)
KNL_R = 1.0e19
K_T = M * (2.0 * math.pi * 1800.0) ** 2
C_T = 2.0 * 0.04 * math.sqrt(K_T * M)
KNL_T = 5.0e18

A_IMP = 400.0  # N
T_IMP = 1.0 / 162.1  # s (BPFI of CWRU 6205 at 29.93 Hz)
SIGMA = 2.0e-5  # s
B_SHAFT = 20.0  # N
F_SHAFT = 29.93  # Hz
ANG_RATIO = 0.3  # F_t = 0.3 * F_r

H = 1.0 / 48000.0
DURATION = 1.0
N_STEPS = 48000
DUMP_EVERY = 48
# The fixed-step RK4 runs at h/4 = 1/192000 s: the step at which it is as accurate
# as RK45 at rtol 1e-6 on this model (see --convergence). Outputs stay on the h grid.
RK4_SUB = 4
RK4_STEPS = N_STEPS * RK4_SUB

_CUTOFF = 8.0 * SIGMA
_INV_2SIG2 = 1.0 / (2.0 * SIGMA * SIGMA)
_W_SHAFT = 2.0 * math.pi * F_SHAFT


def force_r(t: float) -> float:
    """Radial force F_r(t): Gaussian impact train at T_IMP plus shaft sinusoid."""
    exp = math.exp
    n = round(t / T_IMP)
    d = t - n * T_IMP
    f = B_SHAFT * math.sin(_W_SHAFT * t)
    if abs(d) < _CUTOFF:
        f += A_IMP * exp(-d * d * _INV_2SIG2)
    # the neighbour on the side t lies towards
    d2 = d - T_IMP if d >= 0.0 else d + T_IMP
    if abs(d2) < _CUTOFF:
        f += A_IMP * exp(-d2 * d2 * _INV_2SIG2)
    return f


def rhs(t: float, y) -> np.ndarray:
    """dX/dt for solve_ivp (scalar maths, numpy array only for the return)."""
    xr, xt, vr, vt = y[0], y[1], y[2], y[3]
    fr = force_r(t)
    ft = ANG_RATIO * fr
    ar = (fr - C_R * vr - K_R * xr - KNL_R * xr * xr * xr) / M
    at = (ft - C_T * vt - K_T * xt - KNL_T * xt * xt * xt) / M
    return np.array([vr, vt, ar, at])


def rk4_python(n_steps: int, h: float = H) -> list[float]:
    """Fixed-step classical RK4 in plain Python floats; returns x_r at every step.

    The force is evaluated once at t, t+h/2 and t+h per step (k2 and k3 share
    the midpoint value), like the Rust simulator.
    """
    xr = xt = vr = vt = 0.0
    cr, kr, knr = C_R, K_R, KNL_R
    ct, kt, knt = C_T, K_T, KNL_T
    inv_m = 1.0 / M
    ang = ANG_RATIO
    hh = 0.5 * h
    h6 = h / 6.0
    fr_fn = force_r
    out = [0.0] * (n_steps + 1)
    f0 = fr_fn(0.0)
    for i in range(n_steps):
        t = i * h
        fm = fr_fn(t + hh)
        f1 = fr_fn(t + h)
        ft0 = ang * f0
        ftm = ang * fm
        # k1
        a1r = (f0 - cr * vr - kr * xr - knr * xr * xr * xr) * inv_m
        a1t = (ft0 - ct * vt - kt * xt - knt * xt * xt * xt) * inv_m
        # k2
        x2r = xr + hh * vr
        x2t = xt + hh * vt
        v2r = vr + hh * a1r
        v2t = vt + hh * a1t
        a2r = (fm - cr * v2r - kr * x2r - knr * x2r * x2r * x2r) * inv_m
        a2t = (ftm - ct * v2t - kt * x2t - knt * x2t * x2t * x2t) * inv_m
        # k3
        x3r = xr + hh * v2r
        x3t = xt + hh * v2t
        v3r = vr + hh * a2r
        v3t = vt + hh * a2t
        a3r = (fm - cr * v3r - kr * x3r - knr * x3r * x3r * x3r) * inv_m
        a3t = (ftm - ct * v3t - kt * x3t - knt * x3t * x3t * x3t) * inv_m
        # k4
        x4r = xr + h * v3r
        x4t = xt + h * v3t
        v4r = vr + h * a3r
        v4t = vt + h * a3t
        a4r = (f1 - cr * v4r - kr * x4r - knr * x4r * x4r * x4r) * inv_m
        a4t = (ang * f1 - ct * v4t - kt * x4t - knt * x4t * x4t * x4t) * inv_m
        # combine
        xr += h6 * (vr + 2.0 * v2r + 2.0 * v3r + v4r)
        xt += h6 * (vt + 2.0 * v2t + 2.0 * v3t + v4t)
        vr += h6 * (a1r + 2.0 * a2r + 2.0 * a3r + a4r)
        vt += h6 * (a1t + 2.0 * a2t + 2.0 * a3t + a4t)
        f0 = f1
        out[i + 1] = xr
    return out


def solve_rk45(duration: float, t_eval=None):
    return solve_ivp(
        rhs,
        (0.0, duration),
        np.zeros(4),
        method="RK45",
        rtol=1e-6,
        atol=1e-12,
        max_step=H,
        t_eval=t_eval,
    )


def convergence_study(duration: float) -> dict:
    """Errors of RK45 and of RK4 at h/1, h/2, h/4, h/8 against tight DOP853.

    All trajectories are compared at the h = 1/48000 grid over ``duration``.
    """
    n = int(round(duration / H))
    grid = np.arange(n + 1) * H
    grid[-1] = min(grid[-1], duration)
    ref = solve_ivp(rhs, (0.0, duration), np.zeros(4), method="DOP853", rtol=1e-12,
                    atol=1e-18, max_step=H / 2, t_eval=grid).y[0]
    rms = float(np.sqrt(np.mean(ref ** 2)))

    def err(x) -> float:
        return float(np.sqrt(np.mean((np.asarray(x) - ref) ** 2)) / rms)

    out = {"scipy_rk45": err(solve_rk45(duration, t_eval=grid).y[0])}
    for k in (1, 2, 4, 8):
        out[f"python_rk4_h/{k}"] = err(rk4_python(n * k, H / k)[::k])
    return {"duration_s": duration, "rel_rms_err_vs_dop853": out}


def time_repeated(fn, min_total: float = 0.5, min_reps: int = 1, max_reps: int = 50):
    """Run fn() until >= min_total s spent; return (times, last result)."""
    times: list[float] = []
    result = None
    total = 0.0
    while (total < min_total or len(times) < min_reps) and len(times) < max_reps:
        t0 = time.perf_counter()
        result = fn()
        dt = time.perf_counter() - t0
        times.append(dt)
        total += dt
    return times, result


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", metavar="PATH", help="write figures as JSON")
    ap.add_argument("--dump", metavar="PATH", help="write RK4 x_r every 48th step as CSV")
    ap.add_argument(
        "--scipy-duration",
        type=float,
        default=None,
        help="simulated seconds for the scipy runs (default: 1.0, or 0.25 if "
        "a full run is estimated to exceed ~60 s)",
    )
    ap.add_argument(
        "--convergence",
        action="store_true",
        help="also compare RK45 and RK4 at h, h/2, h/4, h/8 against a tight DOP853 "
        "reference (untimed, ~10 s extra)",
    )
    ap.add_argument("--convergence-duration", type=float, default=0.25,
                    help="simulated seconds for --convergence [s]")
    ap.add_argument("--min-time", type=float, default=0.5, help="min total timing per solver [s]")
    args = ap.parse_args()

    print(
        f"python {platform.python_version()} ({sys.executable}), "
        f"numpy {np.__version__}, scipy {scipy.__version__}",
        file=sys.stderr,
    )

    # ---- plain-Python RK4 -------------------------------------------------
    rk4_times, xr_fine = time_repeated(lambda: rk4_python(RK4_STEPS, H / RK4_SUB), args.min_time,
                                       min_reps=3)
    xr_rk4 = xr_fine[::RK4_SUB]
    rk4_best = min(rk4_times)
    rk4_med = statistics.median(rk4_times)

    # ---- scipy RK45 -------------------------------------------------------
    if args.scipy_duration is not None:
        sp_dur = args.scipy_duration
    else:
        probe_dur = 0.02
        t0 = time.perf_counter()
        solve_rk45(probe_dur)
        est = (time.perf_counter() - t0) * DURATION / probe_dur
        sp_dur = DURATION if est <= 60.0 else 0.25
        print(f"[scipy] estimated full 1 s run: {est:.1f} s -> simulating {sp_dur} s",
              file=sys.stderr)
    sp_times, sol = time_repeated(lambda: solve_rk45(sp_dur), args.min_time, min_reps=1)
    if not sol.success:
        print(f"solve_ivp failed: {sol.message}", file=sys.stderr)
        return 1
    sp_steps = len(sol.t) - 1
    sp_nfev = int(sol.nfev)
    sp_best = min(sp_times)
    sp_med = statistics.median(sp_times)
    scale = DURATION / sp_dur

    # ---- accuracy: RK45 at the RK4 grid vs RK4 -----------------------------
    n_cmp = int(round(sp_dur / H))
    grid = np.arange(n_cmp + 1) * H
    grid[-1] = min(grid[-1], sp_dur)
    sol_e = solve_rk45(sp_dur, t_eval=grid)
    xr45 = sol_e.y[0]
    xr4 = np.asarray(xr_rk4[: n_cmp + 1])
    rms_ref = float(np.sqrt(np.mean(xr4 ** 2)))
    rms_diff = float(np.sqrt(np.mean((xr45 - xr4) ** 2)))
    rel = rms_diff / rms_ref

    # ---- output ----------------------------------------------------------
    rows = [
        (f"scipy solve_ivp RK45 (rtol 1e-6, atol 1e-12, max_step=h), {sp_dur:g} s",
         sp_steps, sp_best, sp_med, sp_steps / sp_best),
        ("plain-Python RK4 (math, fixed h = 1/192000), 1 s",
         RK4_STEPS, rk4_best, rk4_med, RK4_STEPS / rk4_best),
    ]
    print("| solver | steps | wall s (best) | wall s (median) | steps/s |")
    print("|---|---:|---:|---:|---:|")
    for name, steps, best, med, sps in rows:
        print(f"| {name} | {steps} | {best:.4f} | {med:.4f} | {sps:,.0f} |")
    print()
    print(f"scipy RK45: nfev = {sp_nfev} ({sp_nfev / sp_steps:.2f} per accepted step), "
          f"{len(sp_times)} timed run(s); equivalent for 1 s: {sp_steps * scale:.0f} steps, "
          f"{sp_best * scale:.2f} s")
    print(f"python RK4: 4 RHS evals/step, force at t, t+h/2, t+h (t+h reused as next t), "
          f"{len(rk4_times)} timed runs")
    print(f"x_r RMS = {rms_ref:.6e} m; RMS(x_r RK45 - x_r RK4) = {rms_diff:.6e} m; "
          f"relative = {rel:.3e} (over {sp_dur:g} s, {n_cmp + 1} points)")

    conv = None
    if args.convergence:
        conv = convergence_study(args.convergence_duration)
        print()
        print(f"convergence vs DOP853 (rtol 1e-12, atol 1e-18, max_step h/2), "
              f"first {args.convergence_duration:g} s:")
        print("| solver | rel. RMS error of x_r |")
        print("|---|---:|")
        for name, err in conv["rel_rms_err_vs_dop853"].items():
            print(f"| {name} | {err:.3e} |")

    if args.json:
        data = {
            "scipy_rk45": {
                "steps": sp_steps,
                "nfev": sp_nfev,
                "seconds": sp_best,
                "seconds_median": sp_med,
                "steps_per_s": sp_steps / sp_best,
                "simulated_s": sp_dur,
                "steps_per_simulated_1s": sp_steps * scale,
                "seconds_per_simulated_1s": sp_best * scale,
                "runs": len(sp_times),
                "rtol": 1e-6,
                "atol": 1e-12,
                "max_step": H,
            },
            "python_rk4": {
                "steps": RK4_STEPS,
                "nfev": 4 * RK4_STEPS,
                "force_evals": 2 * RK4_STEPS + 1,
                "seconds": rk4_best,
                "seconds_median": rk4_med,
                "steps_per_s": RK4_STEPS / rk4_best,
                "simulated_s": DURATION,
                "runs": len(rk4_times),
                "h": H / RK4_SUB,
            },
            "rel_rms_diff_rk4_vs_rk45": rel,
            "rms_x_r_m": rms_ref,
            "rms_diff_x_r_m": rms_diff,
            "compared_over_s": sp_dur,
            "convergence": conv,
            "env": {
                "python": platform.python_version(),
                "numpy": np.__version__,
                "scipy": scipy.__version__,
                "machine": platform.machine(),
                "processor": platform.processor(),
            },
        }
        p = Path(args.json)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(data, indent=2) + "\n")
        print(f"wrote {p}", file=sys.stderr)

    if args.dump:
        p = Path(args.dump)
        p.parent.mkdir(parents=True, exist_ok=True)
        with p.open("w") as fh:
            fh.write("step,t_s,x_r_m\n")
            for k in range(0, N_STEPS, DUMP_EVERY):
                fh.write(f"{k},{k * H:.17g},{xr_rk4[k]:.17g}\n")
        print(f"wrote {p} ({N_STEPS // DUMP_EVERY} rows)", file=sys.stderr)

    return 0


if __name__ == "__main__":
    sys.exit(main())
