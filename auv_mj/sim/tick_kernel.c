/* Helpers of the executor's tick shared by the batched steps (batch_kernel.c, planar; batch3d_kernel.c, 6-DOF),
 * each the C twin of a Python function, in the same order of floating-point operations. Included, not compiled
 * alone: every function is static. */
#include <math.h>

/* Python's float % (the sign of the divisor), as CPython's float_rem computes it. */
static double py_mod(double x, double y) {
    double mod = fmod(x, y);
    if (mod != 0.0) {
        if ((y < 0.0) != (mod < 0.0)) mod += y;
    } else {
        mod = copysign(0.0, y);
    }
    return mod;
}

/* auv_mj.geometry.wrap_angle of a scalar. */
static double wrap_angle(double angle) { return py_mod(angle + M_PI, 2 * M_PI) - M_PI; }

/* GaussMarkov.advance (auv_mj/sim/ocean.py): the exact transition over dt, then saturation. `p` holds the
 * process's mean, sigma, time constant, low and high from index `mean`; `state` its value and transition. */
static void gauss_markov(double *state, int value, int gdt, int ga, int gb, const double *p, int mean, double dt,
                         double w) {
    if (dt != state[gdt]) {
        state[gdt] = dt;
        state[ga] = exp(-dt / p[mean + 2]);
        state[gb] = p[mean + 1] * sqrt(1.0 - state[ga] * state[ga]);
    }
    double x = p[mean] + state[ga] * (state[value] - p[mean]) + state[gb] * w;
    x = p[mean + 3] > x ? p[mean + 3] : x;
    x = p[mean + 4] < x ? p[mean + 4] : x;
    state[value] = x;
}
