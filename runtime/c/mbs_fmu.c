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
} mbs_fmu;

typedef struct { double t, x[MBS_NX + 1], p[MBS_NP + 1]; } mbs_fmu_state;

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
FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
#ifdef MBS_NC
    mbs_fmu *m = c;
    double xc[MBS_NX + 1];
    if (mbs_project(m->t, m->x, m->p, xc, m->work) != MBS_OK) {
        fmu_log(m, fmi2Error, "logStatusError", "the closed loops cannot be closed at the start");
        return fmi2Error;
    }
    memcpy(m->x, xc, sizeof(double) * MBS_NX);
    fmu_changed(m);
#else
    (void)c;
#endif
    return fmi2OK;
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
    (void)c;
    memset(info, 0, sizeof *info);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { (void)c; return fmi2OK; }

FMI2_EXPORT fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean no_set_prior,
                                                   fmi2Boolean *enter_event_mode, fmi2Boolean *terminate)
{
    (void)c; (void)no_set_prior;
    *enter_event_mode = fmi2False;
    *terminate = fmi2False;
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
{ (void)c; (void)g; return n ? fmi2Error : fmi2OK; }

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
    if (mbs_dopri5_init(&m->ode, MBS_NX, mbs_rhs, m->p, m->work, m->t, m->x, m->t_stop, m->rtol, &atol, 1, 0.0,
                        0.0, 0.0, 10000000L)) return fmi2Fatal;
#ifdef MBS_NC
    m->ode.yproj = calloc((size_t)MBS_NX + 1, sizeof(double));
    if (!m->ode.yproj) return fmi2Fatal;
    m->ode.project = mbs_project;
#endif
    m->ode_stale = 0;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior)
{
    mbs_fmu *m = c;
    double target = t + h;
    long index = 0;
    int status;
    (void)no_set_prior;
    if (!m->ode.n || m->ode_stale || fabs(t - m->t) > 1e-12 * (1.0 + fabs(t))) {
        m->t = t;
        if (target > m->t_stop) m->t_stop = target;
        if (fmu_start_integrator(m) != fmi2OK) return fmi2Fatal;
    }
    if (target > m->ode.t_bound) {  /* a step past the announced stop time: restart with a farther bound */
        m->t_stop = DBL_MAX;
        if (fmu_start_integrator(m) != fmi2OK) return fmi2Fatal;
    }
    status = mbs_ode_sample(&m->ode, &target, 1, &index, m->x);
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
{ (void)c; (void)s; *value = fmi2False; return s == fmi2Terminated ? fmi2OK : fmi2Discard; }
FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{ (void)c; (void)s; (void)value; return fmi2Discard; }
