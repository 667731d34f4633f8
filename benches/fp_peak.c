/* Scalar f64 arithmetic rate of this machine, for the "how close to the arithmetic
 * limit" line of the RK4 benchmark: 16 independent mul/add chains (throughput) and one
 * dependent add chain (latency). Built and run by benches/rk4_compare.sh:
 *   gcc -O1 benches/fp_peak.c -o out/fp_peak && out/fp_peak
 * -O1 keeps the compiler from vectorizing or folding the chains. */
#include <stdio.h>
#include <time.h>
static double now(void) { struct timespec a; clock_gettime(CLOCK_MONOTONIC, &a); return a.tv_sec + a.tv_nsec * 1e-9; }
int main(void) {
    volatile double seed = 1.0;
    double a0 = seed, a1 = seed, a2 = seed, a3 = seed, a4 = seed, a5 = seed, a6 = seed, a7 = seed;
    double m0 = seed, m1 = seed, m2 = seed, m3 = seed, m4 = seed, m5 = seed, m6 = seed, m7 = seed;
    const long n = 100000000L;
    double best = 1e9, t;
    for (int rep = 0; rep < 3; rep++) {
        t = now();
        for (long i = 0; i < n; i++) {
            a0 += 1e-9; a1 += 1e-9; a2 += 1e-9; a3 += 1e-9; a4 += 1e-9; a5 += 1e-9; a6 += 1e-9; a7 += 1e-9;
            m0 *= 1.0000001; m1 *= 1.0000001; m2 *= 1.0000001; m3 *= 1.0000001;
            m4 *= 1.0000001; m5 *= 1.0000001; m6 *= 1.0000001; m7 *= 1.0000001;
        }
        t = now() - t;
        if (t < best) best = t;
    }
    double sink = a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7 + m0 + m1 + m2 + m3 + m4 + m5 + m6 + m7;
    double x = seed;
    t = now();
    for (long i = 0; i < 4 * n; i++) x = x + 1e-9;
    t = now() - t;
    printf("{\"scalar_f64_gflops\": %.3f, \"dependent_add_per_ns\": %.3f, \"sink\": %g}\n",
           16.0 * n / best / 1e9, 4.0 * n / t / 1e9, sink + x);
    return 0;
}
