/* Baukasten run-time support shared by every compiled model (C99, no allocation on the hot path).
 *
 * A generated model defines functions of one fixed shape (see mbs_fn below).  The integrators in this
 * directory drive such a function through an mbs_ode: the problem (function, parameters, caller work
 * memory), the settings (tolerances, step limits), the state (t, y, last step) and the counters.  A
 * method fills in three hooks (step, dense, release); everything else -- sampling output times,
 * step-size bookkeeping, failure codes -- is shared in ode.c.
 *
 * All functions here are static: the build includes these files into one translation unit together
 * with the generated model, so nothing but the module init function is exported from the library.
 */
#ifndef MBS_RUNTIME_H
#define MBS_RUNTIME_H

#include <stddef.h>

/* The one signature of every generated model function: out = f(t, x, p); work is caller memory of
 * MBS_NWORK doubles.  Returns MBS_OK or a model status below. */
typedef int (*mbs_fn)(double t, const double *x, const double *p, double *out, double *work);
/* One event indicator alone: out[k] of the model's mbs_events (the rest of out as it was): mbs_event_indicator. */
typedef int (*mbs_indicator_fn)(int k, double t, const double *x, const double *p, double *out, double *work);

/* Model status codes (returned by generated functions). */
#define MBS_OK 0
#define MBS_SINGULAR_MASS 1
#define MBS_NONFINITE 2

/* Integrator outcome codes (never returned by a model; > 100 so the two cannot be confused). */
#define MBS_ODE_RUNNING 0
#define MBS_ODE_FINISHED 101        /* t reached t_bound */
#define MBS_ODE_STEP_COLLAPSED 102  /* step size fell below h_min or below round-off of t */
#define MBS_ODE_TOO_MANY_STEPS 103  /* max_steps accepted + rejected steps used up */
#define MBS_ODE_MODEL_FAILED 104    /* the model failed at the initial point (no step can help) */
#define MBS_ODE_SINGULAR 105        /* iteration matrix singular at every step size tried */
#define MBS_ODE_BAD_SAMPLE 106      /* output times not increasing or before the current step */
#define MBS_ODE_STIFF 107           /* stiffness detected and stop_on_stiff set (the auto integrator switches) */
#define MBS_ODE_EVENT 108           /* an event was located: t, y are the state at it; restart from there */

typedef struct mbs_ode mbs_ode;

struct mbs_ode {
    /* problem */
    int n;                  /* state size */
    mbs_fn fn;              /* ydot = fn(t, y) */
    const double *p;        /* parameters, borrowed */
    double *work;           /* model work memory, borrowed */
    /* settings */
    double rtol;            /* relative tolerance */
    double *atol;           /* absolute tolerance per component [n], owned */
    double t_bound;         /* integrate forward up to here, never beyond */
    double h_max, h_min;    /* step limits [s] */
    long max_steps;         /* limit on attempted steps (accepted + rejected) */
    /* state */
    double t, t_old;        /* current time and start of the last accepted step */
    double h;               /* size of the next step to try */
    double *y;              /* state at t [n], owned */
    double *f;              /* fn(t, y) [n], owned (valid after the first step or init) */
    int status;             /* MBS_ODE_* */
    int model_status;       /* last non-zero model status seen (0 if none) */
    double fail_h;          /* step size when the run failed */
    /* counters */
    long nfev, njev, nlu, nsteps, naccept, nreject;
    /* manifold: if set, every accepted y is replaced by project(t, y) (closed loops: the state stays on the
     * constraints instead of drifting by the integration error; the derivative f at y is unchanged, since the
     * loop right-hand side is evaluated at the projected state) */
    mbs_fn project;         /* NULL: no projection */
    double *yproj;          /* [n], owned: the projection's output */
    long nproject_failed;   /* accepted steps whose projection failed (y then kept as integrated) */
    /* Jacobian: if set, jac(t, y) writes [d f/d y | d f/d t] (n rows of n + 1 columns, row-major; the generated
     * mbs_jacobian); the implicit methods use it instead of finite differences of fn */
    mbs_fn jac;             /* NULL: finite differences */
    /* stiffness (explicit methods, Hairer's test): the first time the step was held by stability for many
     * steps in a row; stop_on_stiff ends the run there with MBS_ODE_STIFF */
    int stop_on_stiff;
    int stiff;              /* 1 once detected */
    double stiff_t, stiff_h, stiff_hlamb;  /* when, the step then, h |lambda| estimated at that step */
    /* events (optional, nev = 0 without): indicators g = events(t, y) checked after every accepted step; the
     * earliest crossing is located on the dense output and the run stops there with MBS_ODE_EVENT */
    mbs_fn events;          /* the model's mbs_events, or NULL */
    mbs_indicator_fn indicator;  /* its indicators one at a time (mbs_event_indicator), or NULL: the root finding
                                  * then evaluates all of them at its trial points */
    int nev;                /* number of indicators */
    int *directions;        /* [nev], owned: +1 rising, -1 falling, 0 either */
    double *g_old, *g_new, *g_try;  /* [nev] each, owned: at the step's start, end, and a trial time */
    double *t_located;              /* [nev], owned: each indicator's crossing in the step (NaN: none) */
    double *y_try;          /* [n], owned: the dense output at a trial time */
    struct mbs_ode_trials *trials;  /* owned: the indicators at the root finder's trial points (ode.c) */
    /* events whose actions are generated C (switch flags, `set` of modes and parameters) applied and the
     * integrator restarted inside mbs_ode_sample, logged for the caller; NULL: every event returns (ode.c) */
    struct mbs_ode_restarts *restarts;
    /* method hooks */
    int (*step)(mbs_ode *);                               /* one accepted step; returns status */
    void (*dense)(const mbs_ode *, double t, double *out);  /* interpolate within the last step */
    void (*release)(mbs_ode *);                           /* free method memory */
    void (*take_over)(mbs_ode *, const mbs_ode *from);    /* copy the method memory a restart keeps from another
                                                           * solver of the same method (ode.c mbs_ode_take_over);
                                                           * NULL: none */
    void (*fill_cont)(mbs_ode *);                         /* write the last step's coefficients into cont, for a
                                                           * reader outside the method (NULL: cont holds them) */
    size_t ncont;           /* doubles of dense-output coefficients (a multiple of n) */
    double *cont;           /* dense-output coefficients of the last step, owned (see fill_cont) */
    void *impl;             /* method memory, owned */
};

#endif
