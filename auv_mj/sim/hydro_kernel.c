/* The hydrodynamic step of auv_mj.hydrodynamics (Eq. 3-11 of Lyu et al. 2023) in C.
 *
 * This is `Hydrodynamics.bind`'s Python loop written again, statement for statement and in the same order
 * of floating-point operations, so that it gives the same bits (built with -ffp-contract=off and the
 * libm sin/cos that CPython's math module calls; tests/sim/test_hydrodynamics.py compares the two). It exists
 * because the loop runs between MuJoCo's mj_step1 and mj_step2 on every physics step: from Python that is
 * three calls into MuJoCo per step, here it is none, and one call per `AUVPhysics.step(n)`.
 *
 * It needs no MuJoCo header: MuJoCo's functions come as pointers and the arrays of mjData as plain
 * doubles, all taken from the Python bindings by auv_mj/native.py.
 */
#include <math.h>

typedef void (*mj_function)(const void *model, void *data);

/* Coefficients, in the order auv_mj.hydrodynamics.KERNEL_COEFFICIENTS gives them. */
enum {
    A11, A22, A23, A33, MUNK, NEG_MUNK, X_UU, Y_UV, Y_UR, N_UV, N_UR,
    Y_VV, Y_VR, Y_RV, Y_RR, N_VV, N_VR, N_RV, N_RR, K_U, K_V, K_R, SWAY_MASS, CROSS_FLOW, N_COEFFICIENTS
};

/* Addresses, in the order auv_mj.hydrodynamics.KERNEL_INDICES gives them. */
enum { I_PSI, IX, IY, IR, M_XX, M_YX, M_YY, M_RX, M_RY, M_RR, N_INDICES };

int auv_kernel_sizes(int which) { return which == 0 ? N_COEFFICIENTS : N_INDICES; }

/* `nstep` steps of: Eq. (3)-(11) into qfrc_passive and R (M_A + dt K) R^T into M, mj_factorM, then
 * mj_step2 and mj_step1. nstep = 0 applies once and factors, with no step (for mj_forward's accelerations).
 * `wrench` is the world-frame disturbance (fx, fy, mz) added at every step, or NULL. */
void auv_hydro_advance(const void *model, void *data, mj_function factor, mj_function step1,
                       mj_function step2, const double *p, const long *ix, double *qpos, double *qvel,
                       double *qfrc, double *M, const double *wind, const double *wrench, int nstep,
                       double dt) {
    const double wx = wind[0], wy = wind[1]; /* the current changes between calls, not within one */
    const double implicit_u = 2.0 * dt * p[K_U], implicit_v = dt * p[K_V], implicit_r = 2.0 * dt * p[K_R];
    const double a11 = p[A11], a22 = p[A22], a23 = p[A23], a33 = p[A33];
    const double munk = p[MUNK], neg_munk = p[NEG_MUNK], sway_mass = p[SWAY_MASS];
    const double X_uu = p[X_UU], Y_uv = p[Y_UV], Y_ur = p[Y_UR], N_uv = p[N_UV], N_ur = p[N_UR];
    const double Y_vv = p[Y_VV], Y_vr = p[Y_VR], Y_rv = p[Y_RV], Y_rr = p[Y_RR];
    const double N_vv = p[N_VV], N_vr = p[N_VR], N_rv = p[N_RV], N_rr = p[N_RR];
    const int cross_flow = p[CROSS_FLOW] != 0.0;
    const long i_psi = ix[I_PSI], jx = ix[IX], jy = ix[IY], jr = ix[IR];
    const long m_xx = ix[M_XX], m_yx = ix[M_YX], m_yy = ix[M_YY], m_rx = ix[M_RX], m_ry = ix[M_RY],
               m_rr = ix[M_RR];
    const int count = nstep > 0 ? nstep : 1;
    for (int k = 0; k < count; ++k) {
        const double psi = qpos[i_psi];
        const double xd = qvel[jx] - wx;
        const double yd = qvel[jy] - wy;
        const double r = qvel[jr];
        const double cp = cos(psi);
        const double sp = sin(psi);
        const double u = cp * xd + sp * yd;
        const double v = cp * yd - sp * xd;
        const double au = u >= 0.0 ? u : -u;
        const double av = v >= 0.0 ? v : -v;
        const double ar = r >= 0.0 ? r : -r;
        const double X = neg_munk * r * v + a23 * r * r + X_uu * au * u;
        double Y, N;
        if (cross_flow) {
            Y = (neg_munk * u * r + (Y_vv * av + Y_vr * ar) * v + (Y_rv * av + Y_rr * ar) * r
                 + Y_uv * u * v + Y_ur * u * r);
            N = (munk * u * v + (N_vv * av + N_vr * ar) * v + (N_rv * av + N_rr * ar) * r
                 + N_uv * u * v + N_ur * u * r);
        } else { /* the same sums without their zero terms, which add exactly nothing */
            Y = neg_munk * u * r + Y_vv * av * v + Y_rr * ar * r + Y_uv * u * v + Y_ur * u * r;
            N = munk * u * v + N_vv * av * v + N_rr * ar * r + N_uv * u * v + N_ur * u * r;
        }
        if (wrench == 0) {
            qfrc[jx] += cp * X - sp * Y;
            qfrc[jy] += sp * X + cp * Y;
            qfrc[jr] += N;
        } else {
            qfrc[jx] += cp * X - sp * Y + wrench[0];
            qfrc[jy] += sp * X + cp * Y + wrench[1];
            qfrc[jr] += N + wrench[2];
        }
        const double b11 = a11 + implicit_u * au;
        const double excess = implicit_v * av - sway_mass;
        const double b22 = excess > 0.0 ? a22 + excess : a22;
        const double cc = cp * cp;
        const double ss = sp * sp;
        const double cs = cp * sp;
        M[m_xx] += b11 * cc + b22 * ss;
        M[m_yx] += (b11 - b22) * cs;
        M[m_yy] += b11 * ss + b22 * cc;
        M[m_rx] -= a23 * sp;
        M[m_ry] += a23 * cp;
        M[m_rr] += a33 + implicit_r * ar;
        factor(model, data);
        if (nstep) {
            step2(model, data);
            step1(model, data);
        }
    }
}
