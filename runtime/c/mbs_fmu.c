/* FMI 2.0 Model Exchange and Co-Simulation around a generated model (mbs fmu).
 *
 * mbs/exchange/fmu.py compiles this file in a directory that holds "model.c" (the generated equations, as the
 * run time compiles them) and "fmu_defaults.h" (GUID, start values, tolerances).  The interface is the one the
 * run time uses: mbs_rhs, mbs_outputs (MBS_NY), mbs_project (closed loops, MBS_NC).  Co-simulation steps with
 * the run time's DOPRI5 (ode.c, dopri5.c) and projects every accepted step onto the loop constraints, as
 * `mbs simulate` does; communication points are read from its dense output, so the integrator keeps its step
 * size across them.
 *
 * Value references: states x [0, NX), their derivatives [NX, 2 NX), parameters [2 NX, 2 NX + NP), outputs
 * after them.  Parameters are tunable: the model reads p at every evaluation.
 *
 * Events (MBS_FMU_FROZEN defined: the model has indicators, mbs_events): the comparisons and kinks of the model
 * are switches whose branch flags (slots of p, not listed in modelDescription.xml) hold while the importer
 * integrates, as in `mbs simulate`.  Model Exchange reports the indicators (fmi2GetEventIndicators); in event
 * mode the actions of the events that crossed are applied (fmu_apply_events: `set`, `reinit`, `terminate`) and
 * every switch takes the side its indicator is on (or, at zero, leaves to).  Co-Simulation locates the crossings
 * on DOPRI5's dense output: an event that assigns run-time values only is restarted from in the sampling loop
 * (ode.c, mbs_ode_restart), as the C sampling loop of a run does; a `reinit` or `terminate` comes back to
 * fmu_sample, which applies it with the same fmu_apply_events.  mbs/fmu.py refuses a switched friction element
 * (the run checks its held forces in Python after every event).
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.c"
#include "mbs_runtime.h"
#include "ode.c"
#include "dopri5.c"
#ifdef MBS_NC
#include "loops.c"
#endif
#include "fmi2_api.h"
#include "fmu_defaults.h"

#ifdef MBS_NY
#define MBS_FMU_NY MBS_NY
#else
#define MBS_FMU_NY 0
#endif
#define VR_DER (MBS_NX)
#define VR_PAR (2 * MBS_NX)
#define VR_OUT (2 * MBS_NX + MBS_NP)
#define VR_END (VR_OUT + MBS_FMU_NY)
#ifdef MBS_FMU_FROZEN
#define MBS_FMU_NEV MBS_NEV
#else
#define MBS_FMU_NEV 0
#endif
#ifdef MBS_NACT
#define MBS_FMU_NACT MBS_NACT
#define MBS_FMU_ACTIONS mbs_event_actions
#else
#define MBS_FMU_NACT 0
#define MBS_FMU_ACTIONS NULL
#endif
/* Chattering in co-simulation: this many events within ZENO_WINDOW s end the step with an error. */
#define MBS_FMU_ZENO_EVENTS 10
#define MBS_FMU_ZENO_WINDOW 1e-9
/* The look ahead that gives an indicator's rate [s, relative to max(1, |t|)] (runtime/events.RATE_STEP). */
#define MBS_FMU_RATE_STEP 1e-8

typedef struct {
    fmi2Type type;
    char name[128];
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    int logging;
    double t, rtol, t_stop;
    double x[MBS_NX + 1], xdot[MBS_NX + 1], p[MBS_NP + 1], y[MBS_FMU_NY + 1];
    double work[MBS_NWORK + 1];
    int xdot_valid, y_valid;
    mbs_ode ode;        /* co-simulation integrator; ode.n == 0: not started */
    int ode_stale;      /* a state, parameter or time was set since the integrator started */
    /* events: indicators at the last completed step or event (Model Exchange), a trial state, action values */
    double g_prev[MBS_FMU_NEV + 1], g[MBS_FMU_NEV + 1], g_try[MBS_FMU_NEV + 1], x_try[MBS_NX + 1];
    double values[MBS_FMU_NACT + 1];
    double event_t[MBS_FMU_ZENO_EVENTS];  /* the times of the last events (a ring, fmu_zeno) */
    long nevents;                          /* events applied since the start */
    int terminated;                        /* an event ended the run (fmi2Terminated) */
} mbs_fmu;

/* A saved state: time, states, run-time values (modes, branches) and the event bookkeeping (the indicators at the
 * last step, the chattering ring, whether the run ended), so that a restored instance goes on as the saved one. */
typedef struct {
    double t, x[MBS_NX + 1], p[MBS_NP + 1], g_prev[MBS_FMU_NEV + 1], event_t[MBS_FMU_ZENO_EVENTS];
    long nevents;
    int terminated;
} mbs_fmu_state;

static void fmu_log(mbs_fmu *m, fmi2Status status, const char *category, const char *format, ...)
{
    char text[512];
    va_list args;
    if (!m->logger || (status == fmi2OK && !m->logging)) return;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    m->logger(m->env, m->name, status, category, "%s", text);
}

static void fmu_changed(mbs_fmu *m)
{
    m->xdot_valid = m->y_valid = 0;
    m->ode_stale = 1;
}

static fmi2Status fmu_derivatives(mbs_fmu *m)
{
    int s;
    if (m->xdot_valid) return fmi2OK;
    s = mbs_rhs(m->t, m->x, m->p, m->xdot, m->work);
    if (s != MBS_OK) {
        fmu_log(m, fmi2Error, "logStatusError", "the model failed at t = %g s: %s", m->t,
                s == MBS_SINGULAR_MASS ? "singular mass matrix" : s == MBS_NONFINITE ? "non-finite value"
                                                                                     : "loops cannot be closed");
        return fmi2Error;
    }
    m->xdot_valid = 1;
    return fmi2OK;
}

static fmi2Status fmu_outputs(mbs_fmu *m)
{
#ifdef MBS_NY
    if (!m->y_valid) {
        if (mbs_outputs(m->t, m->x, m->p, m->y, m->work) != MBS_OK) {
            fmu_log(m, fmi2Error, "logStatusError", "output evaluation failed at t = %g s", m->t);
            return fmi2Error;
        }
        m->y_valid = 1;
    }
#endif
    (void)m;
    return fmi2OK;
}

/* ---- events ------------------------------------------------------------------------------------------------- */
#ifdef MBS_FMU_FROZEN
static int fmu_sign(double g) { return (g > 0) - (g < 0); }

/* The indicators an Euler step of dt after (t, x), into g_try (the branches held). */
static int fmu_ahead(mbs_fmu *m, double dt)
{
    int i;
    m->xdot_valid = 0;
    if (fmu_derivatives(m) != fmi2OK) return -1;
    for (i = 0; i < MBS_NX; i++) m->x_try[i] = m->x[i] + dt * m->xdot[i];
    return mbs_events(m->t + dt, m->x_try, m->p, m->g_try, m->work) == MBS_OK ? 0 : -1;
}

/* The indicators at (t, x) with the branches held, an indicator at zero replaced by its value an Euler step of
 * 1e-12 s later: the side it leaves to (ode.c, mbs_ode_depart; runtime/event_loop.departing). */
static int fmu_departing(mbs_fmu *m, double *g)
{
    int k;
    if (mbs_events(m->t, m->x, m->p, g, m->work) != MBS_OK || fmu_ahead(m, 1e-12 * fmax(1.0, fabs(m->t))) != 0)
        return -1;
    for (k = 0; k < MBS_NEV; k++)
        if (fmu_sign(m->g_try[k]) != fmu_sign(g[k]) && isfinite(m->g_try[k])) g[k] = m->g_try[k];
    return 0;
}

/* Every switch takes the side its indicator is on at (t, x), or leaves to at zero (twice: a branch that changes
 * may move another indicator); g_prev is left at the indicators after.  At the start (the frozen flag 0) the
 * comparisons are first evaluated as written. */
static fmi2Status fmu_settle_switches(mbs_fmu *m)
{
    int k, pass, changed;
#if MBS_FMU_FROZEN >= 0
    if (m->p[MBS_FMU_FROZEN] == 0.0) {
        if (mbs_events(m->t, m->x, m->p, m->g, m->work) != MBS_OK) return fmi2Error;
        for (k = 0; k < MBS_NEV; k++)
            if (MBS_FMU_FLAG[k] >= 0)
                m->p[MBS_FMU_FLAG[k]] = (m->g[k] > 0 || (MBS_FMU_INCLUSIVE[k] && m->g[k] == 0)) ? 1.0 : 0.0;
        m->p[MBS_FMU_FROZEN] = 1.0;
    }
#endif
    for (pass = 0; pass < 2; pass++) {
        if (fmu_departing(m, m->g_prev) != 0) {
            fmu_log(m, fmi2Error, "logStatusError", "the event indicators failed at t = %g s", m->t);
            return fmi2Error;
        }
        for (k = changed = 0; k < MBS_NEV; k++) {
            double side = m->g_prev[k] > 0 ? 1.0 : 0.0;
            if (MBS_FMU_FLAG[k] >= 0 && m->g_prev[k] != 0 && m->p[MBS_FMU_FLAG[k]] != side) {
                m->p[MBS_FMU_FLAG[k]] = side;
                changed = 1;
            }
        }
        if (!changed) break;
    }
    m->xdot_valid = m->y_valid = 0;
    return fmi2OK;
}

/* Whether indicator k crossed from g_old to g_new in its direction (ode.c, mbs_ode_crossed). */
static int fmu_crossed(int k, double g_old, double g_new)
{
    int d = MBS_FMU_DIRECTIONS[k];
    return (d >= 0 && g_old < 0 && g_new >= 0) || (d <= 0 && g_old > 0 && g_new <= 0);
}

/* The times of the last events are a ring in m (one entry per event that fired, as runtime/event_loop counts
 * them); chattering (runtime/events.is_zeno): the last ZENO_EVENTS of them lie within ZENO_WINDOW s. */
static void fmu_note_event(mbs_fmu *m, double t)
{
    m->event_t[m->nevents % MBS_FMU_ZENO_EVENTS] = t;
    m->nevents++;
}

static int fmu_zeno(const mbs_fmu *m)
{
    double last, oldest;
    if (m->nevents < MBS_FMU_ZENO_EVENTS) return 0;
    last = m->event_t[(m->nevents - 1) % MBS_FMU_ZENO_EVENTS];
    oldest = m->event_t[m->nevents % MBS_FMU_ZENO_EVENTS];
    return last - oldest <= MBS_FMU_ZENO_WINDOW * fmax(1.0, fabs(last));
}

static void fmu_log_zeno(mbs_fmu *m)
{
    fmu_log(m, fmi2Warning, "logStatusWarning", "chattering (Zeno behaviour) at t = %.12g s: %d events within "
            "%.3g s; the run ends here with its results", m->t, MBS_FMU_ZENO_EVENTS,
            m->event_t[(m->nevents - 1) % MBS_FMU_ZENO_EVENTS] - m->event_t[m->nevents % MBS_FMU_ZENO_EVENTS]);
}

/* A fired event with a reinit whose indicator, at the located crossing, moves back to the side it came from: a
 * crossing in the integrator's noise, not of the motion (runtime/events.against_motion: a ball near its
 * accumulation point, where its flights are shorter than the integrator resolves; the reinit would send it into
 * the ground).  Returns 1 (the run ends here, nothing applied, said in the log), 0, or -1 when the model failed.
 * m->g holds the indicators at the crossing. */
static int fmu_against_motion(mbs_fmu *m, const double *g_before)
{
    int k, j, jumps = 0;
    for (k = 0; k < MBS_NEV; k++)
        if (fmu_crossed(k, g_before[k], m->g[k]))
            for (j = MBS_FMU_FIRST[k]; j < MBS_FMU_FIRST[k + 1]; j++) jumps |= MBS_FMU_TARGET[j];
    if (!jumps) return 0;
    if (fmu_ahead(m, MBS_FMU_RATE_STEP * fmax(1.0, fabs(m->t))) != 0) return -1;
    for (k = 0; k < MBS_NEV; k++) {
        if (!fmu_crossed(k, g_before[k], m->g[k])) continue;
        for (j = MBS_FMU_FIRST[k]; j < MBS_FMU_FIRST[k + 1]; j++) {
            if (MBS_FMU_TARGET[j] && (m->g_try[k] - m->g[k]) * (0.0 - g_before[k]) < 0) {
                fmu_log(m, fmi2Warning, "logStatusWarning", "chattering (Zeno behaviour) at t = %.12g s: event '%s' "
                        "(%ld events so far) now crosses against the motion: the motion has come to rest at its "
                        "threshold below the integrator's resolution; the run ends here with its results", m->t,
                        MBS_FMU_EVENT_NAMES[k], m->nevents);
                return 1;
            }
        }
    }
    return 0;
}

/* What fmu_apply_events did (a mask). */
#define FMU_FIRED 1        /* an event crossed */
#define FMU_JUMPED 2       /* the state x jumped (a reinit): the importer reads the states again */
#define FMU_TERMINAL 4     /* an event ends the run */
#define FMU_ZENO 8         /* chattering: the run ends here (after the event) */

/* The events whose indicators crossed from g_before to the indicators at (t, x), applied as the run applies them
 * (runtime/events.apply_events): every action value from the state before the event (mbs_event_actions,
 * Modelica's pre), then `set` into p and `reinit` into x, a switch's branch to the side it crossed to; with
 * closed loops the state after an event the C sampling loop cannot restart from (a jump, the end of the run) is
 * projected onto the constraints, positions and speeds (mbs_project, as runtime/event_loop.run_with_events), so
 * the new speeds stay consistent with them.  Chattering (ZENO_EVENTS events within ZENO_WINDOW s) ends the run
 * after the event, as in a run.  importer (Model Exchange): an indicator exactly at zero counts on the side it
 * leaves to, as at a restart (fmu_departing): the importer stops at the roots of the values it reads, and a ball
 * restarted 1e-14 m below the floor, whose departing indicator is above it, reaches zero rising, not falling.
 * Co-Simulation locates the crossings as ode.c does (reaching zero counts).  One function for Model Exchange
 * (event mode) and Co-Simulation (fmi2DoStep).  Returns the FMU_* mask, or -1 when the model failed. */
static int fmu_apply_events(mbs_fmu *m, const double *g_before, int importer)
{
    int k, j, mask = 0, outside = 0;
    if (mbs_events(m->t, m->x, m->p, m->g, m->work) != MBS_OK) return -1;
    for (k = 0; importer && k < MBS_NEV && m->g[k] != 0; k++) {}
    if (importer && k < MBS_NEV) {  /* an indicator at zero: the side it leaves to */
        if (fmu_ahead(m, 1e-12 * fmax(1.0, fabs(m->t))) != 0) return -1;
        for (k = 0; k < MBS_NEV; k++)
            if (m->g[k] == 0 && isfinite(m->g_try[k])) m->g[k] = m->g_try[k];
    }
    for (k = 0; k < MBS_NEV; k++) {
        if (!fmu_crossed(k, g_before[k], m->g[k])) continue;
        mask |= FMU_FIRED;
        outside |= !MBS_FMU_HANDLED[k];
        if (MBS_FMU_TERMINAL[k]) mask |= FMU_TERMINAL;
    }
    if (!mask) return 0;
    if ((k = fmu_against_motion(m, g_before)) != 0) return k < 0 ? -1 : FMU_ZENO;
#ifdef MBS_NACT
    if (mbs_event_actions(m->t, m->x, m->p, m->values, m->work) != MBS_OK) return -1;
#endif
    for (k = 0; k < MBS_NEV; k++) {
        if (!fmu_crossed(k, g_before[k], m->g[k])) continue;
        for (j = MBS_FMU_FIRST[k]; j < MBS_FMU_FIRST[k + 1]; j++) {
            if (MBS_FMU_TARGET[j]) { m->x[MBS_FMU_INDEX[j]] = m->values[MBS_FMU_SLOT[j]]; mask |= FMU_JUMPED; }
            else m->p[MBS_FMU_INDEX[j]] = m->values[MBS_FMU_SLOT[j]];
        }
        if (MBS_FMU_FLAG[k] >= 0) m->p[MBS_FMU_FLAG[k]] = m->g[k] > g_before[k] ? 1.0 : 0.0;
        fmu_note_event(m, m->t);
        fmu_log(m, fmi2OK, "logEvents", "event '%s' at t = %.12g s%s", MBS_FMU_EVENT_NAMES[k], m->t,
                MBS_FMU_TERMINAL[k] ? ": the run ends here" : "");
    }
#ifdef MBS_NC
    if (outside) {
        double xc[MBS_NX + 1];
        if (mbs_project(m->t, m->x, m->p, xc, m->work) != MBS_OK) return -1;
        for (k = 0; k < MBS_NX; k++) {
            if (xc[k] != m->x[k]) mask |= FMU_JUMPED;
            m->x[k] = xc[k];
        }
    }
#else
    (void)outside;
#endif
    if (!(mask & FMU_TERMINAL) && fmu_zeno(m)) {
        fmu_log_zeno(m);
        mask |= FMU_ZENO;
    }
    fmu_changed(m);
    return mask;
}

/* Event mode of Model Exchange: the events that crossed since the last completed step applied (fmu_apply_events),
 * then every switch settles; info says whether the states jumped and whether the run ends. */
static fmi2Status fmu_event_update(mbs_fmu *m, fmi2EventInfo *info)
{
    int mask = fmu_apply_events(m, m->g_prev, 1);
    if (mask < 0) {
        fmu_log(m, fmi2Error, "logStatusError", "the event actions failed at t = %g s", m->t);
        return fmi2Error;
    }
    info->valuesOfContinuousStatesChanged = mask & FMU_JUMPED ? fmi2True : fmi2False;
    if (mask & (FMU_TERMINAL | FMU_ZENO)) {
        info->terminateSimulation = fmi2True;
        m->terminated = 1;
    }
    return fmu_settle_switches(m);
}
#endif

/* ---- common functions -------------------------------------------------------------------------------------- */
FMI2_EXPORT const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_EXPORT const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[])
{
    (void)n; (void)cats;
    ((mbs_fmu *)c)->logging = on;
    return fmi2OK;
}

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                                          const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                                          fmi2Boolean logging)
{
    mbs_fmu *m;
    (void)location; (void)visible;
    if (!guid || strcmp(guid, MBS_FMU_GUID) != 0) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              "GUID %s does not match this binary's %s", guid ? guid : "(none)", MBS_FMU_GUID);
        return NULL;
    }
    m = calloc(1, sizeof *m);
    if (!m) return NULL;
    m->type = type;
    snprintf(m->name, sizeof m->name, "%s", name ? name : "mbs");
    m->logger = functions ? functions->logger : NULL;
    m->env = functions ? functions->componentEnvironment : NULL;
    m->logging = logging;
    memcpy(m->x, MBS_FMU_X0, sizeof(double) * MBS_NX);
    memcpy(m->p, MBS_FMU_P0, sizeof(double) * MBS_NP);
    m->rtol = MBS_FMU_RTOL;
    m->t_stop = DBL_MAX;
    fmu_changed(m);
    return m;
}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component c)
{
    mbs_fmu *m = c;
    if (!m) return;
    if (m->ode.n) mbs_ode_free(&m->ode);
    free(m);
}

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean has_tol, fmi2Real tol, fmi2Real t0,
                                           fmi2Boolean has_stop, fmi2Real t_stop)
{
    mbs_fmu *m = c;
    if (has_tol && tol > 0) m->rtol = tol < MBS_FMU_RTOL ? tol : MBS_FMU_RTOL;
    m->t = t0;
    m->t_stop = has_stop ? t_stop : DBL_MAX;
    fmu_changed(m);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }

/* Closed loops: a parameter set before initialisation may have moved the loops; close them again. */
/* Switches: each branch from its comparison at the start. */
FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    mbs_fmu *m = c;
#ifdef MBS_NC
    double xc[MBS_NX + 1];
    if (mbs_project(m->t, m->x, m->p, xc, m->work) != MBS_OK) {
        fmu_log(m, fmi2Error, "logStatusError", "the closed loops cannot be closed at the start");
        return fmi2Error;
    }
    memcpy(m->x, xc, sizeof(double) * MBS_NX);
    fmu_changed(m);
#endif
#ifdef MBS_FMU_FROZEN
#if MBS_FMU_FROZEN >= 0
    m->p[MBS_FMU_FROZEN] = 0.0;
#endif
    return fmu_settle_switches(m);
#else
    (void)m;
    return fmi2OK;
#endif
}

FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c)
{
    mbs_fmu *m = c;
    if (m->ode.n) mbs_ode_free(&m->ode);
    memcpy(m->x, MBS_FMU_X0, sizeof(double) * MBS_NX);
    memcpy(m->p, MBS_FMU_P0, sizeof(double) * MBS_NP);
    m->t = 0.0;
    m->rtol = MBS_FMU_RTOL;
    m->nevents = 0;
    m->terminated = 0;
    fmu_changed(m);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[])
{
    mbs_fmu *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        unsigned r = vr[i];
        if (r < VR_DER) value[i] = m->x[r];
        else if (r < VR_PAR) {
            if (fmu_derivatives(m) != fmi2OK) return fmi2Error;
            value[i] = m->xdot[r - VR_DER];
        } else if (r < VR_OUT) value[i] = m->p[r - VR_PAR];
        else if (r < VR_END) {
            if (fmu_outputs(m) != fmi2OK) return fmi2Error;
            value[i] = m->y[r - VR_OUT];
        } else {
            fmu_log(m, fmi2Error, "logStatusError", "no real variable with value reference %u", r);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                   const fmi2Real value[])
{
    mbs_fmu *m = c;
    size_t i;
    for (i = 0; i < n; i++) {
        unsigned r = vr[i];
        if (r < VR_DER) m->x[r] = value[i];
        else if (r >= VR_PAR && r < VR_OUT) m->p[r - VR_PAR] = value[i];
        else {
            fmu_log(m, fmi2Error, "logStatusError", "value reference %u cannot be set", r);
            return fmi2Error;
        }
    }
    fmu_changed(m);
    return fmi2OK;
}

#define MBS_NO_VARIABLES(kind, type)                                                                              \
    FMI2_EXPORT fmi2Status fmi2Get##kind(fmi2Component c, const fmi2ValueReference vr[], size_t n, type v[])     \
    { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }                                               \
    FMI2_EXPORT fmi2Status fmi2Set##kind(fmi2Component c, const fmi2ValueReference vr[], size_t n, const type v[]) \
    { (void)c; (void)vr; (void)v; return n ? fmi2Error : fmi2OK; }
MBS_NO_VARIABLES(Integer, fmi2Integer)
MBS_NO_VARIABLES(Boolean, fmi2Boolean)
MBS_NO_VARIABLES(String, fmi2String)

FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    mbs_fmu *m = c;
    mbs_fmu_state *s = *state ? *state : calloc(1, sizeof *s);
    if (!s) return fmi2Error;
    s->t = m->t;
    memcpy(s->x, m->x, sizeof s->x);
    memcpy(s->p, m->p, sizeof s->p);
    memcpy(s->g_prev, m->g_prev, sizeof s->g_prev);
    memcpy(s->event_t, m->event_t, sizeof s->event_t);
    s->nevents = m->nevents;
    s->terminated = m->terminated;
    *state = s;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    mbs_fmu *m = c;
    const mbs_fmu_state *s = state;
    m->t = s->t;
    memcpy(m->x, s->x, sizeof s->x);
    memcpy(m->p, s->p, sizeof s->p);
    memcpy(m->g_prev, s->g_prev, sizeof s->g_prev);
    memcpy(m->event_t, s->event_t, sizeof s->event_t);
    m->nevents = s->nevents;
    m->terminated = s->terminated;
    fmu_changed(m);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    (void)c;
    free(*state);
    *state = NULL;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size)
{ (void)c; (void)s; (void)size; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{ (void)c; (void)s; (void)b; (void)n; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
{ (void)c; (void)b; (void)n; (void)s; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz, const fmi2Real du[],
                                                    fmi2Real dz[])
{ (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)du; (void)dz; return fmi2Error; }

/* ---- model exchange ---------------------------------------------------------------------------------------- */
FMI2_EXPORT fmi2Status fmi2EnterEventMode(fmi2Component c) { (void)c; return fmi2OK; }

FMI2_EXPORT fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info)
{
    memset(info, 0, sizeof *info);
#ifdef MBS_FMU_FROZEN
    return fmu_event_update((mbs_fmu *)c, info);
#else
    (void)c;
    return fmi2OK;
#endif
}

FMI2_EXPORT fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { (void)c; return fmi2OK; }

/* An indicator that changed sign since the last completed step or event asks for event mode (an importer that
 * located the crossing itself enters it anyway); g_prev keeps the values before it until the event. */
FMI2_EXPORT fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean no_set_prior,
                                                   fmi2Boolean *enter_event_mode, fmi2Boolean *terminate)
{
#ifdef MBS_FMU_FROZEN
    mbs_fmu *m = c;
    int k, crossed = 0;
    (void)no_set_prior;
    *terminate = fmi2False;
    if (mbs_events(m->t, m->x, m->p, m->g, m->work) != MBS_OK) return fmi2Error;
    for (k = 0; k < MBS_NEV; k++) crossed |= fmu_sign(m->g[k]) != fmu_sign(m->g_prev[k]) && m->g_prev[k] != 0;
    if (!crossed) memcpy(m->g_prev, m->g, sizeof(double) * MBS_NEV);
    *enter_event_mode = crossed ? fmi2True : fmi2False;
#else
    (void)c; (void)no_set_prior;
    *enter_event_mode = fmi2False;
    *terminate = fmi2False;
#endif
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t)
{
    mbs_fmu *m = c;
    m->t = t;
    fmu_changed(m);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n)
{
    mbs_fmu *m = c;
    if (n != MBS_NX) return fmi2Error;
    memcpy(m->x, x, sizeof(double) * MBS_NX);
    fmu_changed(m);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real xdot[], size_t n)
{
    mbs_fmu *m = c;
    if (n != MBS_NX || fmu_derivatives(m) != fmi2OK) return fmi2Error;
    memcpy(xdot, m->xdot, sizeof(double) * MBS_NX);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real g[], size_t n)
{
#ifdef MBS_FMU_FROZEN
    mbs_fmu *m = c;
    if (n != MBS_NEV || mbs_events(m->t, m->x, m->p, g, m->work) != MBS_OK) return fmi2Error;
    return fmi2OK;
#else
    (void)c; (void)g;
    return n ? fmi2Error : fmi2OK;
#endif
}

FMI2_EXPORT fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n)
{
    mbs_fmu *m = c;
    if (n != MBS_NX) return fmi2Error;
    memcpy(x, m->x, sizeof(double) * MBS_NX);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominal[], size_t n)
{
    size_t i;
    (void)c;
    for (i = 0; i < n; i++) nominal[i] = 1.0;
    return fmi2OK;
}

/* ---- co-simulation ----------------------------------------------------------------------------------------- */
static fmi2Status fmu_start_integrator(mbs_fmu *m)
{
    double atol = MBS_FMU_ATOL * (m->rtol / MBS_FMU_RTOL);
    if (m->ode.n) mbs_ode_free(&m->ode);
#ifdef MBS_FMU_FROZEN
    if (fmu_settle_switches(m) != fmi2OK) return fmi2Error;  /* a restart: each branch from where it starts */
#endif
    if (mbs_dopri5_init(&m->ode, MBS_NX, mbs_rhs, m->p, m->work, m->t, m->x, m->t_stop, m->rtol, &atol, 1, 0.0,
                        0.0, 0.0, 10000000L)) return fmi2Fatal;
#ifdef MBS_NC
    m->ode.yproj = calloc((size_t)MBS_NX + 1, sizeof(double));
    if (!m->ode.yproj) return fmi2Fatal;
    m->ode.project = mbs_project;
#endif
#ifdef MBS_FMU_FROZEN
    {   /* the events that assign run-time values only restart inside the sampling loop (ode.c, as in a run); a
         * jump of the state or the end of the run comes back to fmu_sample */
        if (mbs_ode_set_events(&m->ode, mbs_events, MBS_NEV, MBS_FMU_DIRECTIONS)
            || mbs_ode_set_restarts(&m->ode, m->p, MBS_FMU_ACTIONS, MBS_FMU_NACT, MBS_FMU_HANDLED,
                                    MBS_FMU_FLAG, MBS_FMU_FIRST, MBS_FMU_INDEX, MBS_FMU_SLOT, 64,
                                    MBS_FMU_ZENO_WINDOW)) return fmi2Fatal;
        memcpy(m->ode.g_old, m->g_prev, sizeof(double) * MBS_NEV);  /* an indicator at zero: the side it leaves to */
    }
#else
    (void)mbs_ode_set_events; (void)mbs_ode_set_restarts;  /* ode.c's event set-up: not needed without events */
#endif
    (void)mbs_ode_take_over;  /* an FMU starts afresh after every event it does not restart in C (as after a jump) */
    m->ode_stale = 0;
    return fmi2OK;
}

/* What fmu_sample ended with besides an mbs_ode status: an event ended the run (a terminal event, chattering). */
#define FMU_SAMPLE_TERMINATED 1001

/* Samples the co-simulation integrator up to *target.  At an event the sampling loop hands back, the events
 * that assign run-time values only are restarted in C as in a run (mbs_ode_restart); the others (a reinit, a
 * terminal event) are applied here (fmu_apply_events) and DOPRI5 starts afresh from the state after them, with
 * its own first step, as runtime/event_loop.run_with_events does after a jump.  Every event counts for the
 * chattering check (fmu_zeno).  Returns the last status of mbs_ode_sample, FMU_SAMPLE_TERMINATED (m->t and m->x
 * at the end), or MBS_ODE_MODEL_FAILED when an action failed. */
static int fmu_sample(mbs_fmu *m, double *target, long *index)
{
    int status;
    for (;;) {
#ifdef MBS_FMU_FROZEN
        long i;
        int mask;
        m->ode.restarts->count = 0;
#endif
        status = mbs_ode_sample(&m->ode, target, 1, index, m->x);
#ifdef MBS_FMU_FROZEN
        for (i = 0; i < m->ode.restarts->count; i++)  /* the events C restarted from, for the chattering check */
            fmu_note_event(m, m->ode.restarts->log[(size_t)i * m->ode.restarts->width]);
        if (m->ode.restarts->count && fmu_zeno(m)) {  /* the run ends after the last of them */
            const double *entry = m->ode.restarts->log + (size_t)(m->ode.restarts->count - 1) * m->ode.restarts->width;
            m->t = entry[0];
            memcpy(m->x, entry + 1 + MBS_NX, sizeof(double) * MBS_NX);
            fmu_log_zeno(m);
            return FMU_SAMPLE_TERMINATED;
        }
#endif
        if (*index >= 1 || status != MBS_ODE_EVENT) return status;
#ifdef MBS_FMU_FROZEN
        m->t = m->ode.t;
        memcpy(m->x, m->ode.y, sizeof(double) * MBS_NX);
        for (int k = 0; k < m->ode.nev; k++)  /* chattering is watched here (fmu_zeno), not by the window */
            m->ode.restarts->last_t[k] = -HUGE_VAL;
        m->ode.restarts->count = 0;
        if (mbs_ode_restart(&m->ode)) {
            fmu_note_event(m, m->ode.t);
            if (!fmu_zeno(m)) continue;
            fmu_log_zeno(m);
            memcpy(m->x, m->ode.y, sizeof(double) * MBS_NX);
            return FMU_SAMPLE_TERMINATED;
        }
        mask = fmu_apply_events(m, m->ode.g_old, 0);
        if (mask < 0) {
            fmu_log(m, fmi2Error, "logStatusError", "the event actions failed at t = %.12g s", m->t);
            return MBS_ODE_MODEL_FAILED;
        }
        if (mask & (FMU_TERMINAL | FMU_ZENO)) return FMU_SAMPLE_TERMINATED;
        if (*target - m->t <= MBS_ODE_DEPARTURE_STEP * fmax(1.0, fabs(*target))) {
            *index = 1;  /* the event is at the communication point (to round-off): the state after it is the sample */
            return MBS_ODE_RUNNING;
        }
        if (fmu_start_integrator(m) != fmi2OK) return MBS_ODE_MODEL_FAILED;
#else
        return status;
#endif
    }
}

/* A terminal event or chattering inside the step ends it early: fmi2Discard, with fmi2Terminated true and
 * fmi2LastSuccessfulTime the event's time (FMI 2.0, 4.2.2: the master then reads the status and terminates). */
FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior)
{
    mbs_fmu *m = c;
    double target = t + h;
    long index = 0;
    int status;
    (void)no_set_prior;
    if (m->terminated) {
        fmu_log(m, fmi2Error, "logStatusError", "the run ended at t = %.12g s (a terminal event)", m->t);
        return fmi2Error;
    }
    if (!m->ode.n || m->ode_stale || fabs(t - m->t) > 1e-12 * (1.0 + fabs(t))) {
        m->t = t;
        if (target > m->t_stop) m->t_stop = target;
        if (fmu_start_integrator(m) != fmi2OK) return fmi2Fatal;
    }
    if (target > m->ode.t_bound) {  /* a step past the announced stop time: restart with a farther bound */
        m->t_stop = DBL_MAX;
        if (fmu_start_integrator(m) != fmi2OK) return fmi2Fatal;
    }
    status = fmu_sample(m, &target, &index);
    if (status == FMU_SAMPLE_TERMINATED) {
        m->terminated = 1;
        m->xdot_valid = m->y_valid = 0;
        return fmi2Discard;
    }
    if (index < 1) {
        fmu_log(m, fmi2Error, "logStatusError", "integration failed at t = %g s (status %d, model status %d)",
                m->ode.t, status, m->ode.model_status);
        return fmi2Error;
    }
    m->t = target;
    m->xdot_valid = m->y_valid = 0;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                   const fmi2Integer order[], const fmi2Real value[])
{ (void)c; (void)vr; (void)order; (void)value; return n ? fmi2Error : fmi2OK; }
FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                    const fmi2Integer order[], fmi2Real value[])
{ (void)c; (void)vr; (void)order; (void)value; return n ? fmi2Error : fmi2OK; }
FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{ (void)c; (void)s; *value = fmi2OK; return fmi2OK; }
FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    mbs_fmu *m = c;
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = m->t;
    return fmi2OK;
}
FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{ (void)c; (void)s; (void)value; return fmi2Discard; }
FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    *value = s == fmi2Terminated && ((mbs_fmu *)c)->terminated ? fmi2True : fmi2False;
    return s == fmi2Terminated ? fmi2OK : fmi2Discard;
}
FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{ (void)c; (void)s; (void)value; return fmi2Discard; }
