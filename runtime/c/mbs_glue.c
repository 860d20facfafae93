/* The glue of one generated model: its function table and what the Python bindings need to know of it.
 *
 * build.py compiles the generated model source (which defines MBS_NQ, MBS_NV, MBS_NX, MBS_NP, MBS_NWORK and the
 * mbs_* functions) followed by this file, and links the bindings and the integrators (c/mbs_python.c), which
 * build.py compiles once for all models.  This file describes the model to them (an mbs_model_info,
 * c/mbs_python.h) and defines the module's init function: with -DMBS_MODULE_NAME=<unique name>
 * PyInit_<name> itself; with MBS_SEPARATE_INIT (a split build) mbs_module_init(name), which a small unit of the
 * build calls from PyInit_<name>, so that this unit's object serves every module built from the same model.
 * MBS_OUTPUTS_UNIT (model.h of a split build): the outputs are compiled in a unit of their own, which defines
 * mbs_outputs and their number mbs_ny, so that this unit does not depend on them.  Neither <Python.h> nor NumPy
 * is included here.
 *
 * Adding a generated function is one row of MBS_TABLE (guarded by the size macro it needs).
 */
#if !defined(MBS_MODULE_NAME) && !defined(MBS_SEPARATE_INIT)
#error "compile with -DMBS_MODULE_NAME=<module name>"
#endif
#ifdef MBS_OUTPUTS_UNIT
extern const int mbs_ny;
#endif
#if !defined(MBS_NQ) || !defined(MBS_NV) || !defined(MBS_NX) || !defined(MBS_NP) || !defined(MBS_NWORK)
#error "the model must define MBS_NQ, MBS_NV, MBS_NX, MBS_NP and MBS_NWORK"
#endif

#include "mbs_python.h"
#ifdef MBS_NC
#include "loops.c"  /* closed kinematic loops: projection, partitioning, constrained accelerations */
#ifdef MBS_LOOP_JACOBIAN
#include "loop_jacobian.c"  /* their exact Jacobian (mbs_jacobian) */
#endif
#endif

#define MBS_CAT2(a, b) a##b
#define MBS_CAT(a, b) MBS_CAT2(a, b)

/* ---- the rows of a run (Function.rows: runtime/rows.py) --------------------------------------------- */

#ifdef MBS_NC
/* The outputs of a model with loops solve in work + MBS_OUTPUTS_WORK (compiler/ccode.py), a loop solver's work apart
 * from the integrator's at work: the rows are projected there (mbs_loop_project_row: from the factors the previous
 * row left, else mbs_project), so that the outputs' mbs_loop_rates solves from the factors at the row without
 * projecting it again (c/loops.c), and the integrator's kept partition is left alone. */
#ifdef MBS_OUTPUTS_WORK
#define MBS_ROWS_WORK MBS_OUTPUTS_WORK
#else
#define MBS_ROWS_WORK 0
#endif
static int rows_project(double t, const double *x, const double *p, double *out, double *work)
{
    return mbs_loop_project_row(t, x, p, out, work + MBS_ROWS_WORK);
}
#endif

/* ---- the function table ------------------------------------------------------------------------ */

/* Rows {name, function, rows, cols[, nin]} (c/mbs_python.h mbs_entry).  Not const: the number of outputs of a
 * split build is set when the module is created. */
static mbs_entry MBS_TABLE[] = {
    {"rhs", mbs_rhs, MBS_NX, 0},
#ifndef MBS_COLD_APART  /* else in a library of their own, built when first called (c/mbs_cold_glue.c) */
    {"mass_matrix", mbs_mass_matrix, MBS_NV, MBS_NV},
    {"forces", mbs_forces, MBS_NV, 0},
#endif
    {"qdot", mbs_qdot, MBS_NQ, 0},
#ifdef MBS_NY
    {"outputs", mbs_outputs, MBS_NY, 0},
#elif defined(MBS_OUTPUTS_UNIT)
    {"outputs", mbs_outputs, 0, 0},  /* rows: mbs_ny, set in mbs_module_create */
#endif
#ifdef MBS_JACOBIAN
    {"jacobian", mbs_jacobian, MBS_NX, MBS_NX + 1},
#endif
#ifdef MBS_NXA
    {"inverse_dynamics", mbs_inverse_dynamics, MBS_NV, 0, MBS_NXA},
    {"bias_forces", mbs_bias_forces, MBS_NV, 0, 0},
    {"gravity_forces", mbs_gravity_forces, MBS_NV, 0, 0},
#endif
#ifdef MBS_NF
    {"frame_positions", mbs_frame_positions, MBS_NF, 12, 0},
    {"frame_velocities", mbs_frame_velocities, MBS_NF, 6, 0},
    {"frame_jacobians", mbs_frame_jacobians, 6 * MBS_NF, MBS_NV, 0},
#endif
#ifdef MBS_NEV
    {"events", mbs_events, MBS_NEV, 0},
#endif
#ifdef MBS_NACT
    {"event_actions", mbs_event_actions, MBS_NACT, 0},
#endif
#ifdef MBS_PARAM_JACOBIAN
    {"param_jacobian", mbs_param_jacobian, MBS_NX, MBS_NP},
#endif
#ifdef MBS_NC
    {"constraints", mbs_constraints, MBS_NC, 0},
    {"constraint_velocity", mbs_constraint_velocity, MBS_NC, 0},
    {"constraint_acceleration", mbs_constraint_acceleration, MBS_NC, 0},
    {"constraint_jacobian", mbs_loop_jacobian, MBS_NC, MBS_NV},
    {"project", mbs_project, MBS_NX, 0},
    {"normalize", mbs_loop_normalize, MBS_NX, 0},
    {"multipliers", mbs_loop_multipliers, MBS_NC, 0},
    {"loop_report", mbs_loop_report, MBS_LOOP_NREPORT, 0},
    {"loop_rhs", mbs_loop_rhs_direct, MBS_NX, 0},  /* x' without projection: what the C integrators call */
    {"loop_accept", mbs_loop_accept, 2 * MBS_NX, 0},  /* [x'; the accepted state projected]: a step's end */
    {"project_row", rows_project, MBS_NX, 0},  /* mbs_project of the rows of a run, one after another (rows.py) */
#endif
#ifdef MBS_CLOSED_FORM  /* loops closed in closed form alone (status 4 off their branch), for tests and benches */
    {"closed_form_rhs", mbs_closed_form_rhs, MBS_NX, 0},
    {"closed_form_project", mbs_closed_form_project, MBS_NX, 0},
#endif
};
#define MBS_TABLE_SIZE ((int)(sizeof MBS_TABLE / sizeof MBS_TABLE[0]))

/* The projection before the outputs of a row (Function.rows with `projected`): where the outputs solve the loops in
 * a work of their own, which the row's projection leaves its factors in. */
#if defined(MBS_NC) && defined(MBS_OUTPUTS_WORK) && (defined(MBS_NY) || defined(MBS_OUTPUTS_UNIT))
#define MBS_ROWS_PROJECT rows_project
#else
#define MBS_ROWS_PROJECT NULL
#endif

static mbs_model_info MBS_INFO = {
    MBS_NQ, MBS_NV, MBS_NX, MBS_NP, MBS_NWORK,
#ifdef MBS_NY
    MBS_NY,
#else
    -1,  /* a split build's: mbs_ny, set in mbs_module_init */
#endif
    MBS_TABLE, MBS_TABLE_SIZE, mbs_rhs,
#ifdef MBS_JACOBIAN
    mbs_jacobian,
#else
    NULL,
#endif
#if defined(MBS_NY) || defined(MBS_OUTPUTS_UNIT)
    mbs_outputs,
#else
    NULL,
#endif
#ifdef MBS_NC
    /* the mechanism's own rhs in DOPRI5 is x' at the integrated state itself (mbs_loop_rhs_direct, the kept
     * partition), its accepted states projected reusing the last stage's factors of G (mbs_loop_project_step); the
     * projecting mbs_loop_rhs at every stage would project each stage's state again (the bump: two thirds of the
     * integration's work).  rodasp keeps the projecting rhs, whose Jacobian loop_jacobian.c assembles. */
    mbs_project, mbs_loop_rhs_direct, mbs_loop_project_step,
#else
    NULL, NULL, NULL,
#endif
    MBS_ROWS_PROJECT,
#ifdef MBS_EVENT_INDICATOR
    mbs_event_indicator,
#else
    NULL,
#endif
#ifdef MBS_NC
    mbs_loop_step_drift,
#else
    NULL,
#endif
};

/* The module under `name` (a string that lives as long as the process): what PyInit_<name> returns. */
static void *mbs_module_create(const char *name)
{
#ifdef MBS_OUTPUTS_UNIT
    int i;
    for (i = 0; i < MBS_TABLE_SIZE; i++)
        if (MBS_TABLE[i].fn == mbs_outputs) MBS_TABLE[i].rows = mbs_ny;
    MBS_INFO.ny = mbs_ny;
#endif
    return mbs_python_module(name, &MBS_INFO);
}

#ifdef MBS_SEPARATE_INIT
void *mbs_module_init(const char *name);
void *mbs_module_init(const char *name)
{
    return mbs_module_create(name);
}
#else
#define MBS_STR2(a) #a
#define MBS_STR(a) MBS_STR2(a)
#if defined(_WIN32)
#define MBS_EXPORT __declspec(dllexport)
#else
#define MBS_EXPORT __attribute__((visibility("default")))
#endif
MBS_EXPORT void *MBS_CAT(PyInit_, MBS_MODULE_NAME)(void);
MBS_EXPORT void *MBS_CAT(PyInit_, MBS_MODULE_NAME)(void)
{
    return mbs_module_create(MBS_STR(MBS_MODULE_NAME));
}
#endif
