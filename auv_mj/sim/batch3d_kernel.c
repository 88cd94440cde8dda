/* The batched 6-DOF step of auv_mj.sim.batch3d: N vehicles, each in its own mjModel/mjData, stepped in one call.
 *
 * One call advances every listed vehicle by `ticks` executor periods of `substeps` physics steps, then reads its
 * sensors as the task's after_step does. Each period begins with the 3-D planning tasks' 10 Hz tick
 * (tasks/auv3d.py `Planning3D._tick`), written again here in the same order of floating-point operations as the
 * Python it mirrors, so that a vehicle stepped here follows the single environment's trajectory to the bit:
 *   - the moving spheres (auv_mj/arenas/tubes.py `TubeMover.position`);
 *   - the ocean current (auv_mj/sim/ocean3d.py `Ocean3D.tick`: `Current.advance`, then the depth profile), its
 *     normal draws taken from a buffer the caller fills from the episode's own generator;
 *   - the sensors (auv_mj/sim/sensors3d.py `Sensors3D.read`): which are due at each read is given by the caller
 *     (`masks`, from the same rule in Python), and so is their noise (`noise`, drawn from the episode's generator
 *     in the order `Ocean3D.noise` draws it); each due sensor is sampled and held;
 *   - `read_state` and the depth-heading S-plane executor (auv_mj/control/depth_heading.py
 *     `DepthHeadingController.__call__`) into ctrl, its gains read from an array in `DepthHeadingGains`' order.
 * Then the hydrodynamic substeps of hydro3d_kernel.c (included below: the function the single physics calls).
 *
 * Built with hydro3d_kernel.c's flags; the code after it with no fused multiply-adds, as CPython computes. Vehicles
 * are shared out to `threads` POSIX threads (the caller's among them) through an atomic counter, as in
 * batch_kernel.c; each vehicle's model and data are touched by one thread only.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>

#include <mujoco/mujoco.h>

#include "hydro3d_kernel.c"

#pragma GCC optimize("fp-contract=off")

#include "tick_kernel.c" /* py_mod, wrap_angle, gauss_markov */

#define N_FAN 27
#define MAX_THREADS 64
#define MAX_READS 16

/* What does not change within an episode (pointers into arrays the Python side keeps alive). */
typedef struct {
    mjModel *m;
    mjData *d;
    const double *hydro;   /* hydro3d_kernel.c's parameters */
    const long *hydro_ix;  /* hydro3d_kernel.c's addresses */
    const double *gains;   /* DepthHeadingGains' fields then the executor's constants, the G_ names below */
    const double *movers;  /* mover records, M_ names below */
    const double *fan;     /* the fan's beam directions in the body frame, (27, 3) */
    double *fins;          /* the physics' fin angles (rudder, stern), updated in place */
    const double *source;  /* the fins' commands: data.ctrl, or data.act when lagged */
    int nmover, hull, sonar_site, sonar_body, altimeter_site, altimeter_body;
    int pressure_adr, dvl_adr, gyro_adr, accelerometer_adr, attitude_adr;
} auv3d_slot;

/* Mutable per-vehicle state (a row of doubles), in the order auv_mj.sim.batch3d.STATE gives. */
enum {
    S_SPEED_CMD, S_HEADING_CMD, S_DEPTH_CMD, S_INT_SPEED, S_INT_HEADING, S_INT_DEPTH, S_LAST_U, S_HAS_LAST_U,
    S_READY, S_NOISE_ON, S_OCEAN_TIME, S_CURRENT_ON, S_CUR_SPEED, S_CUR_SPEED_DT, S_CUR_SPEED_A, S_CUR_SPEED_B,
    S_CUR_DIR, S_CUR_DIR_DT, S_CUR_DIR_A, S_CUR_DIR_B, S_NORMAL_POS, S_LAST_DVL, S_ALTIMETER = S_LAST_DVL + 3,
    S_DEPTH, S_DVL, S_GYRO = S_DVL + 3, S_ACCELEROMETER = S_GYRO + 3, S_ATTITUDE = S_ACCELEROMETER + 3,
    N_STATE = S_ATTITUDE + 4
};
/* The executor's gains (DepthHeadingGains' fields, in order) and constants, in auv_mj.sim.batch3d.GAINS' order. */
enum {
    G_K1_SPEED, G_K2_SPEED, G_KI_SPEED, G_K1_HEADING, G_K2_HEADING, G_KI_HEADING, G_K1_DEPTH, G_K2_DEPTH,
    G_KI_DEPTH, G_MAX_PITCH, G_K1_PITCH, G_K2_PITCH, G_BAND_DEPTH, G_INTEGRAL_LIMIT, G_DT, G_THRUST_LIMIT,
    G_FIN_LIMIT, G_SURGE_DRAG, N_GAINS
};
/* Per-vehicle constants of the current (a row of doubles), in auv_mj.sim.batch3d.PARAMETERS' order. */
enum {
    P_SPEED_MEAN, P_SPEED_SIGMA, P_SPEED_T, P_SPEED_LOW, P_SPEED_HIGH,
    P_DIR_MEAN, P_DIR_SIGMA, P_DIR_T, P_DIR_LOW, P_DIR_HIGH, P_PROFILE_ON, P_WATER_DEPTH, P_EXPONENT, N_ROW_PARAMETERS
};
/* Constants of the sensors, in auv_mj.sim.batch3d.CONSTANTS' order. */
enum {
    C_RHO_G, C_SURFACE_Z, C_SONAR_RANGE, C_ALTIMETER_RANGE, C_SIGMA_ALTIMETER, C_SIGMA_DEPTH, C_SIGMA_DVL,
    C_SIGMA_GYRO, C_SIGMA_ACCELEROMETER, N_CONSTANTS
};
/* What a step reports per vehicle (a row of doubles), in auv_mj.sim.batch3d.OUTPUTS' order. */
enum {
    O_X, O_Y, O_Z, O_HEADING, O_TIME, O_COLLIDED, O_INVALID, O_SONAR_SAMPLES, O_ROLL, O_PITCH, O_SENSED_HEADING,
    O_SONAR, N_OUTPUTS = O_SONAR + N_FAN
};
/* A mover record: mocap slot, speed, span (|end - start|, computed by the caller as numpy does), start xyz,
 * end xyz. */
enum { M_SLOT, M_SPEED, M_SPAN, M_START, M_END = M_START + 3, M_SIZE = M_END + 3 };
/* The sensors of a read mask, in Sensors3D's order of sampling (SAMPLE_RATES_HZ). */
enum { R_SONAR = 1, R_ALTIMETER = 2, R_DEPTH = 4, R_DVL = 8, R_IMU = 16 };

int auv3d_batch_sizes(int which) {
    switch (which) {
        case 0: return N_STATE;
        case 1: return N_ROW_PARAMETERS;
        case 2: return N_OUTPUTS;
        case 3: return (int)sizeof(auv3d_slot);
        case 4: return N_GAINS;
        case 5: return N_CONSTANTS;
        case 6: return M_SIZE;
        default: return MAX_READS;
    }
}

/* TubeMover.position at `time` into mocap_pos. */
static void mover_position(const double *rec, double time, double *mocap_pos) {
    double *pos = mocap_pos + 3 * (int)rec[M_SLOT];
    const double speed = rec[M_SPEED], span = rec[M_SPAN];
    if (span < 1e-9 || speed <= 0.0) {
        for (int k = 0; k < 3; ++k) pos[k] = rec[M_START + k];
        return;
    }
    const double travelled = py_mod(speed * time, 2.0 * span);
    const double s = travelled <= span ? travelled : 2.0 * span - travelled;
    for (int k = 0; k < 3; ++k) pos[k] = rec[M_START + k] + (s / span) * (rec[M_END + k] - rec[M_START + k]);
}

/* sensors3d._rays: ranges along world directions from a point, ignoring a body; `cutoff` where nothing is hit.
 * One mj_ray a direction: it returns mj_multiRay's distance (each geom's intersection is the same function; what
 * mj_multiRay adds is a conservative culling by bounding angles), and faster here, since the culling's set-up takes
 * two atan2 for each corner of every geom in range, hundreds of geoms in a tube (checked bit for bit against
 * mj_multiRay over 43,200 fan beams and 3,200 altimeter pings in every arena kind; tests/tasks/test_vector_env_3d.py
 * holds the observations equal). */
static void rays(const mjModel *m, mjData *d, const double *origin, const double *directions, int n, int body,
                 double cutoff, double *out) {
    int geom;
    for (int k = 0; k < n; ++k) {
        out[k] = mj_ray(m, d, origin, directions + 3 * k, NULL, 1, body, &geom, NULL);
        if (out[k] < 0 || out[k] > cutoff) out[k] = cutoff;
    }
}

/* Sensors3D.read of the sensors in `mask`, with Ocean3D.noise's draws from `noise` (advancing `*at`). */
static void read_sensors(const auv3d_slot *slot, double *st, int mask, const double *c, const double *noise, int *at,
                         double *out) {
    if (!mask) return;
    const mjModel *m = slot->m;
    mjData *d = slot->d;
    const int noisy = st[S_NOISE_ON] != 0.0;
    mjModel *mm = slot->m;
    const int flags = mm->opt.disableflags; /* AUV3DPhysics.evaluate_sensors */
    mm->opt.disableflags = flags & ~mjDSBL_SENSOR;
    mj_sensorPos(m, d);
    mj_sensorVel(m, d);
    mj_sensorAcc(m, d);
    mm->opt.disableflags = flags;
    const double *sd = d->sensordata;
    if (mask & R_SONAR) { /* sensors3d.sonar_fan: directions = FAN @ R^T; the noise is the caller's (NoisySonar) */
        const double *R = d->site_xmat + 9 * slot->sonar_site;
        double directions[3 * N_FAN];
        for (int i = 0; i < N_FAN; ++i)
            for (int r = 0; r < 3; ++r)
                directions[3 * i + r] = slot->fan[3 * i] * R[3 * r] + slot->fan[3 * i + 1] * R[3 * r + 1]
                                        + slot->fan[3 * i + 2] * R[3 * r + 2];
        rays(m, d, d->site_xpos + 3 * slot->sonar_site, directions, N_FAN, slot->sonar_body, c[C_SONAR_RANGE],
             out + O_SONAR);
        out[O_SONAR_SAMPLES] += 1.0;
    }
    if (mask & R_ALTIMETER) {
        const double *R = d->site_xmat + 9 * slot->altimeter_site;
        const double down[3] = {-R[2], -R[5], -R[8]};
        double value;
        rays(m, d, d->site_xpos + 3 * slot->altimeter_site, down, 1, slot->altimeter_body, c[C_ALTIMETER_RANGE],
             &value);
        if (noisy) value = value + c[C_SIGMA_ALTIMETER] * noise[(*at)++];
        st[S_ALTIMETER] = value;
    }
    if (mask & R_DEPTH) {
        const double pressure = c[C_RHO_G] * (c[C_SURFACE_Z] - sd[slot->pressure_adr + 2]);
        double value = pressure / c[C_RHO_G];
        if (noisy) value = value + c[C_SIGMA_DEPTH] * noise[(*at)++];
        st[S_DEPTH] = value;
    }
    if (mask & R_DVL) {
        if (noisy && noise[(*at)++] != 0.0) { /* a dropout: the last noisy sample is held */
            for (int k = 0; k < 3; ++k) st[S_DVL + k] = st[S_LAST_DVL + k];
        } else {
            for (int k = 0; k < 3; ++k) {
                double value = sd[slot->dvl_adr + k];
                if (noisy) value = value + c[C_SIGMA_DVL] * noise[*at + k];
                st[S_DVL + k] = value;
            }
            if (noisy) {
                *at += 3;
                for (int k = 0; k < 3; ++k) st[S_LAST_DVL + k] = st[S_DVL + k];
            }
        }
    }
    if (mask & R_IMU) {
        for (int k = 0; k < 3; ++k) {
            double value = sd[slot->gyro_adr + k];
            if (noisy) value = value + c[C_SIGMA_GYRO] * noise[*at + k];
            st[S_GYRO + k] = value;
        }
        if (noisy) *at += 3;
        for (int k = 0; k < 3; ++k) {
            double value = sd[slot->accelerometer_adr + k];
            if (noisy) value = value + c[C_SIGMA_ACCELEROMETER] * noise[*at + k];
            st[S_ACCELEROMETER + k] = value;
        }
        if (noisy) *at += 3;
        for (int k = 0; k < 4; ++k) st[S_ATTITUDE + k] = sd[slot->attitude_adr + k];
    }
}

/* physics3d.euler_angles of a quaternion's rotation (mju_quat2Mat, as auv3d.read_state): roll, pitch, heading. */
static void euler(const double *quat, double *angles) {
    double R[9];
    mju_quat2Mat(R, quat);
    const double clipped = -1.0 > (1.0 < R[6] ? 1.0 : R[6]) ? -1.0 : (1.0 < R[6] ? 1.0 : R[6]);
    angles[1] = asin(clipped);
    angles[2] = atan2(R[3], R[0]);
    angles[0] = atan2(R[7], R[8]);
}

static double s_plane(double e, double edot, double k1, double k2) { return tanh(0.5 * (k1 * e + k2 * edot)); }

static double clip(double x, double low, double high) {
    x = low > x ? low : x;
    return high < x ? high : x;
}

/* DepthHeadingController.__call__ on read_state of the held samples: (thrust, rudder, stern) into ctrl. */
static void executor(const double *g, double *st, double *ctrl) {
    double angles[3];
    euler(st + S_ATTITUDE, angles);
    const double roll = angles[0], pitch = angles[1], heading = angles[2];
    const double u = st[S_DVL], v = st[S_DVL + 1], w = st[S_DVL + 2];
    const double q = st[S_GYRO + 1], r = st[S_GYRO + 2];
    const double v_cmd = st[S_SPEED_CMD], psi_cmd = st[S_HEADING_CMD], depth_cmd = st[S_DEPTH_CMD];
    const double e_v = v_cmd - u;
    const double e_psi = wrap_angle(psi_cmd - heading);
    const double e_d = depth_cmd - st[S_DEPTH];
    const double u_dot = st[S_HAS_LAST_U] == 0.0 ? 0.0 : (u - st[S_LAST_U]) / g[G_DT];
    st[S_LAST_U] = u;
    st[S_HAS_LAST_U] = 1.0;
    const double limit = g[G_INTEGRAL_LIMIT];
    if (fabs(e_v) < 0.2) st[S_INT_SPEED] = clip(st[S_INT_SPEED] + g[G_KI_SPEED] * e_v * g[G_DT], -limit, limit);
    if (fabs(e_psi) < 0.2)
        st[S_INT_HEADING] = clip(st[S_INT_HEADING] + g[G_KI_HEADING] * e_psi * g[G_DT], -limit, limit);
    if (fabs(e_d) < g[G_BAND_DEPTH])
        st[S_INT_DEPTH] = clip(st[S_INT_DEPTH] + g[G_KI_DEPTH] * e_d * g[G_DT] / g[G_MAX_PITCH], -limit, limit);
    const double feed = g[G_SURGE_DRAG] * v_cmd * fabs(v_cmd) / g[G_THRUST_LIMIT];
    const double thrust = g[G_THRUST_LIMIT] * (s_plane(e_v, -u_dot, g[G_K1_SPEED], g[G_K2_SPEED]) + feed
                                               + st[S_INT_SPEED]);
    const double rudder = g[G_FIN_LIMIT] * (s_plane(e_psi, -r, g[G_K1_HEADING], g[G_K2_HEADING]) + st[S_INT_HEADING]);
    const double st_ = sin(pitch), ct = cos(pitch), sf = sin(roll), cf = cos(roll);
    const double depth_rate = -(u * st_ + v * ct * sf + w * ct * cf); /* State3D.depth_rate */
    double pitch_cmd = -g[G_MAX_PITCH] * (s_plane(e_d, -depth_rate, g[G_K1_DEPTH], g[G_K2_DEPTH]) + st[S_INT_DEPTH]);
    pitch_cmd = clip(pitch_cmd, -g[G_MAX_PITCH], g[G_MAX_PITCH]);
    const double stern = g[G_FIN_LIMIT] * s_plane(pitch - pitch_cmd, -q, g[G_K1_PITCH], g[G_K2_PITCH]);
    ctrl[0] = clip(thrust, -g[G_THRUST_LIMIT], g[G_THRUST_LIMIT]);
    ctrl[1] = clip(rudder, -g[G_FIN_LIMIT], g[G_FIN_LIMIT]);
    ctrl[2] = clip(stern, -g[G_FIN_LIMIT], g[G_FIN_LIMIT]);
}

/* Planning3D._tick: movers, current, sensors, executor. */
static void tick(const auv3d_slot *slot, double *st, const double *p, double *normals, int mask, const double *c,
                 const double *noise, int *at, double *out) {
    mjModel *m = slot->m;
    mjData *d = slot->d;
    const double *rec = slot->movers;
    for (int k = 0; k < slot->nmover; ++k, rec += M_SIZE) mover_position(rec, d->time, d->mocap_pos);
    if (st[S_CURRENT_ON] != 0.0) {
        const double time = d->time;
        if (time > st[S_OCEAN_TIME]) {
            const double dt = time - st[S_OCEAN_TIME];
            const int pos = (int)st[S_NORMAL_POS];
            gauss_markov(st, S_CUR_SPEED, S_CUR_SPEED_DT, S_CUR_SPEED_A, S_CUR_SPEED_B, p, P_SPEED_MEAN, dt,
                         normals[pos]);
            gauss_markov(st, S_CUR_DIR, S_CUR_DIR_DT, S_CUR_DIR_A, S_CUR_DIR_B, p, P_DIR_MEAN, dt, normals[pos + 1]);
            st[S_NORMAL_POS] = pos + 2;
            st[S_OCEAN_TIME] = time;
        }
        const double vx = st[S_CUR_SPEED] * cos(st[S_CUR_DIR]), vy = st[S_CUR_SPEED] * sin(st[S_CUR_DIR]);
        double factor = 1.0;
        if (p[P_PROFILE_ON] != 0.0) { /* CurrentProfile.factor at the true depth */
            const double depth = -d->qpos[slot->hydro_ix[0] + 2];
            double height = p[P_WATER_DEPTH] - depth;
            height = 0.0 > height ? 0.0 : height;
            height = p[P_WATER_DEPTH] < height ? p[P_WATER_DEPTH] : height;
            factor = pow(height / p[P_WATER_DEPTH], 1.0 / p[P_EXPONENT]);
        }
        m->opt.wind[0] = vx * factor;
        m->opt.wind[1] = vy * factor;
        m->opt.wind[2] = 0.0;
    }
    read_sensors(slot, st, mask, c, noise, at, out);
    executor(slot->gains, st, d->ctrl);
}

static int warning_count(const mjData *d) {
    int total = 0;
    for (int i = 0; i < mjNWARNING; ++i) total += d->warning[i].number;
    return total;
}

static void step_vehicle(const auv3d_slot *slot, double *st, const double *p, double *normals, const int *masks,
                         const double *noise, const double *c, double *out, int ticks, int substeps) {
    mjModel *m = slot->m;
    mjData *d = slot->d;
    const double dt = m->opt.timestep;
    const long qa = slot->hydro_ix[0];
    const int warnings_before = warning_count(d);
    int invalid = 0, at = 0;
    out[O_SONAR_SAMPLES] = 0.0;
    for (int t = 0; t < ticks; ++t) {
        tick(slot, st, p, normals, masks[t], c, noise, &at, out);
        if (!(isfinite(d->ctrl[0]) && isfinite(d->ctrl[1]) && isfinite(d->ctrl[2]))) {
            invalid = 1;
            break;
        }
        const double start = d->time;
        if (st[S_READY] == 0.0) {
            mj_step1(m, d);
            st[S_READY] = 1.0;
        }
        auv3d_hydro_advance(m, d, (mj_function)mj_factorM, (mj_function)mj_step1, (mj_function)mj_step2,
                            slot->hydro, slot->hydro_ix, d->qpos, d->qvel, d->qfrc_passive, d->M, m->opt.wind, 0,
                            slot->fins, slot->source, substeps, dt);
        double speed = 0.0;
        for (int k = 0; k < m->nv; ++k) speed += d->qvel[k];
        if (d->time < start + (substeps - 0.5) * dt || !isfinite(speed)) invalid = 1;
    }
    if (warning_count(d) != warnings_before) invalid = 1;
    read_sensors(slot, st, masks[ticks], c, noise, &at, out); /* the task's after_step read */
    double angles[3];
    euler(d->qpos + qa + 3, angles);
    out[O_X] = d->qpos[qa];
    out[O_Y] = d->qpos[qa + 1];
    out[O_Z] = d->qpos[qa + 2];
    out[O_HEADING] = angles[2];
    out[O_TIME] = d->time;
    int collided = 0; /* Planning3D._collided: a contact of the hull geom now */
    for (int i = 0; i < d->ncon; ++i)
        if (d->contact[i].geom[0] == slot->hull || d->contact[i].geom[1] == slot->hull) collided = 1;
    out[O_COLLIDED] = collided;
    out[O_INVALID] = invalid;
    euler(st + S_ATTITUDE, angles);
    out[O_ROLL] = angles[0];
    out[O_PITCH] = angles[1];
    out[O_SENSED_HEADING] = angles[2];
}

typedef struct {
    const int *index;
    int count;
    atomic_int next;
    const auv3d_slot *slots;
    double *state, *parameters, *normals, *noise, *out;
    const int *masks;
    const double *constants;
    int normals_stride, noise_stride, ticks, substeps, chunk;
} batch_job;

static void *work(void *arg) {
    batch_job *job = (batch_job *)arg;
    for (;;) {
        const int first = atomic_fetch_add(&job->next, job->chunk);
        if (first >= job->count) break;
        const int last = first + job->chunk < job->count ? first + job->chunk : job->count;
        for (int k = first; k < last; ++k) {
            const int i = job->index[k];
            step_vehicle(job->slots + i, job->state + (long)i * N_STATE, job->parameters + (long)i * N_ROW_PARAMETERS,
                         job->normals + (long)i * job->normals_stride, job->masks + (long)i * MAX_READS,
                         job->noise + (long)i * job->noise_stride, job->constants, job->out + (long)i * N_OUTPUTS,
                         job->ticks, job->substeps);
        }
    }
    return NULL;
}

/* Steps the vehicles index[0..count) of `slots` (rows of state, parameters, normals, masks, noise, out by vehicle)
 * on `threads` threads; returns the number of threads used. */
int auv3d_batch_step(const int *index, int count, const auv3d_slot *slots, double *state, const double *parameters,
                     double *normals, int normals_stride, const int *masks, double *noise, int noise_stride,
                     const double *constants, double *out, int ticks, int substeps, int threads) {
    if (ticks + 1 > MAX_READS) return 0;
    if (threads > count) threads = count;
    if (threads > MAX_THREADS) threads = MAX_THREADS;
    if (threads < 1) threads = 1;
    int chunk = count / (12 * threads); /* runs of neighbours per grab, as batch_kernel.c */
    if (chunk < 1) chunk = 1;
    batch_job job = {index, count, 0, slots, state, (double *)parameters, normals, noise, out, masks, constants,
                     normals_stride, noise_stride, ticks, substeps, chunk};
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
