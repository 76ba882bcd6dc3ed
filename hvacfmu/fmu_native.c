/* hvacfmu native FMU: FMI 2.0 co-simulation runtime of a linear/bilinear zone model.
 *
 * Written once (hvacfmu/fmu_native.c); the model itself is the generated header
 * hvacfmu_model.h (matrices, gain tables, variable layout) produced by
 * hvacfmu.fmu_native from model.equations(). No Python, no libm, no allocation
 * after instantiation. One model step:
 *
 *   u  = M m                       (box airflows -> model inputs; u = m without a map)
 *   x+ = A x + Bu u + Bv v + Bq q + sum_i u_i (Bxu_i x + Bvu_i v) + sum_j v_j (Bxv_j x + Bvv_j v)
 *        + sum_s on_s scale_s g_s   (Bxv/Bvv: HV_DPRODUCTS, e.g. wind infiltration; physical form only)
 *   y  = x[out_state]
 *
 * A large model whose A has real eigenvalues is generated in modal form (HV_MODAL, see
 * hvacfmu/fmu_native_modal.py): the state is z = W x with A = V diag(lam) W, and one step is
 *
 *   z+ = lam * z + P w,  w = [u, v, q, a, s],  a_r = sum_t alpha_t u_i(t) src_t,  xs = S z
 *
 * with xs the physical states the outputs and bilinear terms read (S = rows of V).
 *
 * Idle air handler (HV_NIDLE > 0: the model's stored idle supply rule, hvacfmu.data.idle.IdleStep): before
 * every model step, each listed disturbance v_j (a unit's supply temperature T_supply..., a box's Td_<vav>)
 * whose boxes all have airflow at or below their off bound is replaced by the weighted mean of the FMU's own
 * zone temperatures at the start of the step ("zone" mode), or by its last value while a box of the unit ran
 * (HV_IDLE_LAST; the raw value until the unit first runs).
 *
 * q is row (slot mod n_slots) of the season's time-of-week gain table, with
 * slot = floor((start_time_of_week + t_start)/step + 1e-9) + k for model step k,
 * or floor(time_of_week/step + 1e-9) when the time_of_week input is >= 0.
 * A communication step must be a whole multiple of the model step; other steps,
 * NaN or out-of-range inputs and non-contiguous steps return fmi2Error with a
 * logged reason (time, variable, value) and leave the state unchanged. fmi2Error,
 * not fmi2Discard: a master such as FMPy's simulate_fmu ends a run quietly with a
 * short result on fmi2Discard (it reads fmi2Terminated and stops), but raises on
 * fmi2Error, so `fmpy simulate` exits non-zero. The instance stays usable
 * (fmi2SetFMUstate, fmi2Reset or a corrected step).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

#include "fmi2Functions.h"

enum { R_M = 0, R_V = 1, R_TOWIN = 2, R_Y = 3, R_Y0 = 4, R_SEASON = 5, R_TOW = 6 };

/* a matrix: sparse (nnz entries row[k], col[k], val[k]) or, when row is NULL, dense column-major nrows x ncols */
typedef struct {
    int nnz;
    const int *row;
    const int *col;
    const double *val;
    int nrows, ncols;
} hv_sparse;

typedef struct {
    int input_index; /* -1: no condition on an input */
    double input_below;
    int disturbance_index; /* -1: no condition on a disturbance */
    double disturbance_below;
    int scale_by; /* -1: scale 1 */
    const double *gain; /* HV_NX */
} hv_switch;

#include "hvacfmu_model.h" /* generated: sizes, matrices, gain tables, variables */

#if !HV_MODAL
#define HV_NS 1
#define HV_NREP 0
#endif

/* One coefficient set per season (a seasonal Model A): the generated header holds hv_A_set[season - 1] ...
 * and the step reads the set of the instance's season parameter (checked at initialisation: 1..HV_NSEASON). */
#ifndef HV_SEASONAL
#define HV_SEASONAL 0
#endif
#if HV_SEASONAL
#define HV_SET_OF(c) ((int)(c)->s.r[HV_VR_SEASON] - 1)
#define HV_MAT(name, c) (&name##_set[HV_SET_OF(c)])
#define HV_MATI(name, c, i) (&name##_set[HV_SET_OF(c)][i])
#else
#define HV_MAT(name, c) (&name)
#define HV_MATI(name, c, i) (&name[i])
#endif
#define HV_NWALL (HV_NU + HV_NV + HV_NQ + HV_NSWITCH + HV_MODAL * HV_NREP + 1)

#ifndef HV_NIDLE
#define HV_NIDLE 0
#endif
#define HV_NIDLE1 (HV_NIDLE > 0 ? HV_NIDLE : 1)

#define HV_STATE_MAGIC 0x48564632 /* "HVF2" */

/* everything fmi2GetFMUstate saves */
typedef struct {
    int magic;
    int size;
    double r[HV_NVARS]; /* variable values by value reference (season as a double) */
    double x[HV_NX]; /* the state; in modal form the modal state z */
    double xs[HV_NS]; /* modal form: the physical states S z (outputs first) */
    double idle_last[HV_NIDLE1]; /* idle supply rule: last running value of each replaced input */
    int idle_has[HV_NIDLE1]; /* ... and whether there is one yet */
    long long k; /* model steps since the start time */
    long long slot0;
    double t, t_start;
    int initialized;
    int failed;
} hv_state;

typedef struct {
    hv_state s;
    fmi2CallbackFunctions cb;
    char name[256];
    int logging_on;
    int in_init;
    int pending; /* an earlier call failed: the next doStep reports it */
    char pending_msg[512];
    double u[HV_NU > 0 ? HV_NU : 1];
    double v[HV_NV > 0 ? HV_NV : 1];
    double vraw[HV_NV > 0 ? HV_NV : 1]; /* the disturbance inputs as set (before the idle supply rule) */
    double tmp[HV_NX];
    double xn[HV_NX];
    double zn[HV_NX];
} hv_inst;

/* ------------------------------------------------------------------ helpers without libm */
static int hv_finite(double a) { return a == a && a - a == 0.0; }

static long long hv_floor(double a) {
    long long i = (long long)a;
    return ((double)i > a) ? i - 1 : i;
}

static long long hv_mod(long long a, long long n) {
    long long r = a % n;
    return r < 0 ? r + n : r;
}

static double hv_fabs(double a) { return a < 0 ? -a : a; }

static void hv_log(hv_inst *c, fmi2Status status, const char *category, const char *fmt, ...) {
    char msg[2048];
    va_list ap;
    if (!c->cb.logger) return;
    if (status == fmi2OK && !c->logging_on) return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    /* the message is passed preformatted; no '%' may reach the host's formatter */
    for (char *p = msg; *p; ++p)
        if (*p == '%') *p = ' ';
    c->cb.logger(c->cb.componentEnvironment, c->name, status, category, msg);
}

#if !HV_MODAL
static void spmv_add(const hv_sparse *a, const double *x, double *y) {
    if (!a->row) { /* dense, column-major: y += sum_j a[:, j] x[j] (independent lanes, vectorises) */
        const double *col = a->val;
        const int nr = a->nrows;
        for (int j = 0; j < a->ncols; ++j, col += nr) {
            const double xj = x[j];
            if (xj == 0.0) continue;
            for (int i = 0; i < nr; ++i) y[i] += col[i] * xj;
        }
        return;
    }
    for (int k = 0; k < a->nnz; ++k) y[a->row[k]] += a->val[k] * x[a->col[k]];
}
#endif

/* ------------------------------------------------------------------ the model */
static const double *gains_row(int season, long long slot) {
    long long n = hv_gain_nslots[season - 1];
    return hv_gains + hv_gain_offset[season - 1] + hv_mod(slot, n) * HV_NQ;
}

static void model_inputs(hv_inst *c) {
    const double *r = c->s.r;
#if HV_HAS_MAP
    for (int i = 0; i < HV_NU; ++i) {
        double s = 0.0;
        for (int k = hv_map_start[i]; k < hv_map_start[i + 1]; ++k) s += hv_map_val[k] * r[hv_vr_m[hv_map_col[k]]];
        c->u[i] = s;
    }
#else
    for (int i = 0; i < HV_NU; ++i) c->u[i] = r[hv_vr_m[i]];
#endif
    for (int i = 0; i < HV_NV; ++i) c->v[i] = c->vraw[i] = r[hv_vr_v[i]];
}

#if HV_NIDLE
/* c->v = the raw disturbances with the idle supply rule applied: T holds the zone temperatures (outputs) at the
 * start of the step; last/has the rule's memory, updated for the units that run */
static void idle_inputs(hv_inst *c, const double *T, double *last, int *has) {
    for (int i = 0; i < HV_NV; ++i) c->v[i] = c->vraw[i];
    for (int i = 0; i < HV_NIDLE; ++i) {
        const int j = hv_idle_target[i];
        int off = 1;
        for (int k = hv_idle_bstart[i]; k < hv_idle_bstart[i + 1]; ++k)
            if (!(c->s.r[hv_vr_m[hv_idle_box[k]]] <= hv_idle_bound[k])) off = 0;
        if (!off) {
            last[i] = c->vraw[j];
            has[i] = 1;
        } else if (hv_idle_zstart[i + 1] > hv_idle_zstart[i]) {
            double s = 0.0, sw = 0.0;
            for (int k = hv_idle_zstart[i]; k < hv_idle_zstart[i + 1]; ++k) {
                s += T[hv_idle_zone[k]] * hv_idle_w[k];
                sw += hv_idle_w[k];
            }
            c->v[j] = s / sw;
        } else if (has[i]) {
            c->v[j] = last[i];
        }
    }
}
#endif

/* the factor of switch s this step: 0 when its condition does not hold */
static double switch_value(hv_inst *c, int s) {
    const hv_switch *w = &hv_switches[s];
    if (w->input_index >= 0 && !(c->u[w->input_index] <= w->input_below)) return 0.0;
    if (w->disturbance_index >= 0 && !(c->v[w->disturbance_index] < w->disturbance_below)) return 0.0;
    return w->scale_by >= 0 ? c->v[w->scale_by] : 1.0;
}

#if HV_MODAL
#define HV_BLOCK 8 /* modes per register block */
/* zn, xsn = one modal step from z, xs with inputs c->u, c->v and gain row q */
static void modal_step(hv_inst *c, const double *z, const double *xs, const double *q, double *zn, double *xsn) {
    const double *u = c->u, *v = c->v;
    double w[HV_NWALL];
    double *a = w + HV_NU + HV_NV + HV_NQ, *sw = a + HV_NREP;
    memcpy(w, u, sizeof(double) * HV_NU);
    memcpy(w + HV_NU, v, sizeof(double) * HV_NV);
    memcpy(w + HV_NU + HV_NV, q, sizeof(double) * HV_NQ);
    for (int r = 0; r < HV_NREP; ++r) a[r] = 0.0;
    for (int t = 0; t < HV_NBT; ++t) {
        int src = hv_bt_src[t];
        a[hv_bt_rep[t]] += hv_bt_alpha[t] * u[hv_bt_input[t]] * (src >= 0 ? xs[src] : v[-1 - src]);
    }
    for (int s = 0; s < HV_NSWITCH; ++s) sw[s] = switch_value(c, s);
    double acc[HV_NS];
    for (int i = 0; i < HV_NS; ++i) acc[i] = 0.0;
    /* zn = lam z + P w and xsn = S zn, in blocks of HV_BLOCK modes kept in registers (the sums run in
     * the same order as column by column: k ascending for zn[j], j ascending for xsn[i]) */
    int j0 = 0;
    for (; j0 + HV_BLOCK <= HV_NX; j0 += HV_BLOCK) {
        double b[HV_BLOCK];
        for (int t = 0; t < HV_BLOCK; ++t) b[t] = hv_lam[j0 + t] * z[j0 + t];
        for (int k = 0; k < HV_NW; ++k) {
            const double wk = w[hv_P_src[k]];
            const double *col = hv_P + (size_t)k * HV_NX + j0;
            for (int t = 0; t < HV_BLOCK; ++t) b[t] += col[t] * wk;
        }
        for (int t = 0; t < HV_BLOCK; ++t) {
            const double *row = hv_ST + (size_t)(j0 + t) * HV_NS;
            zn[j0 + t] = b[t];
            for (int i = 0; i < HV_NS; ++i) acc[i] += row[i] * b[t];
        }
    }
    for (int j = j0; j < HV_NX; ++j) {
        double b = hv_lam[j] * z[j];
        for (int k = 0; k < HV_NW; ++k) b += hv_P[(size_t)k * HV_NX + j] * w[hv_P_src[k]];
        const double *row = hv_ST + (size_t)j * HV_NS;
        zn[j] = b;
        for (int i = 0; i < HV_NS; ++i) acc[i] += row[i] * b;
    }
    memcpy(xsn, acc, sizeof acc);
}

/* xn = step(x) in physical coordinates through the modal form (initialisation only: two dense products) */
static void phys_step(hv_inst *c, const double *x, const double *q, double *xn) {
    double *z = c->tmp, *zn = c->zn;
    double xs[HV_NS], xsn[HV_NS];
    for (int i = 0; i < HV_NX; ++i) {
        double s = 0.0;
        for (int j = 0; j < HV_NX; ++j) s += hv_W[(size_t)i * HV_NX + j] * x[j];
        z[i] = s;
    }
    for (int i = 0; i < HV_NS; ++i) xs[i] = x[hv_S_state[i]];
    modal_step(c, z, xs, q, zn, xsn);
    for (int i = 0; i < HV_NX; ++i) {
        double s = 0.0;
        for (int j = 0; j < HV_NX; ++j) s += hv_V[(size_t)i * HV_NX + j] * zn[j];
        xn[i] = s;
    }
}
#define STATE_STEP phys_step
#else
/* xn = step(x) with inputs c->u, c->v and gain row q */
static void step_state(hv_inst *c, const double *x, const double *q, double *xn) {
    const double *u = c->u, *v = c->v;
    memset(xn, 0, sizeof(double) * HV_NX);
    spmv_add(HV_MAT(hv_A, c), x, xn);
    spmv_add(HV_MAT(hv_Bu, c), u, xn);
    spmv_add(HV_MAT(hv_Bv, c), v, xn);
    spmv_add(HV_MAT(hv_Bq, c), q, xn);
#if HV_BILINEAR
    for (int i = 0; i < HV_NU; ++i) {
        if (u[i] == 0.0) continue;
        memset(c->tmp, 0, sizeof(double) * HV_NX);
        spmv_add(HV_MATI(hv_Bxu, c, i), x, c->tmp);
        spmv_add(HV_MATI(hv_Bvu, c, i), v, c->tmp);
        for (int j = 0; j < HV_NX; ++j) xn[j] += u[i] * c->tmp[j];
    }
#endif
#if HV_DPRODUCTS
    for (int i = 0; i < HV_NV; ++i) {
        if (v[i] == 0.0) continue;
        memset(c->tmp, 0, sizeof(double) * HV_NX);
        spmv_add(HV_MATI(hv_Bxv, c, i), x, c->tmp);
        spmv_add(HV_MATI(hv_Bvv, c, i), v, c->tmp);
        for (int j = 0; j < HV_NX; ++j) xn[j] += v[i] * c->tmp[j];
    }
#endif
    for (int s = 0; s < HV_NSWITCH; ++s) {
        double scale = switch_value(c, s);
        if (scale != 0.0)
            for (int j = 0; j < HV_NX; ++j) xn[j] += scale * hv_switches[s].gain[j];
    }
}
#define STATE_STEP step_state
#endif

/* Slot of model step k, the first of the current communication step: the time_of_week input (when set) is the
 * local time of week at the start of this step, so it gives the slot of step k itself (not of step 0) */
static long long slot_of_step(hv_inst *c, long long k) {
#if HV_VR_TOWIN >= 0
    double tow = c->s.r[HV_VR_TOWIN];
    if (tow >= 0.0) return hv_floor(tow / HV_STEP + 1e-9);
#endif
    return c->s.slot0 + k;
}

/* the physical value of output i */
static double output_value(const hv_state *s, int i) {
#if HV_MODAL
    return s->xs[hv_out_xs[i]];
#else
    return s->x[hv_out_state[i]];
#endif
}

static void write_outputs(hv_inst *c) {
    for (int i = 0; i < HV_NY; ++i) c->s.r[hv_vr_y[i]] = output_value(&c->s, i);
}

/* Advance the state n model steps from model step k (inputs held); commit only when the outputs stay finite. */
static int advance(hv_inst *c, int season, long long slot, long long n) {
    double x[HV_NX];
    memcpy(x, c->s.x, sizeof x);
#if HV_MODAL
    double xs[HV_NS];
    memcpy(xs, c->s.xs, sizeof xs);
#if HV_NIDLE
    double last[HV_NIDLE1], T[HV_NY];
    int has[HV_NIDLE1];
    memcpy(last, c->s.idle_last, sizeof last);
    memcpy(has, c->s.idle_has, sizeof has);
#endif
    for (long long j = 0; j < n; ++j) {
#if HV_NIDLE
        for (int i = 0; i < HV_NY; ++i) T[i] = xs[hv_out_xs[i]];
        idle_inputs(c, T, last, has);
#endif
        modal_step(c, x, xs, gains_row(season, slot + j), c->xn, xs);
        memcpy(x, c->xn, sizeof x);
    }
    for (int i = 0; i < HV_NY; ++i)
        if (!hv_finite(xs[hv_out_xs[i]])) return 0;
    memcpy(c->s.xs, xs, sizeof xs);
#else
#if HV_NIDLE
    double last[HV_NIDLE1], T[HV_NY];
    int has[HV_NIDLE1];
    memcpy(last, c->s.idle_last, sizeof last);
    memcpy(has, c->s.idle_has, sizeof has);
#endif
    for (long long j = 0; j < n; ++j) {
#if HV_NIDLE
        for (int i = 0; i < HV_NY; ++i) T[i] = x[hv_out_state[i]];
        idle_inputs(c, T, last, has);
#endif
        step_state(c, x, gains_row(season, slot + j), c->xn);
        memcpy(x, c->xn, sizeof x);
    }
    for (int i = 0; i < HV_NY; ++i)
        if (!hv_finite(x[hv_out_state[i]])) return 0;
#endif
    memcpy(c->s.x, x, sizeof x);
#if HV_NIDLE
    memcpy(c->s.idle_last, last, sizeof last);
    memcpy(c->s.idle_has, has, sizeof has);
#endif
    return 1;
}

/* Solve a (n x n, row-major, overwritten) z = b by Gaussian elimination with partial pivoting. */
static int solve(double *a, double *b, int n) {
    for (int p = 0; p < n; ++p) {
        int best = p;
        for (int i = p + 1; i < n; ++i)
            if (hv_fabs(a[i * n + p]) > hv_fabs(a[best * n + p])) best = i;
        if (a[best * n + p] == 0.0) return 0;
        if (best != p) {
            for (int j = 0; j < n; ++j) {
                double t = a[p * n + j];
                a[p * n + j] = a[best * n + j];
                a[best * n + j] = t;
            }
            double t = b[p];
            b[p] = b[best];
            b[best] = t;
        }
        for (int i = p + 1; i < n; ++i) {
            double f = a[i * n + p] / a[p * n + p];
            if (f == 0.0) continue;
            for (int j = p; j < n; ++j) a[i * n + j] -= f * a[p * n + j];
            b[i] -= f * b[p];
        }
    }
    for (int i = n - 1; i >= 0; --i) {
        double s = b[i];
        for (int j = i + 1; j < n; ++j) s -= a[i * n + j] * b[j];
        b[i] = s / a[i * n + i];
    }
    return 1;
}

/* Initial state: outputs at their start values, unobserved states at their steady state for
 * the inputs and gains held (x = F x + g, F and g probed from step_state); mean of the start
 * values when that system is singular or not finite. Returns 0 when out of memory. */
static int initial_state(hv_inst *c, const double *y0, const double *q) {
    double *x = c->s.x;
    double mean = 0.0;
    int nh = HV_NX - HV_NY;
    for (int i = 0; i < HV_NY; ++i) mean += y0[i];
    mean /= HV_NY;
    for (int j = 0; j < HV_NX; ++j) x[j] = mean;
    for (int i = 0; i < HV_NY; ++i) x[hv_out_state[i]] = y0[i];
    if (nh == 0) return 1;
    double *g = calloc(HV_NX, sizeof(double));
    double *e = calloc(HV_NX, sizeof(double));
    double *col = calloc(HV_NX, sizeof(double));
    double *a = calloc((size_t)nh * nh, sizeof(double));
    double *b = calloc(nh, sizeof(double));
    if (!g || !e || !col || !a || !b) {
        free(g), free(e), free(col), free(a), free(b);
        return 0;
    }
    STATE_STEP(c, e, q, g); /* g = step(0) */
    for (int i = 0; i < nh; ++i) b[i] = g[hv_hidden_state[i]];
    for (int j = 0; j < HV_NX; ++j) { /* column j of F */
        e[j] = 1.0;
        STATE_STEP(c, e, q, col);
        e[j] = 0.0;
        int jh = hv_hidden_index[j];
        for (int i = 0; i < nh; ++i) {
            double f = col[hv_hidden_state[i]] - g[hv_hidden_state[i]];
            if (jh >= 0)
                a[i * nh + jh] = (i == jh ? 1.0 : 0.0) - f;
            else
                b[i] += f * x[j]; /* observed state at its start value */
        }
    }
    int ok = solve(a, b, nh);
    for (int i = 0; ok && i < nh; ++i) ok = hv_finite(b[i]);
    if (ok)
        for (int i = 0; i < nh; ++i) x[hv_hidden_state[i]] = b[i];
    free(g), free(e), free(col), free(a), free(b);
    return 1;
}

/* Modal form: the state x (physical, in c->s.x) becomes z = W x, with xs = x[S_state] exactly. */
static void to_modal(hv_inst *c) {
#if HV_MODAL
    double *x = c->s.x, *z = c->tmp;
    for (int i = 0; i < HV_NS; ++i) c->s.xs[i] = x[hv_S_state[i]];
    for (int i = 0; i < HV_NX; ++i) {
        double s = 0.0;
        for (int j = 0; j < HV_NX; ++j) s += hv_W[(size_t)i * HV_NX + j] * x[j];
        z[i] = s;
    }
    memcpy(x, z, sizeof(double) * HV_NX);
#else
    (void)c;
#endif
}

/* ------------------------------------------------------------------ checks */
static int check_inputs(hv_inst *c, double t) {
    char names[1500];
    size_t used = 0;
    int bad = 0;
    names[0] = 0;
    for (int i = 0; i < HV_NIN; ++i) {
        int vr = hv_vr_in[i];
        double val = c->s.r[vr];
        if (val >= hv_var_min[vr] && val <= hv_var_max[vr]) continue; /* NaN fails both */
        ++bad;
        if (used < sizeof names - 200)
            used += snprintf(names + used, sizeof names - used, "%s%s=%.17g (allowed [%g, %g])", bad > 1 ? ", " : "",
                             hv_var_name[vr], val, hv_var_min[vr], hv_var_max[vr]);
    }
    if (bad) hv_log(c, fmi2Error, "logStatusError", "at t=%.17g s: invalid input value(s): %s; step not taken", t, names);
    return !bad;
}

static int check_parameters(hv_inst *c) {
    int ok = 1;
    for (int i = 0; i < HV_NY; ++i) {
        double val = c->s.r[hv_vr_y0[i]];
        if (!(val >= -60.0 && val <= 80.0)) {
            hv_log(c, fmi2Error, "logStatusError", "initialisation failed: %s=%.17g degC is outside [-60, 80]",
                   hv_var_name[hv_vr_y0[i]], val);
            ok = 0;
        }
    }
    double season = c->s.r[HV_VR_SEASON];
    if (season == 0) {
        /* the Python FMU's "follow the calendar": this FMU has no calendar (no start_time, no time zone) */
        hv_log(c, fmi2Error, "logStatusError",
               "initialisation failed: season=0 (follow the calendar's seasons) is not supported by the native FMU, "
               "which has no calendar (no start_time, no time zone): choose one season, one of %s, and split a run "
               "that crosses a season boundary into one run per season, or use the Python FMU exported with the "
               "building file (hvacfmu export -b BUILDING, without --native), whose season=0 switches season at "
               "the building's season dates", HV_SEASONS);
        ok = 0;
    } else if (!(season >= 1 && season <= HV_NSEASON)) {
        hv_log(c, fmi2Error, "logStatusError", "initialisation failed: season=%g is not one of %s", season, HV_SEASONS);
        ok = 0;
    }
    double tow = c->s.r[HV_VR_TOW];
    if (!(tow >= 0.0 && tow <= 604800.0)) {
        hv_log(c, fmi2Error, "logStatusError", "initialisation failed: start_time_of_week=%.17g s is outside [0, 604800]", tow);
        ok = 0;
    }
    return ok;
}

/* ------------------------------------------------------------------ FMI: common */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[]) {
    (void)nCategories, (void)categories;
    ((hv_inst *)comp)->logging_on = loggingOn ? 1 : 0;
    return fmi2OK;
}

static void reset_state(hv_inst *c) {
    memset(&c->s, 0, sizeof c->s);
    c->s.magic = HV_STATE_MAGIC;
    c->s.size = (int)sizeof(hv_state);
    for (int vr = 0; vr < HV_NVARS; ++vr) c->s.r[vr] = hv_var_start[vr];
    c->pending = 0;
    c->in_init = 0;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)fmuResourceLocation, (void)visible;
    hv_inst *c;
    if (!functions) return NULL;
    c = calloc(1, sizeof(hv_inst));
    if (!c) return NULL;
    c->cb = *functions;
    snprintf(c->name, sizeof c->name, "%s", instanceName ? instanceName : "hvacfmu");
    c->logging_on = loggingOn ? 1 : 0;
    if (fmuType != fmi2CoSimulation) {
        hv_log(c, fmi2Error, "logStatusError", "this FMU supports co-simulation only (fmi2CoSimulation)");
        free(c);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, HV_GUID) != 0) {
        hv_log(c, fmi2Error, "logStatusError", "GUID %s does not match this FMU's %s (modelDescription.xml replaced?)",
               fmuGUID ? fmuGUID : "(null)", HV_GUID);
        free(c);
        return NULL;
    }
    reset_state(c);
    return c;
}

void fmi2FreeInstance(fmi2Component comp) { free(comp); }

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    hv_inst *c = comp;
    if (!hv_finite(startTime)) {
        hv_log(c, fmi2Error, "logStatusError", "fmi2SetupExperiment: start time %g is not finite", startTime);
        return fmi2Error;
    }
    c->s.t_start = c->s.t = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
    ((hv_inst *)comp)->in_init = 1;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {
    hv_inst *c = comp;
    c->in_init = 0;
    if (!check_parameters(c)) {
        c->s.failed = 1;
        return fmi2Error;
    }
    model_inputs(c);
    for (int vr = 0; vr < HV_NVARS; ++vr) {
        int role = hv_var_role[vr];
        if ((role == R_M || role == R_V || role == R_TOWIN) && !hv_finite(c->s.r[vr])) {
            hv_log(c, fmi2Error, "logStatusError", "initialisation failed: input %s is not finite", hv_var_name[vr]);
            c->s.failed = 1;
            return fmi2Error;
        }
    }
    c->s.slot0 = hv_floor((c->s.r[HV_VR_TOW] + c->s.t_start) / HV_STEP + 1e-9);
    double y0[HV_NY];
    for (int i = 0; i < HV_NY; ++i) y0[i] = c->s.r[hv_vr_y0[i]];
    const double *q = gains_row((int)c->s.r[HV_VR_SEASON], slot_of_step(c, 0));
#if HV_NIDLE
    for (int i = 0; i < HV_NIDLE; ++i) c->s.idle_has[i] = 0;
    { /* the initial state sees the inputs the first step will (the rule's memory starts empty) */
        double last[HV_NIDLE1];
        int has[HV_NIDLE1] = {0};
        idle_inputs(c, y0, last, has);
    }
#endif
    if (!initial_state(c, y0, q)) {
        hv_log(c, fmi2Error, "logStatusError", "initialisation failed: out of memory");
        return fmi2Error;
    }
    to_modal(c);
    c->s.k = 0;
    c->s.t = c->s.t_start;
    c->s.initialized = 1;
    c->s.failed = 0;
    write_outputs(c);
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp) { (void)comp; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component comp) {
    reset_state((hv_inst *)comp);
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMI: values */
static fmi2Status bad_vr(hv_inst *c, const char *fn, fmi2ValueReference vr) {
    snprintf(c->pending_msg, sizeof c->pending_msg, "%s: value reference %u is not a variable of this type", fn, (unsigned)vr);
    c->pending = 1;
    hv_log(c, fmi2Error, "logStatusError", "%s", c->pending_msg);
    return fmi2Error;
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    hv_inst *c = comp;
    for (size_t i = 0; i < nvr; ++i) {
        if (vr[i] >= HV_NVARS || hv_var_role[vr[i]] == R_SEASON) return bad_vr(c, "fmi2GetReal", vr[i]);
        value[i] = c->s.r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    hv_inst *c = comp;
    for (size_t i = 0; i < nvr; ++i) {
        if (vr[i] >= HV_NVARS || hv_var_role[vr[i]] != R_SEASON) return bad_vr(c, "fmi2GetInteger", vr[i]);
        value[i] = (fmi2Integer)c->s.r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)value;
    return nvr ? bad_vr(comp, "fmi2GetBoolean (no Boolean variables)", vr[0]) : fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)value;
    return nvr ? bad_vr(comp, "fmi2GetString (no String variables)", vr[0]) : fmi2OK;
}

static int settable(hv_inst *c, fmi2ValueReference vr) {
    int role = hv_var_role[vr];
    if (role == R_Y) {
        hv_log(c, fmi2Error, "logStatusError", "%s is an output and cannot be set", hv_var_name[vr]);
        return 0;
    }
    if ((role == R_Y0 || role == R_SEASON || role == R_TOW) && c->s.initialized) {
        hv_log(c, fmi2Error, "logStatusError",
               "%s is a fixed parameter; setting it after initialisation is not allowed and was ignored "
               "(set it before fmi2ExitInitializationMode)", hv_var_name[vr]);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    hv_inst *c = comp;
    fmi2Status status = fmi2OK;
    for (size_t i = 0; i < nvr; ++i) {
        if (vr[i] >= HV_NVARS || hv_var_role[vr[i]] == R_SEASON) return bad_vr(c, "fmi2SetReal", vr[i]);
        if (!settable(c, vr[i])) {
            status = fmi2Error;
            continue;
        }
        c->s.r[vr[i]] = value[i];
    }
    return status;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    hv_inst *c = comp;
    fmi2Status status = fmi2OK;
    for (size_t i = 0; i < nvr; ++i) {
        if (vr[i] >= HV_NVARS || hv_var_role[vr[i]] != R_SEASON) return bad_vr(c, "fmi2SetInteger", vr[i]);
        if (!settable(c, vr[i])) {
            status = fmi2Error;
            continue;
        }
        c->s.r[vr[i]] = value[i];
    }
    return status;
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)value;
    return nvr ? bad_vr(comp, "fmi2SetBoolean (no Boolean variables)", vr[0]) : fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)value;
    return nvr ? bad_vr(comp, "fmi2SetString (no String variables)", vr[0]) : fmi2OK;
}

/* ------------------------------------------------------------------ FMI: state */
fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *state) {
    hv_inst *c = comp;
    hv_state *s = *state ? (hv_state *)*state : malloc(sizeof(hv_state));
    if (!s) {
        hv_log(c, fmi2Error, "logStatusError", "fmi2GetFMUstate: out of memory");
        return fmi2Error;
    }
    *s = c->s;
    *state = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate state) {
    hv_inst *c = comp;
    const hv_state *s = state;
    if (!s || s->magic != HV_STATE_MAGIC || s->size != (int)sizeof(hv_state)) {
        hv_log(c, fmi2Error, "logStatusError", "fmi2SetFMUstate: not a state of this FMU; state unchanged");
        return fmi2Error;
    }
    c->s = *s;
    c->pending = 0;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *state) {
    (void)comp;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate state, size_t *size) {
    (void)comp, (void)state;
    *size = sizeof(hv_state);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    hv_inst *c = comp;
    if (size < sizeof(hv_state)) {
        hv_log(c, fmi2Error, "logStatusError", "fmi2SerializeFMUstate: buffer of %u bytes, need %u", (unsigned)size,
               (unsigned)sizeof(hv_state));
        return fmi2Error;
    }
    memcpy(bytes, state, sizeof(hv_state));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    hv_inst *c = comp;
    hv_state tmp;
    if (size != sizeof(hv_state)) {
        hv_log(c, fmi2Error, "logStatusError", "fmi2DeSerializeFMUstate: %u bytes, a state of this FMU has %u",
               (unsigned)size, (unsigned)sizeof(hv_state));
        return fmi2Error;
    }
    memcpy(&tmp, bytes, sizeof tmp);
    if (tmp.magic != HV_STATE_MAGIC || tmp.size != (int)sizeof(hv_state)) {
        hv_log(c, fmi2Error, "logStatusError", "fmi2DeSerializeFMUstate: not a state of this FMU");
        return fmi2Error;
    }
    hv_state *s = malloc(sizeof(hv_state));
    if (!s) return fmi2Error;
    *s = tmp;
    *state = s;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown[], size_t nUnknown,
                                        const fmi2ValueReference vKnown[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown, (void)nUnknown, (void)vKnown, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    hv_log(comp, fmi2Error, "logStatusError", "fmi2GetDirectionalDerivative is not provided");
    return fmi2Error;
}

/* ------------------------------------------------------------------ FMI: co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    hv_log(comp, fmi2Error, "logStatusError", "fmi2SetRealInputDerivatives is not provided (inputs are held)");
    return fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    hv_log(comp, fmi2Error, "logStatusError", "fmi2GetRealOutputDerivatives is not provided");
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    hv_inst *c = comp;
    if (c->pending) {
        c->pending = 0;
        hv_log(c, fmi2Error, "logStatusError", "step refused after an earlier error: %s", c->pending_msg);
        return fmi2Error;
    }
    if (!c->s.initialized) {
        hv_log(c, fmi2Error, "logStatusError",
               c->s.failed ? "fmi2DoStep: initialisation had failed (see the earlier message)"
                           : "fmi2DoStep called before initialisation; call fmi2SetupExperiment, "
                             "fmi2EnterInitializationMode and fmi2ExitInitializationMode first");
        return fmi2Error;
    }
    if (!check_inputs(c, t)) return fmi2Error;
    if (!hv_finite(t) || hv_fabs(t - c->s.t) > 1e-9 * (hv_fabs(c->s.t) > 1.0 ? hv_fabs(c->s.t) : 1.0)) {
        hv_log(c, fmi2Error, "logStatusError",
               "fmi2DoStep at t=%.17g s but the FMU is at t=%.17g s; steps must be contiguous "
               "(restore a saved FMU state to go back in time)", t, c->s.t);
        return fmi2Error;
    }
    double kf = h / HV_STEP;
    long long n = hv_floor(kf + 0.5);
    if (!hv_finite(kf) || n < 1 || hv_fabs(kf - (double)n) > 1e-9 * (kf > 1.0 ? kf : 1.0)) {
        hv_log(c, fmi2Error, "logStatusError",
               "communication step %.17g s at t=%.17g s is not a whole multiple of the model step %g s; step refused "
               "(use a step of k*%g s, k >= 1)", h, t, HV_STEP, HV_STEP);
        return fmi2Error;
    }
    model_inputs(c);
    if (!advance(c, (int)c->s.r[HV_VR_SEASON], slot_of_step(c, c->s.k), n)) {
        hv_log(c, fmi2Error, "logStatusError",
               "the zone temperatures became non-finite in the step from t=%.17g s; step refused", t);
        return fmi2Error;
    }
    c->s.k += n;
    c->s.t = c->s.t_start + (double)c->s.k * HV_STEP;
    write_outputs(c);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
    hv_log(comp, fmi2Error, "logStatusError", "fmi2CancelStep: steps are synchronous");
    return fmi2Error;
}

static fmi2Status no_status(fmi2Component comp, const char *fn) {
    hv_log(comp, fmi2Discard, "logStatusDiscard", "%s: steps are synchronous, no status to report", fn);
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    return no_status(comp, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value) {
    hv_inst *c = comp;
    if (s == fmi2LastSuccessfulTime) {
        *value = c->s.t;
        return fmi2OK;
    }
    return no_status(comp, "fmi2GetRealStatus");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    return no_status(comp, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value) {
    if (s == fmi2Terminated) {
        /* asked by FMPy after a discard (this FMU refuses steps with fmi2Error, but a master may still ask):
         * true ends its run at fmi2LastSuccessfulTime (false makes FMPy retry the same step forever) */
        *value = fmi2True;
        return fmi2OK;
    }
    return no_status(comp, "fmi2GetBooleanStatus");
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    return no_status(comp, "fmi2GetStringStatus");
}
