#!/usr/bin/env bash
# RK4 throughput of the 2-DOF bearing model, Rust vs Python, side by side in one run:
#   bash benches/rk4_compare.sh            (writes out/rk4_compare.md)
# 1. Rust (release): core_bench — f64/f32 RK4 steps/s at h = 1/192000 s, and
#    features + graph per 2048-sample window; dumps x_r on the 1 kHz grid.
# 2. Python: scipy solve_ivp RK45 (rtol 1e-6) and a plain-Python fixed-step RK4 of
#    the same model and force (benches/rk4_reference.py installs numpy/scipy in a venv).
# 3. Trajectory check: Rust RK4 vs Python RK4 x_r (same algorithm and step).
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out
cargo bench -q -p pumptwin-core --bench core_bench -- \
    --json "$PWD/out/core_bench.json" --dump "$PWD/out/rk4_rust_xr.csv" | tee out/core_bench.md
python3 benches/rk4_reference.py --json out/rk4_reference.json --dump out/rk4_python_xr.csv --convergence \
    | tee out/rk4_reference.md
gcc -O1 benches/fp_peak.c -o out/fp_peak && out/fp_peak > out/fp_peak.json
python3 - <<'PY' | tee out/rk4_compare.md
import csv, json, math
rust = json.load(open("out/core_bench.json"))
py = json.load(open("out/rk4_reference.json"))
a = [float(r["x_r_m"]) for r in csv.DictReader(open("out/rk4_rust_xr.csv"))]
b = [float(r["x_r_m"]) for r in csv.DictReader(open("out/rk4_python_xr.csv"))]
n = min(len(a), len(b))
rms = math.sqrt(sum(v * v for v in b[:n]) / n)
diff = math.sqrt(sum((x - y) ** 2 for x, y in zip(a[:n], b[:n])) / n)
sp = py["scipy_rk45"]["steps_per_s"]
pr = py["python_rk4"]["steps_per_s"]
print("| solver (same model, 1 s simulated) | steps/s | vs scipy RK45 |")
print("|---|---:|---:|")
print(f"| scipy solve_ivp RK45, rtol 1e-6 | {sp:,.0f} | 1x |")
print(f"| plain-Python RK4, h = 1/192000 | {pr:,.0f} | {pr/sp:,.0f}x |")
for k, name in [("rk4_f64_steps_per_s", "Rust RK4 f64, integration"),
                ("rk4_f32_steps_per_s", "Rust RK4 f32, integration"),
                ("rk4_f64_end_to_end_steps_per_s", "Rust RK4 f64, force rendering + integration")]:
    print(f"| {name} | {rust[k]:,.0f} | {rust[k]/sp:,.0f}x |")
print()
print(f"Rust vs Python RK4 trajectory: relative RMS difference of x_r = {diff/rms:.2e} over {n} points")
conv = py.get("convergence") or {}
for name, err in (conv.get("rel_rms_err_vs_dop853") or {}).items():
    print(f"accuracy vs DOP853 (rtol 1e-12): {name}: {err:.2e}")
fp = json.load(open("out/fp_peak.json"))
flops = 116  # per RK4 step of the 2-DOF model: 4 x 16 (rhs) + 24 (stage states) + 28 (update)
bound = fp["scalar_f64_gflops"] * 1e9 / flops
print(f"arithmetic limit: {flops} flops/step at the measured scalar f64 rate {fp['scalar_f64_gflops']:.2f} Gflop/s "
      f"= {bound/1e6:.1f} M steps/s; Rust f64 reaches {rust['rk4_f64_steps_per_s']/bound:.0%} of it")
print(f"features + dynamic graph: {rust['features_graph_s_per_window']*1e6:.0f} us per window (3 nodes x 2048 samples, T = 8)")
PY
