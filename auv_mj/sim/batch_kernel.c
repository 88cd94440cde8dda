/* The batched planar step of auv_mj.sim.batch: N vehicles, each in its own mjModel/mjData, stepped in one call.
 *
 * One call advances every listed vehicle by `ticks` executor periods of `substeps` physics steps. Each period
 * begins with the executor's 10 Hz tick of the planning tasks (tasks/planning.py `PlanningTask._tick`), written
 * again here statement for statement and in the same order of floating-point operations as the Python it mirrors,
 * so that a vehicle stepped here follows the single environment's trajectory to the bit:
 *   - the ocean current (auv_mj/sim/ocean.py `Ocean.tick`, `Current.advance`, `GaussMarkov.advance`), its normal
 *     draws taken from a buffer the caller fills from the episode's own generator;
 *   - the S-plane executor of Eq. (32) (auv_mj/control/splane.py `SPlaneController.__call__`) into ctrl, its gains read from
 *     the controller's own array (`SPlaneController.parameters`, in `SPlaneGains`' field order);
 *   - the moving obstacles (auv_mj/arenas/arena.py `Mover.position`, numpy.interp on a polyline);
 *   - the contact check of the vehicle.
 * Then the hydrodynamic substeps of hydro_kernel.c (included below: the same function the single physics calls).
 * After the last period it reads what the task's `after_step` needs: the contact check again, the nine sonar
 * ranges (mj_sensorPos with the sensor stage switched on for the call, as `AUVPhysics.sonar`) and the hull's
 * clearance (`PlanningTask._clearance`, mj_geomDistance).
 *
 * Built with the flags of hydro_kernel.c (no fused multiply-adds, libm's own sin, cos, tanh, exp as CPython's
 * math module calls them). Vehicles are shared out to `threads` POSIX threads (the caller's thread among them)
 * through an atomic counter, in runs of neighbours; each vehicle's model and data are touched by one thread only.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>

#include <mujoco/mujoco.h>

#include "hydro_kernel.c"
#include "tick_kernel.c" /* py_mod, wrap_angle, gauss_markov */

#define N_SONAR 9
#define MAX_THREADS 64

/* What does not change within an episode (pointers into arrays the Python side keeps alive). */
typedef struct {
    mjModel *m;
    mjData *d;
    const double *hydro;      /* hydro_kernel.c's coefficients */
    const double *gains;      /* the S-plane controller's `parameters`, in the order of the G_ names below */
    const long *hydro_ix;     /* hydro_kernel.c's addresses */
    const double *movers;     /* packed mover records, see `mover_position` */
    const int *others;        /* geoms whose clearance to the hull counts */
    int nmover, nothers, hull, vehicle_body;
    int qpos_x, qpos_y, qpos_psi, dof_x, dof_y, dof_r;
    int sonar_adr[N_SONAR];
} auv_slot;

/* Mutable per-vehicle state (a row of doubles), in the order auv_mj.sim.batch.STATE gives. */
enum {
    S_SPEED_CMD, S_HEADING_CMD, S_INT_SPEED, S_INT_HEADING, S_LAST_U, S_HAS_LAST_U, S_COLLIDED, S_READY,
    S_OCEAN_TIME, S_CURRENT_ON, S_CUR_SPEED, S_CUR_SPEED_DT, S_CUR_SPEED_A, S_CUR_SPEED_B,
    S_CUR_DIR, S_CUR_DIR_DT, S_CUR_DIR_A, S_CUR_DIR_B, S_NORMAL_POS, N_STATE
};
/* The S-plane gains (`auv_slot.gains`), in the order auv_mj.sim.batch.GAINS gives (`SPlaneGains`' fields). */
enum {
    G_K1_SPEED, G_K2_SPEED, G_KI_SPEED, G_K1_HEADING, G_K2_HEADING, G_KI_HEADING, G_BAND_SPEED, G_BAND_HEADING,
    G_INTEGRAL_LIMIT, G_SURGE_DRAG, G_SURGE_LIMIT, G_YAW_LIMIT, G_DT, N_GAINS
};
/* Per-vehicle constants of the current (a row of doubles), in the order auv_mj.sim.batch.PARAMETERS gives. */
enum {
    P_SPEED_MEAN, P_SPEED_SIGMA, P_SPEED_T, P_SPEED_LOW, P_SPEED_HIGH,
    P_DIR_MEAN, P_DIR_SIGMA, P_DIR_T, P_DIR_LOW, P_DIR_HIGH, N_PARAMETERS
};
/* What a step reports per vehicle (a row of doubles), in the order auv_mj.sim.batch.OUTPUTS gives. */
enum {
    O_X, O_Y, O_PSI, O_COS_PSI, O_SIN_PSI, O_U, O_V, O_R, O_TIME, O_COLLIDED, O_INVALID, O_CLEARANCE, O_SONAR,
    N_OUTPUTS = O_SONAR + N_SONAR
};
/* A mover record: slot, kind (0 fixed, 1 straight, 2 polyline), speed, length, start x y, delta x y,
 * npoints, then npoints (x, y) and npoints arc lengths. */
enum { M_SLOT, M_KIND, M_SPEED, M_LENGTH, M_SX, M_SY, M_DX, M_DY, M_NPOINTS, M_POINTS };

int auv_batch_sizes(int which) {
    switch (which) {
        case 0: return N_STATE;
        case 1: return N_PARAMETERS;
        case 2: return N_OUTPUTS;
        case 3: return (int)sizeof(auv_slot);
        case 4: return N_SONAR;
        default: return N_GAINS;
    }
}

/* SPlaneController._integrate. */
static double integrate(double integral, double error, double ki, double band, const double *g) {
    if (fabs(error) < band) integral += error * g[G_DT];
    if (ki > 0) {
        const double bound = g[G_INTEGRAL_LIMIT] / ki;
        integral = -bound > integral ? -bound : integral;
        integral = bound < integral ? bound : integral;
    }
    return integral;
}

static double clip_unit(double x) {
    x = x > -1.0 ? x : -1.0;
    return x < 1.0 ? x : 1.0;
}

/* Mover.position at `time` into mocap_pos. */
static void mover_position(const double *rec, double time, double *mocap_pos) {
    double *pos = mocap_pos + 3 * (int)rec[M_SLOT];
    const int kind = (int)rec[M_KIND];
    const double speed = rec[M_SPEED], length = rec[M_LENGTH];
    if (kind == 0 || length == 0 || speed == 0) {
        pos[0] = rec[M_SX];
        pos[1] = rec[M_SY];
        return;
    }
    const double travelled = py_mod(speed * time, 2 * length);
    const double s = travelled <= length ? travelled : 2 * length - travelled;
    if (kind == 1) {
        pos[0] = rec[M_SX] + rec[M_DX] * (s / length);
        pos[1] = rec[M_SY] + rec[M_DY] * (s / length);
        return;
    }
    /* numpy.interp(s, arc, points[:, k]) of one query point (numpy/_core/src/multiarray/compiled_base.c) */
    const int np = (int)rec[M_NPOINTS];
    const double *points = rec + M_POINTS, *arc = points + 2 * np;
    for (int k = 0; k < 2; ++k) {
        double value;
        if (s > arc[np - 1]) {
            value = points[2 * (np - 1) + k];
        } else if (s < arc[0]) {
            value = points[k];
        } else {
            int j = 0;
            while (j + 1 < np && arc[j + 1] <= s) ++j;
            if (j == np - 1 || arc[j] == s) {
                value = points[2 * j + k];
            } else {
                const double slope = (points[2 * (j + 1) + k] - points[2 * j + k]) / (arc[j + 1] - arc[j]);
                value = slope * (s - arc[j]) + points[2 * j + k];
                if (isnan(value)) {
                    value = slope * (s - arc[j + 1]) + points[2 * (j + 1) + k];
                    if (isnan(value) && points[2 * j + k] == points[2 * (j + 1) + k]) value = points[2 * j + k];
                }
            }
        }
        pos[k] = value;
    }
}

static int vehicle_contact(const auv_slot *slot) {
    const mjModel *m = slot->m;
    const mjData *d = slot->d;
    for (int i = 0; i < d->ncon; ++i) {
        if (m->geom_bodyid[d->contact[i].geom[0]] == slot->vehicle_body
            || m->geom_bodyid[d->contact[i].geom[1]] == slot->vehicle_body)
            return 1;
    }
    return 0;
}

static int warning_count(const mjData *d) {
    int total = 0;
    for (int i = 0; i < mjNWARNING; ++i) total += d->warning[i].number;
    return total;
}

/* PlanningTask._tick: current, executor, movers, contacts. */
static void tick(const auv_slot *slot, double *st, const double *p, double *normals) {
    mjModel *m = slot->m;
    mjData *d = slot->d;
    if (st[S_CURRENT_ON] != 0.0) {
        const double time = d->time;
        if (time > st[S_OCEAN_TIME]) {
            const double dt = time - st[S_OCEAN_TIME];
            int pos = (int)st[S_NORMAL_POS];
            gauss_markov(st, S_CUR_SPEED, S_CUR_SPEED_DT, S_CUR_SPEED_A, S_CUR_SPEED_B, p, P_SPEED_MEAN, dt,
                         normals[pos]);
            gauss_markov(st, S_CUR_DIR, S_CUR_DIR_DT, S_CUR_DIR_A, S_CUR_DIR_B, p, P_DIR_MEAN, dt,
                         normals[pos + 1]);
            st[S_NORMAL_POS] = pos + 2;
            st[S_OCEAN_TIME] = time;
            m->opt.wind[0] = st[S_CUR_SPEED] * cos(st[S_CUR_DIR]);
            m->opt.wind[1] = st[S_CUR_SPEED] * sin(st[S_CUR_DIR]);
        }
    }
    const double *g = slot->gains;
    const double psi = d->qpos[slot->qpos_psi];
    const double xd = d->qvel[slot->dof_x], yd = d->qvel[slot->dof_y], r = d->qvel[slot->dof_r];
    const double c = cos(psi), s = sin(psi);
    const double u = c * xd + s * yd;
    const double v_cmd = st[S_SPEED_CMD], psi_cmd = st[S_HEADING_CMD];
    const double e_v = v_cmd - u;
    const double edot_v = st[S_HAS_LAST_U] != 0.0 ? -(u - st[S_LAST_U]) / g[G_DT] : 0.0;
    st[S_LAST_U] = u;
    st[S_HAS_LAST_U] = 1.0;
    const double e_psi = wrap_angle(psi_cmd - psi);
    const double edot_psi = -r;
    st[S_INT_SPEED] = integrate(st[S_INT_SPEED], e_v, g[G_KI_SPEED], g[G_BAND_SPEED], g);
    st[S_INT_HEADING] = integrate(st[S_INT_HEADING], e_psi, g[G_KI_HEADING], g[G_BAND_HEADING], g);
    const double feed_forward = g[G_SURGE_DRAG] * v_cmd * fabs(v_cmd) / g[G_SURGE_LIMIT];
    const double du_v = feed_forward + g[G_KI_SPEED] * st[S_INT_SPEED];
    const double du_psi = g[G_KI_HEADING] * st[S_INT_HEADING];
    const double u_v = tanh(0.5 * (g[G_K1_SPEED] * e_v + g[G_K2_SPEED] * edot_v)) + du_v;
    const double u_psi = tanh(0.5 * (g[G_K1_HEADING] * e_psi + g[G_K2_HEADING] * edot_psi)) + du_psi;
    d->ctrl[0] = g[G_SURGE_LIMIT] * clip_unit(u_v);
    d->ctrl[1] = g[G_YAW_LIMIT] * clip_unit(u_psi);
    const double *rec = slot->movers;
    for (int k = 0; k < slot->nmover; ++k) {
        mover_position(rec, d->time, d->mocap_pos);
        rec += M_POINTS + 3 * (int)rec[M_NPOINTS];
    }
    if (d->ncon && st[S_COLLIDED] == 0.0) st[S_COLLIDED] = vehicle_contact(slot);
}

/* PlanningTask._clearance: the hull's distance to the nearest other geom, capped at `cap`. */
static double clearance(const auv_slot *slot, double cap) {
    const mjModel *m = slot->m;
    mjData *d = slot->d;
    const int hull = slot->hull;
    const double *h = d->geom_xpos + 3 * hull;
    double best = cap;
    for (int k = 0; k < slot->nothers; ++k) {
        const int g = slot->others[k];
        const double *x = d->geom_xpos + 3 * g;
        const double dx = x[0] - h[0], dy = x[1] - h[1], dz = x[2] - h[2];
        const double gap = sqrt(dx * dx + dy * dy + dz * dz) - m->geom_rbound[g] - m->geom_rbound[hull];
        if (gap < cap) {
            const double distance = mj_geomDistance(m, d, hull, g, best, NULL);
            if (distance < best) best = distance;
        }
    }
    return best;
}

static void step_vehicle(const auv_slot *slot, double *st, const double *p, double *normals, double *out, int ticks,
                         int substeps, double cap) {
    mjModel *m = slot->m;
    mjData *d = slot->d;
    const double dt = m->opt.timestep;
    const int warnings_before = warning_count(d);
    int invalid = 0;
    for (int t = 0; t < ticks; ++t) {
        tick(slot, st, p, normals);
        const double start = d->time;
        if (st[S_READY] == 0.0) {
            mj_step1(m, d);
            st[S_READY] = 1.0;
        }
        auv_hydro_advance(m, d, (mj_function)mj_factorM, (mj_function)mj_step1, (mj_function)mj_step2,
                          slot->hydro, slot->hydro_ix, d->qpos, d->qvel, d->qfrc_passive, d->M, m->opt.wind, 0,
                          substeps, dt);
        if (d->time < start + (substeps - 0.5) * dt) invalid = 1;
    }
    if (warning_count(d) != warnings_before) invalid = 1;
    if (st[S_COLLIDED] == 0.0 && d->ncon > 0) st[S_COLLIDED] = vehicle_contact(slot);
    const int flags = m->opt.disableflags;
    m->opt.disableflags = flags & ~mjDSBL_SENSOR;
    mj_sensorPos(m, d);
    m->opt.disableflags = flags;
    const double psi = d->qpos[slot->qpos_psi];
    const double xd = d->qvel[slot->dof_x], yd = d->qvel[slot->dof_y];
    const double c = cos(psi), s = sin(psi);
    out[O_X] = d->qpos[slot->qpos_x];
    out[O_Y] = d->qpos[slot->qpos_y];
    out[O_PSI] = psi;
    out[O_COS_PSI] = c;
    out[O_SIN_PSI] = s;
    out[O_U] = c * xd + s * yd;
    out[O_V] = c * yd - s * xd;
    out[O_R] = d->qvel[slot->dof_r];
    out[O_TIME] = d->time;
    out[O_COLLIDED] = st[S_COLLIDED];
    out[O_INVALID] = invalid;
    out[O_CLEARANCE] = clearance(slot, cap);
    for (int k = 0; k < N_SONAR; ++k) out[O_SONAR + k] = d->sensordata[slot->sonar_adr[k]];
}

typedef struct {
    const int *index;
    int count;
    atomic_int next;
    const auv_slot *slots;
    double *state, *parameters, *normals, *out;
    int normals_stride, ticks, substeps, chunk;
    double cap;
} batch_job;

static void *work(void *arg) {
    batch_job *job = (batch_job *)arg;
    for (;;) {
        const int first = atomic_fetch_add(&job->next, job->chunk);
        if (first >= job->count) break;
        const int last = first + job->chunk < job->count ? first + job->chunk : job->count;
        for (int k = first; k < last; ++k) {
            const int i = job->index[k];
            step_vehicle(job->slots + i, job->state + (long)i * N_STATE, job->parameters + (long)i * N_PARAMETERS,
                         job->normals + (long)i * job->normals_stride, job->out + (long)i * N_OUTPUTS, job->ticks,
                         job->substeps, job->cap);
        }
    }
    return NULL;
}

/* Steps the vehicles index[0..count) of `slots` (rows of state, parameters, normals, out by vehicle) on `threads`
 * threads; returns the number of threads used. */
int auv_batch_step(const int *index, int count, const auv_slot *slots, double *state, const double *parameters,
                   double *normals, int normals_stride, double *out, int ticks, int substeps, double cap,
                   int threads) {
    if (threads > count) threads = count;
    if (threads > MAX_THREADS) threads = MAX_THREADS;
    if (threads < 1) threads = 1;
    /* runs of neighbouring vehicles per grab: fewer shared cache lines between threads, and still a dozen grabs
     * per thread to even out vehicles of unequal cost */
    int chunk = count / (12 * threads);
    if (chunk < 1) chunk = 1;
    batch_job job = {index, count, 0, slots, state, (double *)parameters, normals, out, normals_stride, ticks,
                     substeps, chunk, cap};
    atomic_init(&job.next, 0);
    pthread_t pool[MAX_THREADS];
    int started = 0;
    for (int t = 1; t < threads; ++t) {
        if (pthread_create(&pool[started], NULL, work, &job) == 0) ++started;
    }
    work(&job);
    for (int t = 0; t < started; ++t) pthread_join(pool[t], NULL);
    return started + 1;
}
