/* The 6-DOF hydrodynamic step of auv_mj.sim.hydro3d in C (issue 32): the loop of `Hydro3D.bind`, one call per
 * `AUV3DPhysics.step(n)` and none into MuJoCo from Python. The Python loop stays the reference; the two agree
 * to rounding (tests/sim/test_native_kernel_3d.py compares their trajectories).
 *
 * Per step: the fins slew towards their commands at the rate limit; the body force of hydro3d.force_frd is
 * evaluated in Prestero's FRD frame at the velocity relative to the water; it, the buoyancy and an optional
 * world wrench go into qfrc_passive; J^T (M_A + dt K) J goes into the joint-space inertia M, which MuJoCo
 * re-factors; then mj_step2 and mj_step1. nstep = 0 applies once, with no step (mj_forward's accelerations).
 * No MuJoCo header is needed: MuJoCo's functions come as pointers, mjData's arrays as plain doubles.
 */
#include <math.h>

typedef void (*mj_function)(const void *model, void *data);

/* The parameters, in the order auv_mj.sim.native3d.PARAMETERS gives them. */
enum {
    MA_FRD = 0,          /* 36: M_A in FRD, row major */
    MA_FLU = 36,         /* 36: M_A in FLU */
    X_UU = 72, Y_VV, Y_RR, Z_WW, Z_QQ, K_PP, M_WW, M_QQ, N_VV, N_RR,
    Y_UV, Y_UR, Z_UW, Z_UQ, M_UW, M_UQ, N_UV, N_UR, Y_UUDR, N_UUDR, Z_UUDS, M_UUDS, BUOYANCY,
    DRAG,                /* 6: the drag slopes of the implicit damping */
    EXPLICIT = DRAG + 6, /* 6: 1 where only a reversing step is made implicit */
    MASS = EXPLICIT + 6, /* 6: the diagonal of M_RB + M_A */
    FIN_RATE = MASS + 6, RUDDER_LOW, RUDDER_HIGH, STERN_LOW, STERN_HIGH,
    N_PARAMETERS
};

/* The addresses: qpos of the free joint, its first dof, the 21 CSR entries of its 6x6 block (lower triangle
 * row by row), and the index of the rudder's command in `source` (the stern's follows it). */
enum { QPOS, DOF, M_INDEX, FIN_SOURCE = M_INDEX + 21, N_INDICES };

int auv3d_kernel_sizes(int which) { return which == 0 ? N_PARAMETERS : N_INDICES; }

static double slew(double angle, double command, double low, double high, double step) {
    if (command < low) command = low;
    if (command > high) command = high;
    double change = command - angle;
    if (change > step) change = step;
    if (change < -step) change = -step;
    return angle + change;
}

void auv3d_hydro_advance(const void *model, void *data, mj_function factor, mj_function step1,
                        mj_function step2, const double *p, const long *ix, const double *qpos, double *qvel,
                        double *qfrc, double *M, const double *wind, const double *wrench, double *fins,
                        const double *source, int nstep, double dt) {
    static const double T[6] = {1.0, -1.0, -1.0, 1.0, -1.0, -1.0};
    const long qa = ix[QPOS], da = ix[DOF], fs = ix[FIN_SOURCE];
    const double *ma = p + MA_FRD, *mf = p + MA_FLU;
    const int count = nstep > 0 ? nstep : 1;
    for (int k = 0; k < count; ++k) {
        if (dt > 0.0) {
            fins[0] = slew(fins[0], source[fs], p[RUDDER_LOW], p[RUDDER_HIGH], p[FIN_RATE] * dt);
            fins[1] = slew(fins[1], source[fs + 1], p[STERN_LOW], p[STERN_HIGH], p[FIN_RATE] * dt);
        }
        const double rudder = fins[0], stern = fins[1];
        /* R from the unit quaternion (w, x, y, z), as mju_quat2Mat. */
        const double *q = qpos + qa + 3;
        const double q00 = q[0] * q[0], q01 = q[0] * q[1], q02 = q[0] * q[2], q03 = q[0] * q[3];
        const double q11 = q[1] * q[1], q12 = q[1] * q[2], q13 = q[1] * q[3];
        const double q22 = q[2] * q[2], q23 = q[2] * q[3], q33 = q[3] * q[3];
        const double R[9] = {q00 + q11 - q22 - q33, 2 * (q12 - q03), 2 * (q13 + q02),
                             2 * (q12 + q03), q00 - q11 + q22 - q33, 2 * (q23 - q01),
                             2 * (q13 - q02), 2 * (q23 + q01), q00 - q11 - q22 + q33};
        const double *v = qvel + da;
        const double wx = v[0] - wind[0], wy = v[1] - wind[1], wz = v[2] - wind[2];
        double nu[6];
        nu[0] = R[0] * wx + R[3] * wy + R[6] * wz;
        nu[1] = R[1] * wx + R[4] * wy + R[7] * wz;
        nu[2] = R[2] * wx + R[5] * wy + R[8] * wz;
        nu[3] = v[3];
        nu[4] = v[4];
        nu[5] = v[5];
        double n[6], a[6];
        for (int i = 0; i < 6; ++i) n[i] = T[i] * nu[i];
        for (int i = 0; i < 6; ++i) {
            double s = 0.0;
            for (int j = 0; j < 6; ++j) s += ma[6 * i + j] * n[j];
            a[i] = s;
        }
        const double u = n[0], vv = n[1], w = n[2], pp = n[3], qq = n[4], r = n[5];
        const double c1 = qq * w - r * vv, c2 = r * u - pp * w, c3 = pp * vv - qq * u;
        double f[6];
        f[0] = a[1] * r - a[2] * qq + ma[0] * c1;
        f[1] = a[2] * pp - a[0] * r + ma[7] * c2;
        f[2] = a[0] * qq - a[1] * pp + ma[14] * c3;
        f[3] = a[1] * w - a[2] * vv + a[4] * r - a[5] * qq;
        f[4] = a[2] * u - a[0] * w + a[5] * pp - a[3] * r + ma[26] * c3;
        f[5] = a[0] * vv - a[1] * u + a[3] * qq - a[4] * pp + ma[31] * c2;
        const double uu = u * u;
        f[0] += p[X_UU] * fabs(u) * u;
        f[1] += p[Y_VV] * fabs(vv) * vv + p[Y_RR] * fabs(r) * r + p[Y_UV] * u * vv + p[Y_UR] * u * r
                + p[Y_UUDR] * uu * rudder;
        f[2] += p[Z_WW] * fabs(w) * w + p[Z_QQ] * fabs(qq) * qq + p[Z_UW] * u * w + p[Z_UQ] * u * qq
                + p[Z_UUDS] * uu * stern;
        f[3] += p[K_PP] * fabs(pp) * pp;
        f[4] += p[M_WW] * fabs(w) * w + p[M_QQ] * fabs(qq) * qq + p[M_UW] * u * w + p[M_UQ] * u * qq
                + p[M_UUDS] * uu * stern;
        f[5] += p[N_VV] * fabs(vv) * vv + p[N_RR] * fabs(r) * r + p[N_UV] * u * vv + p[N_UR] * u * r
                + p[N_UUDR] * uu * rudder;
        for (int i = 0; i < 6; ++i) f[i] *= T[i];
        double force[3], torque[3];
        for (int i = 0; i < 3; ++i) force[i] = R[3 * i] * f[0] + R[3 * i + 1] * f[1] + R[3 * i + 2] * f[2];
        for (int i = 0; i < 3; ++i) torque[i] = f[3 + i];
        force[2] += p[BUOYANCY];
        if (wrench != 0) {
            for (int i = 0; i < 3; ++i) {
                force[i] += wrench[i];
                torque[i] += R[i] * wrench[3] + R[3 + i] * wrench[4] + R[6 + i] * wrench[5];
            }
        }
        for (int i = 0; i < 3; ++i) {
            qfrc[da + i] += force[i];
            qfrc[da + 3 + i] += torque[i];
        }
        /* J^T (M_A + dt K) J with J = diag(R^T, I): blocks R A11 R^T, R A12, A21 R^T, A22. */
        double A[36];
        for (int i = 0; i < 36; ++i) A[i] = mf[i];
        for (int i = 0; i < 6; ++i) {
            const double speed = fabs(nu[i]);
            double extra;
            if (p[EXPLICIT + i] != 0.0) {
                extra = dt * p[DRAG + i] * speed - p[MASS + i];
                if (extra < 0.0) extra = 0.0;
            } else {
                extra = 2.0 * dt * p[DRAG + i] * speed;
            }
            A[7 * i] += extra;
        }
        double J[36]; /* only the lower triangle is read */
        for (int i = 0; i < 3; ++i) {
            double RA[3]; /* row i of R A11 */
            for (int l = 0; l < 3; ++l) RA[l] = R[3 * i] * A[l] + R[3 * i + 1] * A[6 + l] + R[3 * i + 2] * A[12 + l];
            for (int j = 0; j <= i; ++j) J[6 * i + j] = RA[0] * R[3 * j] + RA[1] * R[3 * j + 1] + RA[2] * R[3 * j + 2];
        }
        for (int i = 3; i < 6; ++i) {
            for (int j = 0; j < 3; ++j) /* A21 R^T */
                J[6 * i + j] = A[6 * i] * R[3 * j] + A[6 * i + 1] * R[3 * j + 1] + A[6 * i + 2] * R[3 * j + 2];
            for (int j = 3; j <= i; ++j) J[6 * i + j] = A[6 * i + j];
        }
        int e = 0;
        for (int i = 0; i < 6; ++i)
            for (int j = 0; j <= i; ++j) M[ix[M_INDEX + e++]] += J[6 * i + j];
        factor(model, data);
        if (nstep) {
            step2(model, data);
            step1(model, data);
        }
    }
}
