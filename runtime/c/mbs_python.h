/* What a compiled model hands the Python bindings (c/mbs_python.c): its sizes, its function table and the few
 * functions the bindings treat specially.  The bindings and the integrators use no model macro, so runtime/build.py
 * compiles them once into an object kept in the build cache and links it into every model; the model's own glue
 * (c/mbs_glue.c, compiled with the model) fills an mbs_model_info and calls mbs_python_module.  Plain C: the glue
 * needs neither <Python.h> nor NumPy's headers. */
#ifndef MBS_PYTHON_H
#define MBS_PYTHON_H

#include "mbs_runtime.h"

/* A row of the function table: what Function(name, ...) finds. */
typedef struct {
    const char *name;
    mbs_fn fn;
    int rows, cols;  /* output shape; cols == 0 for a vector */
    int nin;         /* length of the input x; 0: nx (mbs_inverse_dynamics reads [q; v; a]) */
} mbs_entry;

typedef struct {
    int nq, nv, nx, np, nwork;
    int ny;                     /* outputs (-1: the model has none) */
    const mbs_entry *table;     /* the functions, table_size rows */
    int table_size;
    mbs_fn rhs;                 /* mbs_rhs: the right-hand side a Solver integrates */
    mbs_fn jacobian;            /* its exact Jacobian for the implicit methods, or NULL */
    mbs_fn outputs;             /* mbs_outputs, or NULL */
    /* closed loops (all NULL without): */
    mbs_fn project;             /* the projection onto the constraints after an accepted step */
    mbs_fn rhs_direct;          /* x' at the state itself, DOPRI5's right-hand side in place of rhs */
    mbs_fn project_step;        /* the projection that reuses rhs_direct's factors of the last stage */
    mbs_fn rows_project;        /* the projection before the outputs of a row (Function.rows `projected`) */
    mbs_indicator_fn event_indicator;  /* mbs_event_indicator: one of mbs_events' indicators alone, or NULL */
    void (*step_drift)(double *work, double atol);  /* closed loops: a run's smallest atol to project_step in its work
                                                     * (the drift an accepted state keeps, c/loops.c), or NULL */
} mbs_model_info;

/* The extension module `name` of the model `info` (a PyObject *, or NULL with a Python exception set): what the
 * module's PyInit_<name> returns.  `name` and `info` must live as long as the process. */
void *mbs_python_module(const char *name, const mbs_model_info *info);

#endif
