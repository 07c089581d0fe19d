/* The fixed-step master loop for native FMI 2.0 co-simulation FMUs, without Python between FMI calls.
 *
 * Python (native_loop.py) describes one master step as a list of operations on the master's own buffers,
 * in the order and with the conditions of the compiled Python step (compiled.py), and this loop runs
 * steps [n0, n1) of it. Every value it computes is computed with the same IEEE operations as the Python
 * path (t = start + n*h; a transfer is a copy, then a multiply, then an add, as np.take and the in-place
 * numpy operations do; build with -ffp-contract=off so that no multiply-add is fused), so results are
 * bit-identical. It returns to Python at every point where Python must look: an FMI status above Warning,
 * an FMI 3.0 doStep that returned early or asks to terminate, a full recording block, a non-finite output.
 */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <string.h>

enum { OP_XFER_REAL = 1, OP_XFER_INT32 = 2, OP_SET = 3, OP_STEP = 4, OP_GET = 5, OP_PUBLISH = 6, OP_SET3 = 7,
       OP_GET3 = 8, OP_STEP3 = 9 };
enum { GATHER_F64 = 1, GATHER_I32 = 2, GATHER_BITS64 = 3 };
enum { DONE = 0, OP_FAILED = 1, SAMPLE_FAILED = 2, BLOCK_FULL = 3, NONFINITE = 4, STEP3_LOOK = 5 };

typedef int (*fmi2_io)(void *, const unsigned int *, size_t, void *);
typedef int (*fmi2_do_step)(void *, double, double, int);
typedef int (*fmi3_io)(void *, const unsigned int *, size_t, void *, size_t);
typedef int (*fmi3_do_step)(void *, double, double, bool, bool *, bool *, bool *, double *);

/* every field 8 bytes wide: the ctypes mirror in native_loop.py is then trivially laid out */
typedef struct {
    long long kind, comp, every, phase;  /* due when (n + phase) % every == 0 */
    void *fn, *inst;
    const unsigned int *vr;
    long long n;                         /* values (transfers, ports) or bytes (publish) */
    void *dst;
    const void *src;
    const long long *idx;                /* transfers: positions in src */
    const double *factor, *offset;       /* Real transfers with a linear transformation, else NULL */
    double h;                            /* the component's step (master step times its multiple) */
    long long nvalues;                   /* FMI 3.0 get/set: values (an array variable has several) */
    long long no_set_prior;              /* FMI 3.0 doStep: noSetFMUStatePriorToCurrentPoint */
    bool *event, *terminate, *early;     /* FMI 3.0 doStep: the slave's own flags ... */
    double *last;                        /* ... and lastSuccessfulTime, which Fmi3Slave.after_do_step reads */
} cm_op;

typedef struct {
    long long kind;
    const void *src;
    const long long *pos;
    long long n, col;
} cm_gather;

typedef struct {
    double start, h;
    cm_op *ops;
    long long n_ops;
    cm_op *samples;                      /* reads of the recorded-only variables, at record points */
    long long n_samples;
    long long every, steps;              /* record after step n when (n+1) % every == 0 or n+1 == steps; 0: never */
    double *block;
    long long block_rows, ncols, fill;
    cm_gather *gathers;
    long long n_gathers;
    const double *check;                 /* Real outputs that must stay finite, or NULL */
    long long n_check;
    long long *counts;                   /* doStep calls per component */
    long long n, code, op, status;       /* out: steps done, why it returned, which operation, its status */
    /* progress for a supervisor (supervise.py), kept as its Python path keeps it; a scratch array when there is
     * none. Plain stores into shared memory, no system call: the time reached after every step, the time and
     * count of the rows recorded at every row, and the component whose FMI call is in progress (-1: none), so
     * that a crash inside an FMU is pinned on its component. */
    double *time_reached, *last_row, *rows, *busy;
} cm_loop;

static int run_op(cm_loop *L, const cm_op *o, double t) {
    long long k;
    switch (o->kind) {
    case OP_XFER_REAL: {
        double *d = (double *)o->dst;
        const double *s = (const double *)o->src;
        for (k = 0; k < o->n; k++)
            d[k] = s[o->idx[k]];
        if (o->factor) {
            for (k = 0; k < o->n; k++)
                d[k] = d[k] * o->factor[k];
            for (k = 0; k < o->n; k++)
                d[k] = d[k] + o->offset[k];
        }
        return 0;
    }
    case OP_XFER_INT32: {
        int *d = (int *)o->dst;
        const int *s = (const int *)o->src;
        for (k = 0; k < o->n; k++)
            d[k] = s[o->idx[k]];
        return 0;
    }
    case OP_SET:
    case OP_GET:
        *L->busy = (double)o->comp;
        return ((fmi2_io)o->fn)(o->inst, o->vr, (size_t)o->n, o->dst);
    case OP_STEP:
        *L->busy = (double)o->comp;
        L->counts[o->comp]++;
        return ((fmi2_do_step)o->fn)(o->inst, t, o->h, 1);
    case OP_SET3:
    case OP_GET3:
        *L->busy = (double)o->comp;
        return ((fmi3_io)o->fn)(o->inst, o->vr, (size_t)o->n, o->dst, (size_t)o->nvalues);
    case OP_STEP3: {
        int st;
        *L->busy = (double)o->comp;
        L->counts[o->comp]++;
        st = ((fmi3_do_step)o->fn)(o->inst, t, o->h, o->no_set_prior != 0, o->event, o->terminate, o->early,
                                   o->last);
        /* all but a plain step (an error, a request to terminate, an early return) is Python's to finish */
        return (st > 1 || *o->terminate || *o->early) ? -1 - st : st;
    }
    case OP_PUBLISH:
        memcpy(o->dst, o->src, (size_t)o->n);
        return 0;
    }
    return 4;
}

static int all_finite(const cm_loop *L) {
    long long k;
    for (k = 0; k < L->n_check; k++)
        if (!isfinite(L->check[k]))
            return 0;
    return 1;
}

static void record(cm_loop *L, double t1) {
    double *row = L->block + L->fill * L->ncols;
    long long g, k;
    row[0] = t1;
    for (g = 0; g < L->n_gathers; g++) {
        const cm_gather *G = &L->gathers[g];
        double *cell = row + G->col;
        if (G->kind == GATHER_F64)
            for (k = 0; k < G->n; k++)
                cell[k] = ((const double *)G->src)[G->pos[k]];
        else if (G->kind == GATHER_I32)
            for (k = 0; k < G->n; k++)
                cell[k] = (double)((const int *)G->src)[G->pos[k]];
        else
            for (k = 0; k < G->n; k++)
                memcpy(cell + k, (const long long *)G->src + G->pos[k], 8);
    }
    L->fill++;
}

/* Return to Python with ``code`` after ``n`` steps. After a failed FMI call the component stays marked busy: Python
 * finishes that call (its status, the FMU's log, a request to terminate). */
static int leave(cm_loop *L, long long n, int code) {
    L->n = n;
    L->code = code;
    if (code != OP_FAILED && code != STEP3_LOOK && code != SAMPLE_FAILED)
        *L->busy = -1.0;
    return code;
}

/* Steps n0 .. n1-1, the first from operation op0 on. ``rest_only``: finish step n0 from op0 and return
 * (after an FMU asked to end the run in its doStep; Python then does what follows the step). */
int cm_run(cm_loop *L, long long n0, long long n1, long long op0, int rest_only) {
    long long n, k;
    for (n = n0; n < n1; n++) {
        double t = L->start + (double)n * L->h;
        double t1;
        for (k = op0; k < L->n_ops; k++) {
            const cm_op *o = &L->ops[k];
            int st;
            if (o->every > 1 && (n + o->phase) % o->every != 0)
                continue;
            st = run_op(L, o, t);
            if (st > 1) {
                L->op = k; L->status = st;
                return leave(L, n, OP_FAILED);
            }
            if (st < 0) {
                L->op = k; L->status = -1 - st;
                return leave(L, n, STEP3_LOOK);
            }
        }
        op0 = 0;
        if (rest_only)
            return leave(L, n + 1, DONE);
        t1 = L->start + (double)(n + 1) * L->h;
        *L->time_reached = t1;
        if (L->every && ((n + 1) % L->every == 0 || n + 1 == L->steps)) {
            for (k = 0; k < L->n_samples; k++) {
                int st = run_op(L, &L->samples[k], t1);
                if (st > 1) {
                    L->op = k; L->status = st;
                    return leave(L, n, SAMPLE_FAILED);
                }
            }
            record(L, t1);
            /* after the row is whole: a supervisor keeps exactly the rows counted here */
            *L->last_row = t1;
            *L->rows = (double)L->fill;
            if (L->fill == L->block_rows) {
                L->status = L->check && !all_finite(L);
                return leave(L, n + 1, BLOCK_FULL);
            }
        }
        if (L->check && !all_finite(L))
            return leave(L, n + 1, NONFINITE);
    }
    return leave(L, n1, DONE);
}
