/* Shared integrator machinery: set-up, error norm, initial step, step-size guards, output sampling.
 * Every method (dopri5.c, rodasp.c) builds on these; see mbs_runtime.h for the mbs_ode contract. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef MBS_ODE_TRACE  /* -DMBS_ODE_TRACE=1: each restart and each event handed back written to stderr (dopri5.c) */
#include <stdio.h>
#endif

#include "mbs_runtime.h"

/* Grow the step by at most this factor when the error estimate is tiny (Hairer's FAC2 for DOPRI5). */
#define MBS_ODE_MAX_GROWTH 10.0
/* Shrink the step by this factor after the model reported a failure (e.g. non-finite values):
 * stronger than an ordinary rejection because the failure carries no error estimate. */
#define MBS_ODE_MODEL_FAILURE_SHRINK 0.25
/* The look ahead after a restart that tells which side an indicator at zero leaves to (DEPARTURE_STEP of
 * runtime/events.py), relative to max(1, |t|). */
#define MBS_ODE_DEPARTURE_STEP 1e-12
/* Crossings at most this far after the earliest of a step (relative to max(1, |t|)) are one event (see
 * mbs_ode_find_event); at least MBS_ODE_DEPARTURE_STEP.  -DMBS_ODE_TWIN_WINDOW=1e-12 builds the former window. */
#ifndef MBS_ODE_TWIN_WINDOW
#define MBS_ODE_TWIN_WINDOW 1e-10
#endif
/* A second crossing at most this far after an event (relative to max(1, |t|)) is reached by an Euler step from the
 * restart instead of a step of the method (see mbs_ode_bridge) ... */
#define MBS_ODE_BRIDGE_GAP 1e-6
/* ... when that step's error estimate, in the method's error norm, is at most this (a step accepted with room) */
#define MBS_ODE_BRIDGE_ERROR 1e-2
/* The first step after a restart that went through without a rejection lets the next restart of that indicator in
 * that direction start this much larger again (up to the controller's step: see mbs_ode_learn_first_step). */
#define MBS_ODE_FIRST_STEP_RELAX 1.2

/* handled[k] of an event whose actions make the state leave the constraints it was on (on a model with loops a
 * prescribed motion's switch: its speed steps, and the loops' speeds with it): mbs_ode_restart applies it, projects
 * the state with the model's projection (o->project, as every accepted step) and restarts from there, what the
 * caller does when the event is handed back to it (runtime/event_loop.py), without a new solver.
 * -DMBS_ODE_PRESCRIBED_FORMER=1 builds the former behaviour: such an event goes back to the caller (the same-run
 * baseline of bench/restart_steps.py --former prescribed). */
#define MBS_ODE_HANDLED_PROJECT 2
#ifdef MBS_ODE_PRESCRIBED_FORMER
#define MBS_ODE_PROJECT_IN_C 0
#else
#define MBS_ODE_PROJECT_IN_C 1
#endif

/* The root finder's memory of one step (mbs_ode_trials), and how many trial points it keeps: a crossing takes about
 * eight evaluations, the indicators that cross in one step together (the twin wheels) a dozen or two. */
#define MBS_ODE_TRIALS 64
/* -DMBS_ODE_EVENTS_FORMER=1 builds the former root finding (each crossing located from the step's ends alone, the
 * departure probe taken every time, the indicators at an event evaluated again by the restart): the same-run
 * baseline of bench/event_instructions.py --machinery. */
#ifdef MBS_ODE_EVENTS_FORMER
#define MBS_ODE_SHARE_TRIALS 0
#else
#define MBS_ODE_SHARE_TRIALS 1
#endif

/* Every trial point of one step's root finding evaluates all the indicators that crossed in the step (each
 * crossing indicator's search, in turn): its trial points bracket the others' crossings too.  The mirror-image
 * wheels of the symmetric Iltis cross within 1e-14 to 1e-9 s of each other in nearly every step with a crossing: the
 * second one's search starts from the tightest bracket the first one's trial points give (a few doubles wide) instead
 * of the whole step.  When the trial points evaluated every indicator (a model without mbs_event_indicator: see
 * mbs_ode_search), the indicators at the located event are kept for the restart there, evaluated at the same time
 * and state with the same parameters: the same bits. */
typedef struct mbs_ode_trials {
    int count;              /* trial points kept from the current search (at most MBS_ODE_TRIALS) */
    double t[MBS_ODE_TRIALS];
    double *g;              /* [MBS_ODE_TRIALS * nev]: the indicators at t[i] are g[i nev .. (i + 1) nev) */
    int g_old_exact;        /* g_old holds the indicators evaluated at t_old (not departing values: see
                             * mbs_ode_depart; external callers may write departing values after set_events) */
    int event_ready;        /* g_event holds the indicators at the located event t_event, parameters unchanged */
    int nsearch;            /* > 0: the trial points evaluate the indicators search[0 .. nsearch) alone (the ones
                             * that crossed in the step: mbs_ode_search), the rest of their rows is stale; 0: all */
    int *search;            /* [nev] */
    double t_event;
    double *g_event;        /* [nev] */
} mbs_ode_trials;

static void mbs_ode_free_trials(mbs_ode_trials *tr)
{
    if (!tr) return;
    free(tr->g); free(tr->g_event); free(tr->search);
    free(tr);
}

/* Events restarted in C (see mbs_ode_restart): which indicators qualify and what their actions assign, and the
 * log of the events handled since the caller last read it. */
typedef struct mbs_ode_restarts {
    double *p;              /* the parameters the run uses (o->p), writable: modes and branch flags change */
    mbs_fn actions;         /* mbs_event_actions (the values the actions assign), or NULL without values */
    int nvalues;            /* its output size */
    int *handled;           /* [nev]: 1 when the event can be applied here (no jump of x, not terminal), 2 when
                             * so but the state is projected after it (MBS_ODE_HANDLED_PROJECT) */
    int *flag;              /* [nev]: p index of a switch's branch flag, or -1 */
    int *first;             /* [nev + 1]: the p assignments of event k are index[first[k] .. first[k + 1]) */
    int *index, *slot;      /* p index assigned, and the slot of the actions' output it takes */
    double window;          /* an indicator firing again this close after its last event here goes back to the
                             * caller (chattering); another indicator may fire within it (the twin wheel) */
    double *last_t;         /* [nev]: per indicator, the time of its last event handled here (-HUGE_VAL: none) */
    double h_cut;           /* size of the step in which the pending event was located */
    double t_next;          /* the next crossing located in that step after the event (HUGE_VAL: none) */
    double h_resume;        /* > 0: the step size to go on with after the short step to t_next */
    double t_fence;         /* the next sample time: an Euler bridge to a second crossing stays before it */
    double *f_bridge;       /* [n]: the rhs at the end of an Euler bridge */
    double *first_step;     /* [2 nev]: per indicator, falling and rising, the fraction of the controller's step the
                             * first step after its last restart took (1: none rejected; mbs_ode_learn_first_step) */
    int learning;           /* the index into first_step of the restart whose first step is under way, or -1 */
    double h_tried;         /* the size that first step was tried with */
    long capacity, count;   /* log entries: room for, and taken */
    size_t width;           /* doubles per entry: t, y before [n], x after [n], g before [nev], g at [nev], values */
    double *log;            /* [capacity * width] */
} mbs_ode_restarts;

static void mbs_ode_free_restarts(mbs_ode_restarts *r)
{
    if (!r) return;
    free(r->handled); free(r->flag); free(r->first); free(r->index); free(r->slot); free(r->log);
    free(r->f_bridge); free(r->first_step); free(r->last_t);
    free(r);
}

static void mbs_ode_free(mbs_ode *o)
{
    mbs_ode_free_restarts(o->restarts);
    mbs_ode_free_trials(o->trials);
    if (o->release) o->release(o);
    free(o->atol); free(o->y); free(o->f); free(o->cont); free(o->impl); free(o->yproj);
    free(o->directions); free(o->g_old); free(o->g_new); free(o->g_try); free(o->t_located); free(o->y_try);
    memset(o, 0, sizeof *o);
}

/* Evaluate the model; remember any failure status so a later message can name it. */
static int mbs_ode_eval(mbs_ode *o, double t, const double *y, double *out)
{
    int s = o->fn(t, y, o->p, out, o->work);
    o->nfev++;
    if (s != MBS_OK) o->model_status = s;
    return s;
}

/* Allocate the shared arrays and evaluate f(t0, y0).  Returns 0, or -1 if memory ran out.  A model
 * failure at the initial point is not an error here: it sets status = MBS_ODE_MODEL_FAILED. */
static int mbs_ode_setup(mbs_ode *o, int n, mbs_fn fn, const double *p, double *work, double t0,
                         const double *y0, double t_bound, double rtol, const double *atol, int natol,
                         double h0, double h_max, double h_min, long max_steps, size_t ncont)
{
    int i;
    memset(o, 0, sizeof *o);
    o->n = n; o->fn = fn; o->p = p; o->work = work;
    o->rtol = rtol; o->t_bound = t_bound;
    o->h_max = h_max > 0 ? h_max : fabs(t_bound - t0);
    o->h_min = h_min > 0 ? h_min : 0.0;
    o->max_steps = max_steps;
    o->t = o->t_old = t0;
    o->h = h0;
    o->ncont = ncont;
    /* calloc(0) may return NULL: allocate at least one element so NULL always means "out of memory" */
    o->atol = calloc((size_t)n + 1, sizeof(double));
    o->y = calloc((size_t)n + 1, sizeof(double));
    o->f = calloc((size_t)n + 1, sizeof(double));
    o->cont = calloc(ncont + 1, sizeof(double));
    if (!o->atol || !o->y || !o->f || !o->cont) return -1;
    for (i = 0; i < n; i++) {
        o->atol[i] = natol == 1 ? atol[0] : atol[i];
        o->y[i] = y0[i];
    }
    o->status = mbs_ode_eval(o, t0, o->y, o->f) == MBS_OK ? MBS_ODE_RUNNING : MBS_ODE_MODEL_FAILED;
    if (t0 >= t_bound && o->status == MBS_ODE_RUNNING) o->status = MBS_ODE_FINISHED;
    return 0;
}

/* Loops over the state that are elementwise (the methods' stage combinations, the error norm's weighted squares) are
 * vectorized: GCC's -O2 (12 and later) vectorizes only loops whose trip count it knows (its very-cheap cost model),
 * and these run over n, so the functions that hold them ask for the vectorizer with the dynamic model (runtime alias
 * checks, a scalar epilogue).  Each element is computed by the same operations in the same order either way (no
 * reduction is vectorized without -ffast-math, and -std=c99 contracts no a*b+c): the same bits in about half the
 * instructions.  -DMBS_MACHINERY_FORMER=1 builds them scalar (bench/event_instructions.py --machinery). */
#if defined(__GNUC__) && !defined(__clang__) && !defined(MBS_MACHINERY_FORMER)
#define MBS_ODE_ELEMENTWISE __attribute__((optimize("tree-vectorize", "vect-cost-model=dynamic")))
#else
#define MBS_ODE_ELEMENTWISE
#endif
/* The error norm's squares are summed in chunks of this many: each chunk's squares computed elementwise
 * (vectorized), then added in the order of the elements (the same sum to the bit). */
#define MBS_ODE_NORM_CHUNK 32

/* Weighted RMS norm of an error vector e with scale atol + rtol*max(|y0|, |y1|) (fmax's: a NaN one gives the other).
 * A non-finite norm becomes +inf so that comparisons reject the step instead of silently passing. */
MBS_ODE_ELEMENTWISE static double mbs_ode_error_norm(const mbs_ode *o, const double *e, const double *y0,
                                                     const double *y1)
{
    double sum = 0.0, squares[MBS_ODE_NORM_CHUNK];
    int i, j;
    for (i = 0; i < o->n; i += MBS_ODE_NORM_CHUNK) {
        const int m = o->n - i < MBS_ODE_NORM_CHUNK ? o->n - i : MBS_ODE_NORM_CHUNK;
        for (j = 0; j < m; j++) {
            const double a = fabs(y0[i + j]), b = fabs(y1[i + j]);
            const double r = e[i + j] / (o->atol[i + j] + o->rtol * (a >= b || b != b ? a : b));
            squares[j] = r * r;
        }
        for (j = 0; j < m; j++) sum += squares[j];
    }
    sum = o->n > 0 ? sqrt(sum / o->n) : 0.0;
    return sum <= DBL_MAX ? sum : HUGE_VAL;
}

/* Starting step of Hairer & Wanner (Solving ODEs I, II.4): balance the first two Taylor terms.
 * scratch must hold 2n doubles.  Returns a positive step even if the model fails on the trial point. */
static double mbs_ode_initial_step(mbs_ode *o, int order, double *scratch)
{
    int i, n = o->n;
    double dnf = 0.0, dny = 0.0, der2 = 0.0, h, h1, der12;
    double *y1 = scratch, *f1 = scratch + n;
    for (i = 0; i < n; i++) {
        double sk = o->atol[i] + o->rtol * fabs(o->y[i]);
        dnf += (o->f[i] / sk) * (o->f[i] / sk);
        dny += (o->y[i] / sk) * (o->y[i] / sk);
    }
    h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
    h = fmin(h, o->h_max);
    for (i = 0; i < n; i++) y1[i] = o->y[i] + h * o->f[i];
    if (mbs_ode_eval(o, o->t + h, y1, f1) != MBS_OK) return fmax(h * 1e-3, 1e-10);
    for (i = 0; i < n; i++) {
        double sk = o->atol[i] + o->rtol * fabs(o->y[i]);
        der2 += ((f1[i] - o->f[i]) / sk) * ((f1[i] - o->f[i]) / sk);
    }
    der2 = sqrt(der2) / h;
    der12 = fmax(fabs(der2), sqrt(dnf));
    h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 1.0 / order);
    h = fmin(fmin(100.0 * h, h1), o->h_max);
    return h > 0 && h <= DBL_MAX ? h : 1e-6;
}

/* Size of the next attempt, clipped to the end of the interval; sets *last when it lands on t_bound.
 * Returns 0, or sets the status and returns it when the step has collapsed or the budget is used. */
static int mbs_ode_next_h(mbs_ode *o, double *h, int *last)
{
    *h = fmin(o->h, o->h_max);
    *last = 0;
    if (o->t + 1.01 * *h >= o->t_bound) { *h = o->t_bound - o->t; *last = 1; }
    if (o->nsteps >= o->max_steps) {
        o->fail_h = *h;
        return o->status = MBS_ODE_TOO_MANY_STEPS;
    }
    if (*h < o->h_min || 0.1 * *h <= fabs(o->t) * DBL_EPSILON || !(*h > 0)) {
        o->fail_h = *h;
        return o->status = MBS_ODE_STEP_COLLAPSED;
    }
    o->nsteps++;
    return 0;
}

static void mbs_ode_learn_first_step(mbs_ode_restarts *r, double h);

/* Bookkeeping of an accepted step [t, t + h], whose result the method has stored in y: projected onto the
 * manifold when the problem has one.  The dense output keeps interpolating the integrated values. */
static void mbs_ode_accept(mbs_ode *o, double h, int last)
{
    o->t_old = o->t;
    o->t = last ? o->t_bound : o->t + h;
    o->naccept++;
    if (o->restarts && o->restarts->learning >= 0) mbs_ode_learn_first_step(o->restarts, last ? HUGE_VAL : h);
    if (o->project) {
        if (o->project(o->t, o->y, o->p, o->yproj, o->work) == MBS_OK)
            memcpy(o->y, o->yproj, (size_t)o->n * sizeof(double));
        else
            o->nproject_failed++;  /* the next evaluation meets the same failure and reports it */
    }
    if (last) o->status = MBS_ODE_FINISHED;
}

/* Watch the indicators of events(t, y): allocates the arrays once and evaluates g at the current point.
 * Returns 0, -1 without memory; a model failure sets the status. */
static int mbs_ode_set_events(mbs_ode *o, mbs_fn events, int nev, const int *directions)
{
    int k, s;
    o->events = events;
    o->nev = nev;
    o->directions = calloc((size_t)nev + 1, sizeof(int));
    o->g_old = calloc((size_t)nev + 1, sizeof(double));
    o->g_new = calloc((size_t)nev + 1, sizeof(double));
    o->g_try = calloc((size_t)nev + 1, sizeof(double));
    o->t_located = calloc((size_t)nev + 1, sizeof(double));
    o->y_try = calloc((size_t)o->n + 1, sizeof(double));
    o->trials = calloc(1, sizeof *o->trials);
    if (!o->directions || !o->g_old || !o->g_new || !o->g_try || !o->t_located || !o->y_try || !o->trials) return -1;
    o->trials->g = calloc((size_t)MBS_ODE_TRIALS * (size_t)nev + 1, sizeof(double));
    o->trials->g_event = calloc((size_t)nev + 1, sizeof(double));
    o->trials->search = calloc((size_t)nev + 1, sizeof(int));
    if (!o->trials->g || !o->trials->g_event || !o->trials->search) return -1;
    for (k = 0; k < nev; k++) o->directions[k] = directions[k];
    s = events(o->t, o->y, o->p, o->g_old, o->work);
    if (s != MBS_OK) { o->model_status = s; o->status = MBS_ODE_MODEL_FAILED; }
    return 0;
}

/* Whether indicator k left its old sign in an allowed direction (reaching zero counts; starting at zero not). */
static int mbs_ode_crossed(const mbs_ode *o, int k, double g_old, double g_new)
{
    int d = o->directions[k];
    return (d >= 0 && g_old < 0 && g_new >= 0) || (d <= 0 && g_old > 0 && g_new <= 0);
}

/* Keep the indicators g at trial point t for the other crossings' searches (while there is room). */
static void mbs_ode_keep_trial(mbs_ode *o, double t, const double *g)
{
    mbs_ode_trials *tr = o->trials;
    if (!MBS_ODE_SHARE_TRIALS || tr->count >= MBS_ODE_TRIALS) return;
    tr->t[tr->count] = t;
    memcpy(tr->g + (size_t)tr->count * (size_t)o->nev, g, (size_t)o->nev * sizeof(double));
    tr->count++;
}

/* The indicators kept at trial point t, or NULL. */
static const double *mbs_ode_kept_trial(const mbs_ode *o, double t)
{
    const mbs_ode_trials *tr = o->trials;
    int i;
    for (i = 0; i < tr->count; i++)
        if (tr->t[i] == t) return tr->g + (size_t)i * (size_t)o->nev;
    return NULL;
}

/* The root finding evaluates at its trial points only the indicators that crossed in the step (twin wheels: those
 * of both), each alone (o->indicator, the model's mbs_event_indicator: each indicator's own slice of mbs_events,
 * printed as mbs_events prints it, the same bits): on the Iltis over the bump at 10 m/s a damper's rate limit costs
 * about 150 instructions, a tyre's indicator about 550, where all 30 cost 2,900.  The indicators at the event itself
 * are then evaluated afresh, all of them, by the restart there.  -DMBS_ODE_SINGLE_FORMER=1 builds the former
 * search (every indicator at every trial point): the same-run baseline of bench/event_instructions.py --machinery
 * --former single. */
#ifdef MBS_ODE_SINGLE_FORMER
#define MBS_ODE_SINGLE 0
#else
#define MBS_ODE_SINGLE 1
#endif

/* The indicators the trial points of a search evaluate: those that crossed from g_a to g_b alone when the model
 * evaluates them one at a time, else all. */
static void mbs_ode_search(mbs_ode *o, const double *g_a, const double *g_b)
{
    mbs_ode_trials *tr = o->trials;
    int k;
    tr->nsearch = 0;
    if (!MBS_ODE_SINGLE || !o->indicator) return;
    for (k = 0; k < o->nev; k++)
        if (mbs_ode_crossed(o, k, g_a[k], g_b[k])) tr->search[tr->nsearch++] = k;
}

/* The indicators at (t, y) into g that the current search evaluates (mbs_ode_search); returns the status. */
static int mbs_ode_trial_indicators(mbs_ode *o, double t, const double *y, double *g)
{
    const mbs_ode_trials *tr = o->trials;
    int i, s;
    if (!tr->nsearch) return o->events(t, y, o->p, g, o->work);
    for (i = 0; i < tr->nsearch; i++)
        if ((s = o->indicator(tr->search[i], t, y, o->p, g, o->work)) != MBS_OK) return s;
    return MBS_OK;
}

/* The indicators kept at trial point t when the search evaluated all of them there, or NULL. */
static const double *mbs_ode_kept_all(const mbs_ode *o, double t)
{
    return o->trials->nsearch ? NULL : mbs_ode_kept_trial(o, t);
}

/* g_k on the dense output at t (the trial state is left in y_try, the search's indicators in g_try and kept among
 * the trials); a model failure returns NaN. */
static double mbs_ode_g_at(mbs_ode *o, int k, double t)
{
    o->dense(o, t, o->y_try);
    if (mbs_ode_trial_indicators(o, t, o->y_try, o->g_try) != MBS_OK) return NAN;
    mbs_ode_keep_trial(o, t, o->g_try);
    return o->g_try[k];
}

/* Narrow the bracket [*a, *b] of indicator k (values *ga, *gb) by the trial points kept inside it: its right end to
 * the earliest where g_k has left the sign of *ga, its left end to the latest before that where it has not. */
static void mbs_ode_narrow(const mbs_ode *o, int k, double *a, double *b, double *ga, double *gb)
{
    const mbs_ode_trials *tr = o->trials;
    int i, nev = o->nev;
    for (i = 0; i < tr->count; i++) {
        double t = tr->t[i], g = tr->g[(size_t)i * (size_t)nev + k];
        if (*a < t && t < *b && !(g * *ga > 0)) { *b = t; *gb = g; }
    }
    for (i = 0; i < tr->count; i++) {
        double t = tr->t[i], g = tr->g[(size_t)i * (size_t)nev + k];
        if (*a < t && t < *b && g * *ga > 0) { *a = t; *ga = g; }
    }
}

/* The first time in (a, b] at which g_k has left the sign of ga, to adjacent doubles: Illinois (a secant that
 * halves the value at an end kept twice) until the bracket is 1e-12 s wide; then the double nearest the secant's
 * root and its neighbour, probes four doubles either side of it, and bisection, until the bracket is two adjacent
 * doubles.  The algorithm of mbs.runtime.events.locate_crossing (which does without the first pair of probes: both
 * end on adjacent doubles across a sign change), started from the bracket the trial points of the step's other
 * crossings give (mbs_ode_trials).  A NaN counts as the new side (the bracket closes on it); a trial point where g_k
 * is exactly 0 is the crossing once g_k has ga's sign four doubles below it. */
static double mbs_ode_locate(mbs_ode *o, int k, double a, double b, double ga, double gb)
{
    int retained = 0, straddled = 0;
    /* ga may be the value an indicator at zero leaves with (1e-12 s on, runtime/event_loop.py): start there.  Not
     * when g_old holds the indicators evaluated at a (the step after one without an event): g_k has ga's sign there
     * already, and the probe would move a by 1e-12 s. */
    double probe = a + MBS_ODE_DEPARTURE_STEP * fmax(1.0, fabs(a));
    if (probe < b && !(MBS_ODE_SHARE_TRIALS && o->trials->g_old_exact)) {
        const double *kept = mbs_ode_kept_trial(o, probe);
        double gp = kept ? kept[k] : mbs_ode_g_at(o, k, probe);
        if (gp * ga > 0) { a = probe; ga = gp; }
    }
    mbs_ode_narrow(o, k, &a, &b, &ga, &gb);
    for (;;) {
        double width = b - a, c, gc;
        if (width <= 1e-12 * fmax(1.0, fabs(b)) && straddled == 0 && MBS_ODE_SHARE_TRIALS) {
            /* the indicator is linear to round-off here: the double nearest the secant's root, then its neighbour on
             * the other side of the crossing; adjacent doubles in two evaluations when the secant is right to the
             * last bit (six crossings in seven over the Iltis bump), else the probes below go on from there */
            double s = b - gb * width / (gb - ga);
            straddled = 1;
            s = fmin(fmax(s, a), b);
            if (a < s && s < b) {
                gc = mbs_ode_g_at(o, k, s);
                if (gc * ga > 0) { a = s; ga = gc; }
                else { b = s; gb = gc; }
            }
            c = s == a ? nextafter(s, HUGE_VAL) : nextafter(s, -HUGE_VAL);
            if (a < c && c < b) {
                gc = mbs_ode_g_at(o, k, c);
                if (gc * ga > 0) { a = c; ga = gc; }
                else { b = c; gb = gc; }
            }
            continue;
        }
        if (width <= 1e-12 * fmax(1.0, fabs(b)) && straddled < 2) {
            /* probe a few doubles either side of the secant's root (the bracket closes to ~8 doubles in two
             * evaluations instead of a dozen halvings) */
            double s = b - gb * width / (gb - ga), e, side[2];
            int j;
            straddled = 2;
            s = fmin(fmax(s, a), b);  /* a root at an end to round-off: the probe inside it closes the bracket */
            e = 4.0 * (nextafter(s, HUGE_VAL) - s);
            side[0] = s - e; side[1] = s + e;
            for (j = 0; j < 2; j++) {
                if (!(a < side[j] && side[j] < b)) continue;
                gc = mbs_ode_g_at(o, k, side[j]);
                if (gc * ga > 0) { a = side[j]; ga = gc; }
                else { b = side[j]; gb = gc; }
            }
            continue;
        }
        if (width <= 1e-12 * fmax(1.0, fabs(b))) c = a + 0.5 * width;
        else {
            /* the secant, kept half the goal width inside the bracket: a root at an end to round-off (the secant
             * rounding onto it) is then closed by the next point instead of bisected towards for 30 halvings */
            double margin = 0.5e-12 * fmax(1.0, fabs(b));
            c = b - gb * width / (gb - ga);
            if (!(a <= c && c <= b)) c = a + 0.5 * width;
            else c = fmin(fmax(c, a + margin), b - margin);
        }
        if (!(a < c && c < b)) return b;  /* adjacent doubles */
        gc = mbs_ode_g_at(o, k, c);
        if (gc * ga > 0) {
            a = c; ga = gc;
            if (retained == 1) gb *= 0.5;
            retained = 1;
        } else {
            b = c; gb = gc;
            if (gc == 0) {  /* on the crossing to the last bit (a linear indicator): close the bracket below it */
                double below = c - 4.0 * (nextafter(c, HUGE_VAL) - c), gp = a < below ? mbs_ode_g_at(o, k, below) : ga;
                if (gp * ga > 0) return c;
                b = below; gb = gp;
            }
            if (retained == -1) ga *= 0.5;
            retained = -1;
        }
    }
}

/* The indicators g at the event about to be stopped at, t (NULL: not known), for mbs_ode_restart. */
static void mbs_ode_keep_event(mbs_ode *o, double t, const double *g)
{
    mbs_ode_trials *tr = o->trials;
    tr->event_ready = MBS_ODE_SHARE_TRIALS && g != NULL;
    if (!tr->event_ready) return;
    tr->t_event = t;
    memcpy(tr->g_event, g, (size_t)o->nev * sizeof(double));
}

/* -DMBS_ODE_SCAN_FORMER=1 builds the former test for a crossing at a step's end (each indicator's bookkeeping for the
 * root finding set up, then tested in turn), the same-run baseline of bench/event_instructions.py --machinery
 * --former scan. */
#ifdef MBS_ODE_SCAN_FORMER
#define MBS_ODE_SCAN 0
#else
#define MBS_ODE_SCAN 1
#endif

/* Whether any indicator crossed from g_old to g_new (mbs_ode_crossed), tested for all at once: nine steps in ten end
 * without a crossing (the Iltis over the bump at 10 m/s), and the test is then all that mbs_ode_find_event does
 * besides evaluating the indicators.  Without a branch per indicator (the comparisons combined bitwise: none has an
 * effect, so none needs a short circuit), so that the compiler may vectorize it. */
MBS_ODE_ELEMENTWISE static int mbs_ode_any_crossed(const mbs_ode *o, const double *g_old, const double *g_new)
{
    int k, any = 0;
    long long changed = 0;
    /* first whether any indicator left its sign at all, a test of the doubles alone (64-bit masks throughout, no
     * int directions to widen: 150 instructions for the Iltis's 30 indicators against 275), then, when one did, the
     * directions */
    for (k = 0; k < o->nev; k++) {
        const double a = g_old[k], b = g_new[k];
        changed |= ((long long)(a < 0) & (b >= 0)) | ((long long)(a > 0) & (b <= 0));
    }
    if (!changed) return 0;
    for (k = 0; k < o->nev; k++) {
        const int d = o->directions[k];
        const double a = g_old[k], b = g_new[k];
        any |= ((d >= 0) & (a < 0) & (b >= 0)) | ((d <= 0) & (a > 0) & (b <= 0));
    }
    return any;
}

/* A step without a crossing: its end's indicators are the next step's start's. */
static void mbs_ode_no_event(mbs_ode *o)
{
    double *swap = o->g_old;
    o->g_old = o->g_new;
    o->g_new = swap;
    o->trials->g_old_exact = 1;
    if (o->restarts && o->restarts->h_resume > 0) {  /* the next crossing was not there */
        o->h = o->restarts->h_resume;
        o->restarts->h_resume = 0;
    }
}

/* After an accepted step: stop at the earliest located crossing (status MBS_ODE_EVENT, t and y at it; g_old
 * keeps the indicators of the step's start so the caller can tell which fired), else move g_new to g_old.
 * Crossings within MBS_ODE_TWIN_WINDOW of the earliest are one event, at the latest of them, where each has
 * crossed: the mirror-image wheels of a symmetric vehicle over one bump cross 1e-14 s apart, by the round-off of
 * their states.  Stopped at the first alone, the second would lie within the departure step of the restart: its
 * switch taken over by mbs_ode_settle without an event, and the short step to its crossing (1e-14 s) would meet
 * it again on the other side by the projection's round-off, again and again (chattering).  Later in a run the
 * round-off between the mirror images grows: on the Iltis over the bump at 10 m/s 94 pairs crossed 1.0-1.4e-12 s
 * apart, beyond the departure step (1e-12), each a restart and two rows of its own; the window of 1e-10 s takes
 * them as one (a switch applied 1e-10 s late, a state moved by its speed times that: far below any tolerance). */
static void mbs_ode_find_event(mbs_ode *o)
{
    int k, s, found = 0;
    double t_event = o->t, t_next = HUGE_VAL, t_first = HUGE_VAL, together, *located = o->t_located;
    mbs_ode_restarts *r = o->restarts;
    if (!o->nev || (o->status != MBS_ODE_RUNNING && o->status != MBS_ODE_FINISHED)) return;
    s = o->events(o->t, o->y, o->p, o->g_new, o->work);
    if (s != MBS_OK) { o->model_status = s; o->status = MBS_ODE_MODEL_FAILED; return; }
    o->trials->count = 0;
    if (MBS_ODE_SCAN && !mbs_ode_any_crossed(o, o->g_old, o->g_new)) {
        mbs_ode_no_event(o);
        return;
    }
    mbs_ode_search(o, o->g_old, o->g_new);
    mbs_ode_keep_trial(o, o->t, o->g_new);
    for (k = 0; k < o->nev; k++) {
        located[k] = NAN;
        if (mbs_ode_crossed(o, k, o->g_old[k], o->g_new[k])) {
            located[k] = mbs_ode_locate(o, k, o->t_old, o->t, o->g_old[k], o->g_new[k]);
            if (located[k] < t_first) t_first = located[k];
            found = 1;
        }
    }
    if (found) {  /* the event: the latest crossing within the departure step of the first; then the next after it */
        together = t_first + MBS_ODE_TWIN_WINDOW * fmax(1.0, fabs(t_first));
        t_event = t_first;
        for (k = 0; k < o->nev; k++)
            if (located[k] <= together && located[k] > t_event) t_event = located[k];
        for (k = 0; k < o->nev; k++)
            if (located[k] > t_event && located[k] < t_next) t_next = located[k];
    }
    if (!found) {
        mbs_ode_no_event(o);
        return;
    }
    if (r) { r->h_cut = o->t - o->t_old; r->t_next = t_next; }
    mbs_ode_keep_event(o, t_event, t_event == o->t ? o->g_new : mbs_ode_kept_all(o, t_event));
    o->dense(o, t_event, o->y);
    o->t = t_event;
    o->status = MBS_ODE_EVENT;
}

/* Handle events in C: ``handled[k]`` marks the indicators whose actions only assign parameters (the
 * ``nassign`` pairs index[j] <- actions output slot[j], grouped per event by first[]) or flip a switch's branch
 * flag (flag[k] >= 0); ``capacity`` log entries to start with (the log grows as needed until the caller
 * takes it).  Returns 0, or -1 without memory (the solver then returns every event, as without this call). */
static int mbs_ode_set_restarts(mbs_ode *o, double *p, mbs_fn actions, int nvalues, const int *handled,
                                const int *flag, const int *first, const int *index, const int *slot,
                                long capacity, double window)
{
    int k, nev = o->nev, nassign = first[nev];
    mbs_ode_restarts *r = calloc(1, sizeof *r);
    if (!r) return -1;
    r->p = p; r->actions = actions; r->nvalues = nvalues; r->window = window;
    r->t_next = HUGE_VAL;
    r->t_fence = -HUGE_VAL;
    r->capacity = capacity > 0 ? capacity : 1;
    r->width = 1 + 2 * (size_t)o->n + 2 * (size_t)nev + (size_t)nvalues;
    r->handled = calloc((size_t)nev + 1, sizeof(int));
    r->flag = calloc((size_t)nev + 1, sizeof(int));
    r->first = calloc((size_t)nev + 1, sizeof(int));
    r->index = calloc((size_t)nassign + 1, sizeof(int));
    r->slot = calloc((size_t)nassign + 1, sizeof(int));
    r->log = calloc((size_t)r->capacity * r->width, sizeof(double));
    r->f_bridge = calloc((size_t)o->n + 1, sizeof(double));
    r->first_step = calloc(2 * (size_t)nev + 1, sizeof(double));
    r->last_t = calloc((size_t)nev + 1, sizeof(double));
    r->learning = -1;
    if (!r->handled || !r->flag || !r->first || !r->index || !r->slot || !r->log || !r->f_bridge
        || !r->first_step || !r->last_t) {
        mbs_ode_free_restarts(r);
        return -1;
    }
    for (k = 0; k < nev; k++) { r->handled[k] = handled[k]; r->flag[k] = flag[k]; r->last_t[k] = -HUGE_VAL; }
    for (k = 0; k < 2 * nev; k++) r->first_step[k] = 1.0;
    for (k = 0; k <= nev; k++) r->first[k] = first[k];
    for (k = 0; k < nassign; k++) { r->index[k] = index[k]; r->slot[k] = slot[k]; }
    mbs_ode_free_restarts(o->restarts);
    o->restarts = r;
    return 0;
}

/* Room for one more log entry: the log doubles when full (between steps, once per so many events, never on the
 * hot path).  Returns 0, or -1 without memory (the event then goes back to the caller, which empties the log). */
static int mbs_ode_log_room(mbs_ode_restarts *r)
{
    double *grown;
    if (r->count < r->capacity) return 0;
    grown = realloc(r->log, (size_t)(2 * r->capacity) * r->width * sizeof(double));
    if (!grown) return -1;
    r->log = grown;
    r->capacity *= 2;
    return 0;
}

static int mbs_ode_sign(double g) { return (g > 0) - (g < 0); }

/* The indicators at a restart from (t, y), with f = fn(t, y) evaluated: an indicator at zero (within round-off)
 * is replaced by its value an Euler step of MBS_ODE_DEPARTURE_STEP later, the side it is leaving to (as
 * runtime/event_loop.departing). */
static void mbs_ode_depart(mbs_ode *o, double *g)
{
    double dt = MBS_ODE_DEPARTURE_STEP * fmax(1.0, fabs(o->t));
    int i, k;
    o->trials->g_old_exact = 0;
    if (o->events(o->t, o->y, o->p, g, o->work) != MBS_OK) return;
    for (i = 0; i < o->n; i++) o->y_try[i] = o->y[i] + dt * o->f[i];
    if (o->events(o->t + dt, o->y_try, o->p, o->g_try, o->work) != MBS_OK) return;
    for (k = 0; k < o->nev; k++)
        if (mbs_ode_sign(o->g_try[k]) != mbs_ode_sign(g[k]) && isfinite(o->g_try[k])) g[k] = o->g_try[k];
}

/* Each switch takes the side its indicator leaves to (runtime/event_loop.settle_switches); 1 when a branch
 * changed (f and the indicators must then be evaluated again). */
static int mbs_ode_settle(mbs_ode *o, const double *g)
{
    mbs_ode_restarts *r = o->restarts;
    int k, changed = 0;
    for (k = 0; k < o->nev; k++) {
        if (r->flag[k] >= 0 && g[k] != 0) {
            double side = g[k] > 0 ? 1.0 : 0.0;
            if (r->p[r->flag[k]] != side) { r->p[r->flag[k]] = side; changed = 1; }
        }
    }
    return changed;
}

/* Whether the event of indicator k is applied and restarted from here (mbs_ode_restart) rather than handed back. */
static int mbs_ode_handles(const mbs_ode *o, int k)
{
    const int handled = o->restarts->handled[k];
    return handled == 1 || (handled == MBS_ODE_HANDLED_PROJECT && MBS_ODE_PROJECT_IN_C && o->project);
}

/* The state at an event whose actions were applied projected onto the constraints with the new values (o->project,
 * the projection of every accepted step).  Returns its status; on a failure y is left as it was. */
static int mbs_ode_project_event(mbs_ode *o)
{
    int s = o->project(o->t, o->y, o->p, o->yproj, o->work);
    if (s != MBS_OK) {
        o->model_status = s;
        return s;
    }
    memcpy(o->y, o->yproj, (size_t)o->n * sizeof(double));
    return MBS_OK;
}

static int mbs_ode_restart(mbs_ode *o);
static void mbs_ode_restart_step(mbs_ode *o, const double *g_before, const double *g_event);
#ifdef MBS_ODE_TRACE
static void mbs_ode_trace_restart(const mbs_ode *o, const char *what, const double *g_before, const double *g_event);
#endif

/* The first step after a restart at a switch into stiffer dynamics (a leaf spring's stop engaging) must be smaller
 * than the step the controller proposed on the other side: there it was rejected once in three restarts, at six
 * evaluations of f each (the Iltis over the bump).  So the step starts at the fraction of the controller's step that
 * the first step after the last restart of the same indicator in the same direction took (the least over the
 * indicators that fired; 1 until one was rejected), and the accepted step updates that fraction: to its share of
 * the size tried when it was rejected on the way, else MBS_ODE_FIRST_STEP_RELAX times more, up to 1.  The error
 * control is the method's as ever: a fraction too small costs a step that the controller then grows. */
static void mbs_ode_first_step(mbs_ode *o, const double *g_before, const double *g_event)
{
    mbs_ode_restarts *r = o->restarts;
    double least = HUGE_VAL;
    int k;
    r->learning = -1;
    for (k = 0; k < o->nev; k++) {
        if (mbs_ode_crossed(o, k, g_before[k], g_event[k])) {
            int key = 2 * k + (g_event[k] > g_before[k]);
            if (r->first_step[key] < least) { least = r->first_step[key]; r->learning = key; }
        }
    }
    if (r->learning < 0) return;
    o->h *= least;
    r->h_tried = fmin(o->h, o->h_max);
}

/* An accepted step of size h (HUGE_VAL: the last, clipped to the end) after a restart: learn its fraction. */
static void mbs_ode_learn_first_step(mbs_ode_restarts *r, double h)
{
    double *fraction = r->first_step + r->learning;
    r->learning = -1;
    if (h == HUGE_VAL) return;
    if (h < 0.999 * r->h_tried) *fraction *= h / r->h_tried;
    else *fraction = fmin(1.0, *fraction * MBS_ODE_FIRST_STEP_RELAX);
}

/* The Euler step from a restart: y(t) = y + (t - t_restart) f, f evaluated afresh at the restart. */
static void mbs_ode_euler_dense(const mbs_ode *o, double t, double *out)
{
    int i;
    for (i = 0; i < o->n; i++) out[i] = o->y[i] + (t - o->t) * o->f[i];
}

/* Just after a restart at t1 (f and the departing indicators g_old evaluated there), another indicator crossed at
 * r->t_next, a moment later, on the dense output of the step that found the first (the left and the right wheel
 * over one bump, 1e-8 s apart).  An Euler step from t1 reaches it for one evaluation of f, where a step of the
 * method (a short one to just beyond it, or a full one running over its kink with the old branch, rejected) costs
 * one evaluation per stage: the crossing is located on the Euler step as on any dense output (to 1e-12 s or
 * adjacent doubles), the step's error estimate (half the step times the change of f, in the method's norm) is
 * checked, and the event there is applied and restarted from as the first was.  Returns 1 when it was (the run
 * continues, or stops there when its restart hands it back), 0 with nothing changed when the Euler step does not
 * qualify: no crossing on it, too large an error, a sample time or the end before it, or an indicator crossing
 * there that C does not handle (an indicator firing again within the chattering window: mbs_ode_restart). */
static int mbs_ode_bridge(mbs_ode *o)
{
    mbs_ode_restarts *r = o->restarts;
    void (*dense)(const mbs_ode *, double, double *) = o->dense;
    double t1 = o->t, b = t1 + 2.0 * (r->t_next - t1), t2 = HUGE_VAL, err;
    const double *kept;
    int i, k, ok = 0;
    if (!(b < r->t_fence && b <= o->t_bound && r->t_next > t1)) return 0;
    o->trials->count = 0;
    o->dense = mbs_ode_euler_dense;
    o->dense(o, b, o->y_try);
    if (o->events(b, o->y_try, o->p, o->g_new, o->work) != MBS_OK) goto done;
    mbs_ode_search(o, o->g_old, o->g_new);
    for (k = 0; k < o->nev; k++) {
        if (mbs_ode_crossed(o, k, o->g_old[k], o->g_new[k])) {
            double tk = mbs_ode_locate(o, k, t1, b, o->g_old[k], o->g_new[k]);
            if (tk < t2) t2 = tk;
        }
    }
    if (!(t2 < HUGE_VAL && t2 > t1)) goto done;
    o->dense(o, t2, o->y_try);
    kept = mbs_ode_kept_all(o, t2);  /* the located end of a bracket: evaluated there already */
    if (kept) memcpy(o->g_new, kept, (size_t)o->nev * sizeof(double));
    else if (o->events(t2, o->y_try, o->p, o->g_new, o->work) != MBS_OK) goto done;
    for (k = 0; k < o->nev; k++)
        if (mbs_ode_crossed(o, k, o->g_old[k], o->g_new[k]) && !mbs_ode_handles(o, k)) goto done;
    o->nfev++;
    if (o->fn(t2, o->y_try, o->p, r->f_bridge, o->work) != MBS_OK) goto done;
    for (i = 0; i < o->n; i++) r->f_bridge[i] = 0.5 * (t2 - t1) * (r->f_bridge[i] - o->f[i]);
    err = mbs_ode_error_norm(o, r->f_bridge, o->y, o->y_try);
    ok = err <= MBS_ODE_BRIDGE_ERROR;
done:
    o->dense = dense;
    if (!ok) return 0;
    memcpy(o->y, o->y_try, (size_t)o->n * sizeof(double));
    o->t = t2;
    o->status = MBS_ODE_EVENT;
    mbs_ode_keep_event(o, t2, o->g_new);
    r->t_next = HUGE_VAL;
    mbs_ode_restart(o);  /* 0: the event at t2 goes back to the caller from the state there */
    return 1;
}

/* At a located event (status MBS_ODE_EVENT, g_old the indicators at the step's start): when every indicator
 * that fired is handled here, log it, apply its actions (values computed before any is applied, Modelica's pre)
 * and restart the method from the same state: f and the indicators evaluated afresh, the step size kept (the
 * state did not jump).  Returns 1 when the run continues, 0 to hand the event to the caller (an event not
 * handled here, a full log, or chattering: an indicator firing again within the window). */
static int mbs_ode_restart(mbs_ode *o)
{
    mbs_ode_restarts *r = o->restarts;
    int k, j, n = o->n, nev = o->nev, fired = 0, pass, project = 0;
    double *entry, *g_event, *values;
    if (!r || mbs_ode_log_room(r)) return 0;
    entry = r->log + (size_t)r->count * r->width;
    g_event = entry + 1 + 2 * (size_t)n + nev;
    values = g_event + nev;
    if (o->trials->event_ready && o->trials->t_event == o->t)  /* found there by the root finder (same bits) */
        memcpy(g_event, o->trials->g_event, (size_t)nev * sizeof(double));
    else if (o->events(o->t, o->y, o->p, g_event, o->work) != MBS_OK) return 0;
    o->trials->event_ready = 0;
    for (k = 0; k < nev; k++) {
        if (mbs_ode_crossed(o, k, o->g_old[k], g_event[k])) {
            if (!mbs_ode_handles(o, k) || o->t - r->last_t[k] <= r->window * fmax(1.0, fabs(o->t))) {
#ifdef MBS_ODE_TRACE
                fprintf(stderr, "HANDBACK %.17g k %d handled %d\n", o->t, k, r->handled[k]);
#endif
                return 0;
            }
            fired++;
            project |= r->handled[k] == MBS_ODE_HANDLED_PROJECT;
        }
    }
    if (!fired || (r->nvalues && r->actions(o->t, o->y, o->p, values, o->work) != MBS_OK)) return 0;
    entry[0] = o->t;
    memcpy(entry + 1, o->y, (size_t)n * sizeof(double));
    memcpy(entry + 1 + 2 * (size_t)n, o->g_old, (size_t)nev * sizeof(double));
    for (k = 0; k < nev; k++) {
        if (!mbs_ode_crossed(o, k, o->g_old[k], g_event[k])) continue;
        r->last_t[k] = o->t;
        for (j = r->first[k]; j < r->first[k + 1]; j++) r->p[r->index[j]] = values[r->slot[j]];
        if (r->flag[k] >= 0) r->p[r->flag[k]] = g_event[k] > o->g_old[k] ? 1.0 : 0.0;
    }
    /* no projection after a switch that leaves the state on its constraints: the state did not jump, and the
     * dense output at the event is as near the constraints as any state inside a step (the next accepted step is
     * projected).  Projecting it would move the indicators that just fired by the integration error, back across
     * zero at times: the switch would then settle on its old side and fire again within 1e-11 s.  A prescribed
     * motion's switch steps the loops' speeds: projected with the new values, as the caller did after it. */
    if (project && mbs_ode_project_event(o) != MBS_OK) o->status = MBS_ODE_MODEL_FAILED;
    memcpy(entry + 1 + (size_t)n, o->y, (size_t)n * sizeof(double));
    r->count++;
    o->t_old = o->t;
    if (o->status == MBS_ODE_MODEL_FAILED) return 1;  /* logged, with the state as it was: the run stops there */
    for (pass = 0;; pass++) {
        if (mbs_ode_eval(o, o->t, o->y, o->f) != MBS_OK) {
            o->status = MBS_ODE_MODEL_FAILED;
            return 1;
        }
        mbs_ode_depart(o, o->g_old);
        if (pass == 1 || !mbs_ode_settle(o, o->g_old)) break;
    }
    o->status = o->t >= o->t_bound ? MBS_ODE_FINISHED : MBS_ODE_RUNNING;
#ifdef MBS_ODE_TRACE
    mbs_ode_trace_restart(o, "RESTART", entry + 1 + 2 * (size_t)n, g_event);
#endif
    mbs_ode_restart_step(o, entry + 1 + 2 * (size_t)n, g_event);
    return 1;
}

/* The step the method goes on with after a restart at an event where g_before (the step's start) -> g_event fired,
 * f and the departing indicators evaluated there and the status set: the one its controller proposed, but no larger
 * than the step just taken (that proposal was made across the switch, where the solution's derivatives jump); after
 * a short step to a second crossing, the step size from before it; times the learned fraction of the indicators
 * that fired (mbs_ode_first_step).  When another indicator crossed a moment later in the same step (the left and
 * the right wheel over one bump): a short step to just beyond it finds it there, instead of a full step that would
 * run over its kink with the old branch (rejected) and then be cut short by it (or the Euler bridge to it, within
 * sampling in C).  The restarts in C and the run taken over from a solver that handed its event back
 * (mbs_ode_take_over) both go on this way. */
static void mbs_ode_restart_step(mbs_ode *o, const double *g_before, const double *g_event)
{
    mbs_ode_restarts *r = o->restarts;
    double h_step = r->h_resume > 0 ? r->h_resume : r->h_cut;
    if (r->h_resume > 0) o->h = r->h_resume;
    else if (h_step > 0 && o->h > h_step) o->h = h_step;
    r->h_resume = 0;
    mbs_ode_first_step(o, g_before, g_event);
#ifdef MBS_ODE_TRACE
    fprintf(stderr, "STEPSIZE %.17g h %.17g h_cut %.17g t_next %.17g learning %d fev %ld\n", o->t, o->h, r->h_cut,
            r->t_next, r->learning, o->nfev);
#endif
    if (r->t_next < HUGE_VAL && 2.0 * (r->t_next - o->t) < o->h && r->t_next > o->t && o->status == MBS_ODE_RUNNING) {
        if (r->t_next - o->t <= MBS_ODE_BRIDGE_GAP * fmax(1.0, fabs(o->t)) && mbs_ode_bridge(o)) return;
        if (2.0 * (r->t_next - o->t) >= o->h_min) {
            r->learning = -1;  /* the short step tells nothing about the step the switch needs */
            r->h_resume = o->h;
            o->h = 2.0 * (r->t_next - o->t);
        }
    }
}

/* -DMBS_ODE_HANDBACK_FORMER=1 builds the former hand-back: a run handed back to the caller at an event goes on in a
 * new solver that has learned nothing (mbs_ode_take_over does nothing), the same-run baseline of
 * bench/restart_steps.py --handback. */
#ifdef MBS_ODE_HANDBACK_FORMER
#define MBS_ODE_CARRY 0
#else
#define MBS_ODE_CARRY 1
#endif

/* A run handed back to the caller at an event C does not handle without a jump of the state (a friction law's event,
 * after which the caller checks the held forces; with -DMBS_ODE_PRESCRIBED_FORMER=1 a prescribed motion's switch on a
 * model with loops, whose speeds the caller projects) goes on in a new solver `to`, set up from the state after the
 * event with its events and restarts, before its first step.  What `from`, the solver that handed the event back, learned goes over, as a restart in C
 * keeps it: the first-step fractions per indicator and direction, the times of the indicators' last events (the
 * chattering window; the indicators that fired at this event among them) and the step as mbs_ode_restart_step takes
 * it after a restart in C, from `from`'s controller and the step that found the event, instead of the caller's first
 * step.  g_before and g_event: the indicators at the start of the step that found the event and at it, as the caller
 * took them (twins that crossed with it included).  (After a jump of the state the caller starts afresh, as the FMU
 * does.)  Nothing changes with -DMBS_ODE_HANDBACK_FORMER=1 (the same-run baseline of bench/restart_steps.py) or
 * without restarts in either solver. */
static void mbs_ode_take_over(mbs_ode *to, const mbs_ode *from, const double *g_before, const double *g_event)
{
    mbs_ode_restarts *r = to->restarts;
    const mbs_ode_restarts *q = from->restarts;
    int k, nev = to->nev;
#ifdef MBS_ODE_TRACE
    mbs_ode_trace_restart(to, "RESUME", g_before, g_event);
#endif
    if (!MBS_ODE_CARRY || !r || !q || from->nev != nev || to->naccept > 0 || to->nsteps > 0) return;
    memcpy(r->first_step, q->first_step, 2 * (size_t)nev * sizeof(double));
    for (k = 0; k < nev; k++)
        r->last_t[k] = mbs_ode_crossed(to, k, g_before[k], g_event[k]) ? from->t : q->last_t[k];
    if (to->take_over && to->take_over == from->take_over) to->take_over(to, from);  /* the method's own memory */
    if (to->status != MBS_ODE_RUNNING) return;
    to->h = from->h;
    r->h_cut = q->h_cut;
    r->h_resume = q->h_resume;
    r->t_next = q->t_next;
    mbs_ode_restart_step(to, g_before, g_event);
}

#ifdef MBS_ODE_TRACE
/* The trace line of a restart (RESTART) or a take-over (RESUME): the time and the indicators that fired. */
static void mbs_ode_trace_restart(const mbs_ode *o, const char *what, const double *g_before, const double *g_event)
{
    int k;
    fprintf(stderr, "%s %.17g fired", what, o->t);
    for (k = 0; k < o->nev; k++)
        if (mbs_ode_crossed(o, k, g_before[k], g_event[k]))
            fprintf(stderr, " %d%c", k, g_event[k] > g_before[k] ? '+' : '-');
    fprintf(stderr, "\n");
}
#endif

/* Fill out[i*n .. i*n+n) with y(t_eval[i]) for i from *index on, stepping as needed.  Stops when all
 * samples are filled (returns the status, RUNNING or FINISHED) or the run fails (returns the failure;
 * *index is then the first unfilled sample).  No Python, no allocation. */
static int mbs_ode_sample(mbs_ode *o, const double *t_eval, long n_eval, long *index, double *out)
{
    long i = *index;
    int n = o->n;
    if (o->trials) o->trials->event_ready = 0;  /* the caller may have changed the parameters since */
    for (;;) {
        /* at an event only the samples before it: from its time on they belong to the state after it */
        while (i < n_eval && (t_eval[i] < o->t || (t_eval[i] == o->t && o->status != MBS_ODE_EVENT))) {
            double *row = out + (size_t)i * (size_t)n;
            if (t_eval[i] == o->t) memcpy(row, o->y, (size_t)n * sizeof(double));
            else if (o->naccept > 0 && t_eval[i] >= o->t_old && (i == 0 || t_eval[i] >= t_eval[i - 1]))
                o->dense(o, t_eval[i], row);
            else { *index = i; return o->status = MBS_ODE_BAD_SAMPLE; }
            i++;
        }
        *index = i;
        /* restart here only with every sample before the event filled (the old step's dense output goes) */
        if (o->status == MBS_ODE_EVENT && i < n_eval) {
            int restarted;
            if (o->restarts) o->restarts->t_fence = t_eval[i];
            restarted = mbs_ode_restart(o);
            if (o->restarts) o->restarts->t_fence = -HUGE_VAL;
            if (restarted) continue;
        }
        if (i >= n_eval || o->status == MBS_ODE_EVENT) return o->status;
        if (o->status == MBS_ODE_FINISHED) return o->status = MBS_ODE_BAD_SAMPLE;  /* beyond t_bound */
        if (o->status != MBS_ODE_RUNNING) return o->status;
        o->step(o);
        mbs_ode_find_event(o);
    }
}
