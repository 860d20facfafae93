/* The Python bindings of a compiled model and the integrators they run: the part of every model's extension
 * module that is the same for all models.  runtime/build.py compiles it once (its object is kept in the build
 * cache under a hash of these files, the flags and the compiler) and links it into every model; the model's own
 * glue (c/mbs_glue.c) describes the model in an mbs_model_info (c/mbs_python.h) and calls mbs_python_module from
 * its PyInit_<name>.  The module exposes:
 *
 *   NQ, NV, NX, NP, NWORK, NY      sizes (NY is -1 when the model has no outputs)
 *   FUNCTIONS                      ((name, output shape), ...) of the model's function table
 *   METHODS                        names of the integrators in C
 *   Function(name, p, work)        a callable f(t, x) -> fresh ndarray bound to one workspace's p and
 *                                  work arrays (vectorcall: about a microsecond per call)
 *   Solver(method, rhs, ...)       an integrator run in C (see solver_new)
 *   _init(error_class)             the exception raised for a model status != 0
 *
 * Only mbs_python_module has external linkage (hidden: the module exports PyInit_<name> alone); the integrators
 * stay static here, as in the FMU (c/mbs_fmu.c), which includes them too.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <structmember.h>
#include <time.h>

#include "mbs_python.h"
#include "ode.c"
#include "dense_lu.c"
#include "dopri5.c"
#include "rosenbrock.c"
#include "rodasp.c"
#include "rodas5p.c"
#include "adams.c"
#include "huge_text.c"

/* The model of this module (one model per module: each links its own copy of this object). */
static const mbs_model_info *mbs_model = NULL;

typedef int (*mbs_init_fn)(mbs_ode *, int, mbs_fn, const double *, double *, double, const double *, double,
                           double, const double *, int, double, double, double, long);

static const struct { const char *name; mbs_init_fn init; } MBS_METHODS[] = {
    {"dopri5", mbs_dopri5_init},
    {"rodasp", mbs_rodasp_init},
    {"rodas5p", mbs_rodas5p_init},
    {"adams", mbs_adams_init},
};
#define MBS_METHODS_SIZE ((int)(sizeof MBS_METHODS / sizeof MBS_METHODS[0]))

static PyObject *mbs_error_class = NULL;  /* set by _init; RuntimeError until then */

/* values (may be NULL): what the function wrote before it failed, kept on the exception as .values (the
   failing mass matrix tells which coordinates have no inertia) */
static void raise_status(const char *name, int status, double t, PyObject *values)
{
    PyObject *cls = mbs_error_class ? mbs_error_class : PyExc_RuntimeError;
    PyObject *exc = PyObject_CallFunction(cls, "sid", name, status, t);
    if (exc) {
        if (values && PyObject_SetAttrString(exc, "values", values) < 0) PyErr_Clear();
        PyErr_SetObject((PyObject *)Py_TYPE(exc), exc);
        Py_DECREF(exc);
    }
}

/* A read-only view of obj as n contiguous doubles; *tmp receives a converted copy to release, if any. */
static const double *as_vector(PyObject *obj, npy_intp n, const char *what, PyObject **tmp)
{
    PyArrayObject *a;
    *tmp = NULL;
    if (PyArray_Check(obj)) {
        a = (PyArrayObject *)obj;
        if (PyArray_TYPE(a) == NPY_DOUBLE && PyArray_NDIM(a) == 1 && PyArray_DIM(a, 0) == n
            && PyArray_ISCARRAY_RO(a))
            return (const double *)PyArray_DATA(a);
    }
    *tmp = PyArray_FROMANY(obj, NPY_DOUBLE, 1, 1, NPY_ARRAY_CARRAY_RO);
    if (!*tmp) return NULL;
    a = (PyArrayObject *)*tmp;
    if (PyArray_DIM(a, 0) != n) {
        PyErr_Format(PyExc_ValueError, "%s must have %zd elements, got %zd", what, (Py_ssize_t)n,
                     (Py_ssize_t)PyArray_DIM(a, 0));
        Py_CLEAR(*tmp);
        return NULL;
    }
    return (const double *)PyArray_DATA(a);
}

/* A writable float64 C-contiguous ndarray of exactly `size` elements, or NULL with an exception. */
static double *as_buffer(PyObject *obj, npy_intp size, const char *what)
{
    PyArrayObject *a = (PyArrayObject *)obj;
    if (!PyArray_Check(obj) || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISCARRAY(a)
        || PyArray_SIZE(a) != size) {
        PyErr_Format(PyExc_TypeError, "%s must be a writable C-contiguous float64 ndarray of %zd elements",
                     what, (Py_ssize_t)size);
        return NULL;
    }
    return (double *)PyArray_DATA(a);
}

/* ---- Function: f(t, x) -> fresh ndarray -------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    const mbs_entry *entry;
    PyObject *p_obj, *work_obj;  /* the workspace's arrays, kept alive */
    const double *p;
    double *work;
    unsigned long long calls;
} FunctionObject;

static PyObject *function_vectorcall(PyObject *self_, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    FunctionObject *self = (FunctionObject *)self_;
    const mbs_entry *e = self->entry;
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    npy_intp dims[2] = {e->rows, e->cols};
    PyObject *tmp, *out;
    const double *x;
    double t;
    int status;
    if (nargs != 2 || (kwnames && PyTuple_GET_SIZE(kwnames))) {
        PyErr_Format(PyExc_TypeError, "%s(t, x) takes exactly 2 positional arguments", e->name);
        return NULL;
    }
    t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred()) return NULL;
    x = as_vector(args[1], e->nin ? e->nin : mbs_model->nx, "x", &tmp);
    if (!x) return NULL;
    out = PyArray_SimpleNew(e->cols ? 2 : 1, dims, NPY_DOUBLE);
    if (!out) { Py_XDECREF(tmp); return NULL; }
    status = e->fn(t, x, self->p, (double *)PyArray_DATA((PyArrayObject *)out), self->work);
    self->calls++;
    Py_XDECREF(tmp);
    if (status != MBS_OK) {
        raise_status(e->name, status, t, out);
        Py_DECREF(out);
        return NULL;
    }
    return out;
}

static PyObject *function_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"name", "p", "work", NULL};
    const char *name;
    PyObject *p_obj, *work_obj;
    FunctionObject *self;
    int i;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "sOO:Function", kwlist, &name, &p_obj, &work_obj)) return NULL;
    for (i = 0; i < mbs_model->table_size; i++)
        if (strcmp(mbs_model->table[i].name, name) == 0) break;
    if (i == mbs_model->table_size) {
        PyErr_Format(PyExc_KeyError, "the model has no function '%s'", name);
        return NULL;
    }
    self = (FunctionObject *)type->tp_alloc(type, 0);
    if (!self) return NULL;
    self->vectorcall = function_vectorcall;
    self->entry = &mbs_model->table[i];
    if (!(self->p = as_buffer(p_obj, mbs_model->np, "p")) || !(self->work = as_buffer(work_obj, mbs_model->nwork, "work"))) {
        Py_DECREF(self);
        return NULL;
    }
    Py_INCREF(p_obj); self->p_obj = p_obj;
    Py_INCREF(work_obj); self->work_obj = work_obj;
    return (PyObject *)self;
}

static void function_dealloc(FunctionObject *self)
{
    Py_XDECREF(self->p_obj);
    Py_XDECREF(self->work_obj);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *function_call(PyObject *self, PyObject *args, PyObject *kwds)
{
    return PyVectorcall_Call(self, args, kwds);
}

/* f.time(x, n, t=0.0) -> seconds per call, n calls timed inside C (no Python in the loop). */
static PyObject *function_time(FunctionObject *self, PyObject *args)
{
    PyObject *x_obj, *tmp;
    long n, i;
    double t = 0.0, *out;
    const double *x;
    struct timespec t0, t1;
    int status = MBS_OK;
    volatile double sink = 0.0;  /* keeps the compiler from dropping the calls */
    size_t size = (size_t)self->entry->rows * (size_t)(self->entry->cols ? self->entry->cols : 1);
    if (!PyArg_ParseTuple(args, "Ol|d:time", &x_obj, &n, &t)) return NULL;
    if (n < 1) { PyErr_SetString(PyExc_ValueError, "n must be positive"); return NULL; }
    x = as_vector(x_obj, self->entry->nin ? self->entry->nin : mbs_model->nx, "x", &tmp);
    if (!x) return NULL;
    out = PyMem_Malloc((size + 1) * sizeof(double));
    if (!out) { Py_XDECREF(tmp); return PyErr_NoMemory(); }
    Py_BEGIN_ALLOW_THREADS
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (i = 0; i < n && status == MBS_OK; i++) {
        status = self->entry->fn(t, x, self->p, out, self->work);
        sink += out[0];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    Py_END_ALLOW_THREADS
    (void)sink;
    PyMem_Free(out);
    Py_XDECREF(tmp);
    if (status != MBS_OK) { raise_status(self->entry->name, status, t, NULL); return NULL; }
    return PyFloat_FromDouble(((double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec)) / (double)n);
}

/* Whether obj is an aligned C-contiguous ndarray of `type` with `ndim` dimensions (writable when asked). */
static int is_carray(PyObject *obj, int type, int ndim, int writable)
{
    PyArrayObject *a = (PyArrayObject *)obj;
    return PyArray_Check(obj) && PyArray_TYPE(a) == type && PyArray_NDIM(a) == ndim
           && (writable ? PyArray_ISCARRAY(a) : PyArray_ISCARRAY_RO(a));
}

/* f.rows(t, x, out, ps, which[, projected]) -> rows done: out[i] = f(t[i], x[i]) with the run-time values
 * ps[which[i]] copied into the bound p where which changes (p restored at the end), a row equal to the one before it
 * (time, state, which) taking its value; stops at the first failing row (the caller calls f there for its error).
 * out may be x.  With `projected` (the outputs of a model with loops): each row is projected first, into
 * projected[i], and f evaluated there (one projection per row instead of the projection and the outputs' own: a
 * failing row is then the projection's or f's).  The rows of a run in one call, no Python between them
 * (runtime/simulate.py). */
static PyObject *function_rows(FunctionObject *self, PyObject *args)
{
    PyObject *t_obj, *x_obj, *out_obj, *ps_obj, *w_obj, *proj_obj = NULL;
    double *proj = NULL;
    const mbs_entry *e = self->entry;
    npy_intp n, i, nin = e->nin ? e->nin : mbs_model->nx, size = (npy_intp)e->rows * (e->cols ? e->cols : 1), copies;
    const double *t, *x, *ps;
    const npy_intp *which;
    double *out, *p = (double *)self->p, *saved;
    npy_intp current = -1;
    int status = MBS_OK;
    if (!PyArg_ParseTuple(args, "OOOOO|O:rows", &t_obj, &x_obj, &out_obj, &ps_obj, &w_obj, &proj_obj)) return NULL;
    if (!is_carray(t_obj, NPY_DOUBLE, 1, 0) || !is_carray(x_obj, NPY_DOUBLE, 2, 0) || !is_carray(out_obj, NPY_DOUBLE, 2, 1)
        || !is_carray(ps_obj, NPY_DOUBLE, 2, 0) || !is_carray(w_obj, NPY_INTP, 1, 0)) {
        PyErr_SetString(PyExc_TypeError, "rows(t, x, out, ps, which): C-contiguous float64 arrays (out writable) "
                        "and an intp array");
        return NULL;
    }
    n = PyArray_DIM((PyArrayObject *)t_obj, 0);
    copies = PyArray_DIM((PyArrayObject *)ps_obj, 0);
    if (PyArray_DIM((PyArrayObject *)x_obj, 0) != n || PyArray_DIM((PyArrayObject *)x_obj, 1) != nin
        || PyArray_DIM((PyArrayObject *)out_obj, 0) != n || PyArray_DIM((PyArrayObject *)out_obj, 1) != size
        || PyArray_DIM((PyArrayObject *)ps_obj, 1) != mbs_model->np || PyArray_DIM((PyArrayObject *)w_obj, 0) != n) {
        PyErr_SetString(PyExc_ValueError, "rows(t, x, out, ps, which): shapes (n,), (n, nx), (n, size), (k, np), (n,)");
        return NULL;
    }
    t = PyArray_DATA((PyArrayObject *)t_obj);
    x = PyArray_DATA((PyArrayObject *)x_obj);
    out = PyArray_DATA((PyArrayObject *)out_obj);
    ps = PyArray_DATA((PyArrayObject *)ps_obj);
    which = PyArray_DATA((PyArrayObject *)w_obj);
    if (proj_obj && proj_obj != Py_None) {
        if (!mbs_model->rows_project) {
            PyErr_SetString(PyExc_ValueError, "rows(..., projected): this model has no loops solved in its outputs");
            return NULL;
        }
        if (e->fn != mbs_model->outputs || !is_carray(proj_obj, NPY_DOUBLE, 2, 1)
            || PyArray_DIM((PyArrayObject *)proj_obj, 0) != n
            || PyArray_DIM((PyArrayObject *)proj_obj, 1) != mbs_model->nx || proj_obj == x_obj) {
            PyErr_SetString(PyExc_ValueError, "rows(..., projected): the outputs' rows, projected a writable (n, nx) "
                            "array apart from x");
            return NULL;
        }
        proj = PyArray_DATA((PyArrayObject *)proj_obj);
    }
    for (i = 0; i < n; i++)
        if (which[i] < 0 || which[i] >= copies) { PyErr_SetString(PyExc_IndexError, "which out of range"); return NULL; }
    saved = PyMem_Malloc(((size_t)mbs_model->np + 1) * sizeof(double));
    if (!saved) return PyErr_NoMemory();
    memcpy(saved, p, (size_t)mbs_model->np * sizeof(double));
    for (i = 0; i < n && status == MBS_OK; i++) {
        const double *xi = x + i * nin;
        if (which[i] != current) {
            current = which[i];
            memcpy(p, ps + current * mbs_model->np, (size_t)mbs_model->np * sizeof(double));
        } else if (i > 0 && t[i] == t[i - 1] && memcmp(xi, xi - nin, (size_t)nin * sizeof(double)) == 0
                   && out != x) {
            memcpy(out + i * size, out + (i - 1) * size, (size_t)size * sizeof(double));
            if (proj) memcpy(proj + i * nin, proj + (i - 1) * nin, (size_t)nin * sizeof(double));
            continue;
        }
        if (proj) {
            status = mbs_model->rows_project(t[i], xi, p, proj + i * nin, self->work);
            if (status != MBS_OK) continue;  /* (the loop ends: row i failed) */
            xi = proj + i * nin;
        }
        status = e->fn(t[i], xi, p, out + i * size, self->work);
        self->calls++;
    }
    memcpy(p, saved, (size_t)mbs_model->np * sizeof(double));
    PyMem_Free(saved);
    return PyLong_FromSsize_t(status == MBS_OK ? n : i - 1);
}

static PyObject *function_get_name(FunctionObject *self, void *closure)
{
    (void)closure;
    return PyUnicode_FromString(self->entry->name);
}

static PyObject *function_get_calls(FunctionObject *self, void *closure)
{
    (void)closure;
    return PyLong_FromUnsignedLongLong(self->calls);
}

static PyMethodDef function_methods[] = {
    {"time", (PyCFunction)function_time, METH_VARARGS,
     "time(x, n, t=0.0) -> seconds per call of n calls made inside C"},
    {"rows", (PyCFunction)function_rows, METH_VARARGS,
     "rows(t, x, out, ps, which) -> rows done: out[i] = f(t[i], x[i]) with p = ps[which[i]]"},
    {NULL, NULL, 0, NULL},
};

static PyGetSetDef function_getset[] = {
    {"name", (getter)function_get_name, NULL, "name in the model's function table", NULL},
    {"calls", (getter)function_get_calls, NULL, "number of calls from Python so far", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject FunctionType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "mbs_model.Function",  /* the module's own name is put in by mbs_python_module */
    .tp_basicsize = sizeof(FunctionObject),
    .tp_dealloc = (destructor)function_dealloc,
    .tp_vectorcall_offset = offsetof(FunctionObject, vectorcall),
    .tp_call = function_call,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_doc = "Function(name, p, work): f(t, x) -> new ndarray, bound to one workspace's p and work",
    .tp_methods = function_methods,
    .tp_getset = function_getset,
    .tp_new = function_new,
};

/* ---- Solver: an integrator run in C ------------------------------------------------------------ */

typedef struct {
    PyObject_HEAD
    mbs_ode ode;
    PyObject *function;  /* the FunctionObject whose p and work the run uses */
    PyObject *events;    /* the FunctionObject of the event indicators, or NULL */
    int busy;            /* a call is running with the GIL released */
} SolverObject;

static PyTypeObject SolverType;

static PyObject *solver_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"method", "rhs", "t0", "y0", "t_bound", "rtol", "atol", "first_step",
                             "max_step", "min_step", "max_steps", NULL};
    const char *method;
    PyObject *fn_obj, *y0_obj, *atol_obj, *y0_tmp = NULL, *atol_tmp = NULL;
    double t0, t_bound, rtol, first_step = 0.0, max_step = 0.0, min_step = 0.0, smallest_atol;
    long max_steps = 1000000;
    const double *y0, *atol;
    int natol, i, k, rc;
    FunctionObject *fn;
    mbs_fn rhs;
    SolverObject *self;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "sO!dOddO|dddl:Solver", kwlist, &method, &FunctionType, &fn_obj,
                                     &t0, &y0_obj, &t_bound, &rtol, &atol_obj, &first_step, &max_step, &min_step,
                                     &max_steps))
        return NULL;
    for (i = 0; i < MBS_METHODS_SIZE; i++)
        if (strcmp(MBS_METHODS[i].name, method) == 0) break;
    if (i == MBS_METHODS_SIZE) {
        PyErr_Format(PyExc_ValueError, "no integrator %s in C", method);
        return NULL;
    }
    fn = (FunctionObject *)fn_obj;
    if (fn->entry->rows != mbs_model->nx || fn->entry->cols != 0) {
        PyErr_Format(PyExc_ValueError, "%s is not a right-hand side x -> xdot", fn->entry->name);
        return NULL;
    }
    if (!(t_bound >= t0)) {
        PyErr_SetString(PyExc_ValueError, "t_bound must not lie before t0 (integration runs forward)");
        return NULL;
    }
    if (!(y0 = as_vector(y0_obj, mbs_model->nx, "y0", &y0_tmp))) return NULL;
    if (PyFloat_Check(atol_obj) || PyLong_Check(atol_obj)) {
        atol = as_vector(atol_obj = PyTuple_Pack(1, atol_obj), 1, "atol", &atol_tmp);
        Py_DECREF(atol_obj);
        natol = 1;
    } else {
        atol = as_vector(atol_obj, mbs_model->nx, "atol", &atol_tmp);
        natol = mbs_model->nx;
    }
    if (!atol) { Py_XDECREF(y0_tmp); return NULL; }
    for (smallest_atol = atol[0], k = 1; k < natol; k++)
        smallest_atol = atol[k] < smallest_atol ? atol[k] : smallest_atol;
    self = (SolverObject *)type->tp_alloc(type, 0);
    if (!self) { Py_XDECREF(y0_tmp); Py_XDECREF(atol_tmp); return NULL; }
    Py_INCREF(fn_obj);
    self->function = fn_obj;
    rhs = fn->entry->fn;
    /* the mechanism's own rhs in DOPRI5: x' at the integrated state itself (mbs_loop_rhs_direct, the kept
     * partition), the accepted states projected below; the projecting mbs_loop_rhs at every stage would project
     * each stage's state again (the bump: two thirds of the integration's work).  rodasp keeps the projecting
     * rhs, whose Jacobian loop_jacobian.c assembles.  Adams (adams.c) as DOPRI5 (it evaluates f at each accepted
     * state after its projection: the direct rhs there is the projecting one's; the projecting rhs at its
     * predicted states took the same steps on the Iltis bump for half again the wall time). */
    if (fn->entry->fn == mbs_model->rhs && mbs_model->rhs_direct
        && (MBS_METHODS[i].init == mbs_dopri5_init || MBS_METHODS[i].init == mbs_adams_init))
        rhs = mbs_model->rhs_direct;
    rc = MBS_METHODS[i].init(&self->ode, mbs_model->nx, rhs, fn->p, fn->work, t0, y0, t_bound, rtol, atol,
                             natol, first_step, max_step, min_step, max_steps);
    Py_XDECREF(y0_tmp);
    Py_XDECREF(atol_tmp);
    if (!rc && fn->entry->fn == mbs_model->rhs) self->ode.jac = mbs_model->jacobian;  /* the generated one, exact */
    /* the mechanism's own right-hand side: keep the integrated state on its loop-closure constraints */
    if (!rc && fn->entry->fn == mbs_model->rhs && mbs_model->project) {
        self->ode.yproj = calloc((size_t)mbs_model->nx + 1, sizeof(double));
        /* the factors of G the last evaluation left serve the projection: DOPRI5's last stage is at the
         * accepted state, Adams' at its predicted state, near it (c/loops.c mbs_loop_stamp_q_near) */
        self->ode.project = rhs == mbs_model->rhs_direct ? mbs_model->project_step : mbs_model->project;
        if (rhs == mbs_model->rhs_direct && mbs_model->step_drift)  /* the drift its accepted states may keep */
            mbs_model->step_drift(fn->work, smallest_atol);
        rc = self->ode.yproj ? 0 : -1;
    }
    if (rc) { Py_DECREF(self); return PyErr_NoMemory(); }
    return (PyObject *)self;
}

static void solver_dealloc(SolverObject *self)
{
    mbs_ode_free(&self->ode);
    Py_XDECREF(self->function);
    Py_XDECREF(self->events);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int solver_enter(SolverObject *self)
{
    if (self->busy) {
        PyErr_SetString(PyExc_RuntimeError, "this solver is running in another thread");
        return -1;
    }
    self->busy = 1;
    return 0;
}

/* s.step() -> status: one accepted step (or a failure) */
static PyObject *solver_step(SolverObject *self, PyObject *unused)
{
    int status;
    (void)unused;
    if (solver_enter(self)) return NULL;
    Py_BEGIN_ALLOW_THREADS
    if (self->ode.status == MBS_ODE_RUNNING) {
        self->ode.step(&self->ode);
        mbs_ode_find_event(&self->ode);
    }
    status = self->ode.status;
    Py_END_ALLOW_THREADS
    self->busy = 0;
    return PyLong_FromLong(status);
}

/* s.budget(n): allow n more steps from now; a run that stopped at its step budget resumes (the caller
   returns to Python between budgets to check for interruption, wall time and stalls) */
static PyObject *solver_budget(SolverObject *self, PyObject *arg)
{
    long n = PyLong_AsLong(arg);
    if (n == -1 && PyErr_Occurred()) return NULL;
    if (n < 0) { PyErr_SetString(PyExc_ValueError, "budget(n) needs n >= 0"); return NULL; }
    self->ode.max_steps = self->ode.nsteps + n;
    if (self->ode.status == MBS_ODE_TOO_MANY_STEPS) self->ode.status = MBS_ODE_RUNNING;
    Py_RETURN_NONE;
}

/* s.sample(t_eval, out, start) -> (status, next): fill out[i] = y(t_eval[i]) for i >= start */
static PyObject *solver_sample(SolverObject *self, PyObject *args)
{
    PyObject *t_obj, *out_obj, *t_tmp = NULL;
    PyArrayObject *out;
    const double *t_eval;
    long start, n_eval;
    int status;
    if (!PyArg_ParseTuple(args, "OO!l:sample", &t_obj, &PyArray_Type, &out_obj, &start)) return NULL;
    t_tmp = PyArray_FROMANY(t_obj, NPY_DOUBLE, 1, 1, NPY_ARRAY_CARRAY_RO);
    if (!t_tmp) return NULL;
    t_eval = (const double *)PyArray_DATA((PyArrayObject *)t_tmp);
    n_eval = (long)PyArray_DIM((PyArrayObject *)t_tmp, 0);
    out = (PyArrayObject *)out_obj;
    if (PyArray_TYPE(out) != NPY_DOUBLE || !PyArray_ISCARRAY(out) || PyArray_NDIM(out) != 2
        || PyArray_DIM(out, 0) != n_eval || PyArray_DIM(out, 1) != mbs_model->nx || start < 0 || start > n_eval) {
        Py_DECREF(t_tmp);
        PyErr_SetString(PyExc_ValueError, "out must be a writable C-contiguous float64 array of shape "
                                          "(len(t_eval), NX) and 0 <= start <= len(t_eval)");
        return NULL;
    }
    if (solver_enter(self)) { Py_DECREF(t_tmp); return NULL; }
    Py_BEGIN_ALLOW_THREADS
    status = mbs_ode_sample(&self->ode, t_eval, n_eval, &start, (double *)PyArray_DATA(out));
    Py_END_ALLOW_THREADS
    self->busy = 0;
    Py_DECREF(t_tmp);
    return Py_BuildValue("il", status, start);
}

/* s.set_events(events, directions, g_start=None): watch the indicators of a model function (its "events"
 * entry); g_start replaces their values at the start (the side an indicator at zero is leaving to) */
static PyObject *solver_set_events(SolverObject *self, PyObject *args)
{
    PyObject *fn_obj, *dir_obj, *dir_tmp, *g0_obj = Py_None, *g0_tmp = NULL;
    FunctionObject *fn;
    npy_intp n;
    if (!PyArg_ParseTuple(args, "O!O|O:set_events", &FunctionType, &fn_obj, &dir_obj, &g0_obj)) return NULL;
    fn = (FunctionObject *)fn_obj;
    if (self->events || self->ode.naccept > 0) {
        PyErr_SetString(PyExc_RuntimeError, "set_events: only once, before the first step");
        return NULL;
    }
    if (fn->entry->cols != 0 || fn->p != ((FunctionObject *)self->function)->p) {
        PyErr_SetString(PyExc_ValueError, "set_events needs a vector function bound to the same workspace");
        return NULL;
    }
    dir_tmp = PyArray_FROMANY(dir_obj, NPY_INT, 1, 1, NPY_ARRAY_CARRAY_RO);
    if (!dir_tmp) return NULL;
    n = PyArray_DIM((PyArrayObject *)dir_tmp, 0);
    if (n != fn->entry->rows) {
        Py_DECREF(dir_tmp);
        PyErr_Format(PyExc_ValueError, "directions must have %d elements", fn->entry->rows);
        return NULL;
    }
    if (mbs_ode_set_events(&self->ode, fn->entry->fn, (int)n, (const int *)PyArray_DATA((PyArrayObject *)dir_tmp))) {
        Py_DECREF(dir_tmp);
        return PyErr_NoMemory();
    }
    if (strcmp(fn->entry->name, "events") == 0)  /* the model's own: its indicators one at a time for the root finding */
        self->ode.indicator = mbs_model->event_indicator;
    Py_DECREF(dir_tmp);
    Py_INCREF(fn_obj);
    self->events = fn_obj;
    if (g0_obj != Py_None) {
        const double *g0 = as_vector(g0_obj, n, "g_start", &g0_tmp);
        if (!g0) return NULL;
        memcpy(self->ode.g_old, g0, (size_t)n * sizeof(double));
        Py_XDECREF(g0_tmp);
    }
    Py_RETURN_NONE;
}

/* s.set_restarts(actions, handled, flag, first, index, slot, capacity, window): apply the events marked in
 * handled (int array per indicator) and restart inside sample() (ode.c, mbs_ode_restart); actions is the
 * model's "event_actions" function or None.  See mbs_ode_set_restarts for the arrays. */
static PyObject *solver_set_restarts(SolverObject *self, PyObject *args)
{
    PyObject *act_obj, *obj[5], *tmp[5] = {NULL, NULL, NULL, NULL, NULL};
    const int *a[5];
    long capacity;
    double window;
    int k, rc = -1, nev = self->ode.nev;
    npy_intp need[5];
    mbs_fn actions = NULL;
    int nvalues = 0;
    if (!PyArg_ParseTuple(args, "OOOOOOld:set_restarts", &act_obj, &obj[0], &obj[1], &obj[2], &obj[3], &obj[4],
                          &capacity, &window)) return NULL;
    if (!self->events) {
        PyErr_SetString(PyExc_RuntimeError, "set_restarts: call set_events first");
        return NULL;
    }
    if (act_obj != Py_None) {
        FunctionObject *fa = (FunctionObject *)act_obj;
        if (!PyObject_TypeCheck(act_obj, &FunctionType) || fa->p != ((FunctionObject *)self->function)->p
            || fa->entry->cols != 0) {
            PyErr_SetString(PyExc_ValueError, "set_restarts needs the event actions bound to the same workspace");
            return NULL;
        }
        actions = fa->entry->fn;
        nvalues = fa->entry->rows;
    }
    for (k = 0; k < 5; k++) {
        tmp[k] = PyArray_FROMANY(obj[k], NPY_INT, 1, 1, NPY_ARRAY_CARRAY_RO);
        if (!tmp[k]) goto done;
        a[k] = (const int *)PyArray_DATA((PyArrayObject *)tmp[k]);
    }
    need[0] = need[1] = nev; need[2] = nev + 1;
    need[3] = need[4] = PyArray_DIM((PyArrayObject *)tmp[2], 0) == nev + 1 ? a[2][nev] : -1;
    for (k = 0; k < 5; k++) {
        if (PyArray_DIM((PyArrayObject *)tmp[k], 0) != need[k]) {
            PyErr_SetString(PyExc_ValueError, "set_restarts: handled and flag need one entry per indicator, first "
                                              "one more, index and slot first[-1]");
            goto done;
        }
    }
    for (k = 0; k < a[2][nev]; k++) {
        if (a[3][k] < 0 || a[3][k] >= mbs_model->np || a[4][k] < 0 || a[4][k] >= nvalues) {
            PyErr_SetString(PyExc_ValueError, "set_restarts: an assignment out of range");
            goto done;
        }
    }
    for (k = 0; k < nev; k++) {
        if (a[1][k] >= mbs_model->np) { PyErr_SetString(PyExc_ValueError, "set_restarts: a flag out of range"); goto done; }
    }
    /* the parameters are the workspace's own array (the FunctionObject keeps it alive): modes change in place */
    if (mbs_ode_set_restarts(&self->ode, (double *)((FunctionObject *)self->function)->p, actions, nvalues, a[0],
                             a[1], a[2], a[3], a[4], capacity, window)) {
        PyErr_NoMemory();
        goto done;
    }
    rc = 0;
done:
    for (k = 0; k < 5; k++) Py_XDECREF(tmp[k]);
    if (rc) return NULL;
    Py_RETURN_NONE;
}

/* s.take_over(old, g_before, g_event): before the first step, go on from the event `old` handed back without a jump
 * of the state (runtime/event_loop.py) with what `old` had learned, as a restart in C would (c/ode.c
 * mbs_ode_take_over) */
static PyObject *solver_take_over(SolverObject *self, PyObject *args)
{
    PyObject *old_obj, *gb_obj, *ge_obj, *gb_tmp = NULL, *ge_tmp = NULL;
    const double *gb, *ge;
    SolverObject *old;
    int nev = self->ode.nev;
    if (!PyArg_ParseTuple(args, "O!OO:take_over", &SolverType, &old_obj, &gb_obj, &ge_obj)) return NULL;
    old = (SolverObject *)old_obj;
    if (old == self || !self->events || old->ode.nev != nev || self->ode.nsteps > 0 || old->busy) {
        PyErr_SetString(PyExc_RuntimeError, "take_over: another solver of the same events, before the first step");
        return NULL;
    }
    if (!(gb = as_vector(gb_obj, nev, "g_before", &gb_tmp))) return NULL;
    if (!(ge = as_vector(ge_obj, nev, "g_event", &ge_tmp))) { Py_XDECREF(gb_tmp); return NULL; }
    mbs_ode_take_over(&self->ode, &old->ode, gb, ge);
    Py_XDECREF(gb_tmp);
    Py_XDECREF(ge_tmp);
    Py_RETURN_NONE;
}

/* s.take_event_log() -> array (events, width): the events handled in C since the last call (see
 * mbs_ode_restarts for the layout of a row), and the log emptied */
static PyObject *solver_take_event_log(SolverObject *self, PyObject *unused)
{
    mbs_ode_restarts *r = self->ode.restarts;
    npy_intp dims[2];
    PyObject *a;
    (void)unused;
    dims[0] = r ? r->count : 0;
    dims[1] = r ? (npy_intp)r->width : 0;
    a = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (a && r && r->count) {
        memcpy(PyArray_DATA((PyArrayObject *)a), r->log, (size_t)r->count * r->width * sizeof(double));
        r->count = 0;
    }
    return a;
}

static PyObject *vector_copy(const double *data, npy_intp n)
{
    PyObject *a = PyArray_SimpleNew(1, &n, NPY_DOUBLE);
    if (a) memcpy(PyArray_DATA((PyArrayObject *)a), data, (size_t)n * sizeof(double));
    return a;
}

static PyObject *solver_get_y(SolverObject *self, void *c) { (void)c; return vector_copy(self->ode.y, mbs_model->nx); }
static PyObject *solver_get_g_old(SolverObject *self, void *c)
{
    (void)c;
    if (!self->ode.nev) Py_RETURN_NONE;
    return vector_copy(self->ode.g_old, self->ode.nev);
}
static PyObject *solver_get_cont(SolverObject *self, void *c)
{
    (void)c;
    if (self->ode.fill_cont) self->ode.fill_cont(&self->ode);
    return vector_copy(self->ode.cont, (npy_intp)self->ode.ncont);
}

static PyObject *solver_get_stats(SolverObject *self, void *c)
{
    const mbs_ode *o = &self->ode;
    (void)c;
    return Py_BuildValue("{sl,sl,sl,sl,sl,sl}", "nfev", o->nfev, "njev", o->njev, "nlu", o->nlu,
                         "nsteps", o->nsteps, "naccept", o->naccept, "nreject", o->nreject);
}

static PyMemberDef solver_members[] = {
    {"t", T_DOUBLE, offsetof(SolverObject, ode.t), READONLY, "current time [s]"},
    {"t_old", T_DOUBLE, offsetof(SolverObject, ode.t_old), READONLY, "start of the last step [s]"},
    {"h", T_DOUBLE, offsetof(SolverObject, ode.h), READONLY, "next step size to try [s]"},
    {"fail_h", T_DOUBLE, offsetof(SolverObject, ode.fail_h), READONLY, "step size at failure [s]"},
    {"status", T_INT, offsetof(SolverObject, ode.status), READONLY, "0 running, 101 finished, >101 failed"},
    {"model_status", T_INT, offsetof(SolverObject, ode.model_status), READONLY, "last non-zero model status"},
    {"stop_on_stiff", T_INT, offsetof(SolverObject, ode.stop_on_stiff), 0, "end the run when stiffness is found"},
    {"stiff", T_INT, offsetof(SolverObject, ode.stiff), READONLY, "1 once an explicit method found stiffness"},
    {"stiff_t", T_DOUBLE, offsetof(SolverObject, ode.stiff_t), READONLY, "when stiffness was found [s]"},
    {"stiff_h", T_DOUBLE, offsetof(SolverObject, ode.stiff_h), READONLY, "the step size then [s]"},
    {"stiff_hlamb", T_DOUBLE, offsetof(SolverObject, ode.stiff_hlamb), READONLY, "h |lambda| estimated then"},
    {NULL, 0, 0, 0, NULL},
};

static PyGetSetDef solver_getset[] = {
    {"y", (getter)solver_get_y, NULL, "copy of the state at t", NULL},
    {"cont", (getter)solver_get_cont, NULL, "copy of the dense-output coefficients of the last step", NULL},
    {"g_old", (getter)solver_get_g_old, NULL, "event indicators at the start of the last step (None without)", NULL},
    {"stats", (getter)solver_get_stats, NULL, "counters: nfev, njev, nlu, nsteps, naccept, nreject", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyMethodDef solver_methods[] = {
    {"step", (PyCFunction)solver_step, METH_NOARGS, "step() -> status: advance by one accepted step"},
    {"budget", (PyCFunction)solver_budget, METH_O, "budget(n): allow n more steps (resumes a run stopped at its "
     "step budget)"},
    {"set_events", (PyCFunction)solver_set_events, METH_VARARGS,
     "set_events(events, directions): locate zero crossings of a model function after every step"},
    {"set_restarts", (PyCFunction)solver_set_restarts, METH_VARARGS,
     "set_restarts(actions, handled, flag, first, index, slot, capacity, window): events restarted in C"},
    {"take_over", (PyCFunction)solver_take_over, METH_VARARGS,
     "take_over(old, g_before, g_event): go on from the event old handed back with what it learned"},
    {"take_event_log", (PyCFunction)solver_take_event_log, METH_NOARGS,
     "take_event_log() -> (events, width) array of the events handled in C since the last call"},
    {"sample", (PyCFunction)solver_sample, METH_VARARGS,
     "sample(t_eval, out, start) -> (status, next): fill out[i] = y(t_eval[i]) for i >= start"},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject SolverType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "mbs_model.Solver",
    .tp_basicsize = sizeof(SolverObject),
    .tp_dealloc = (destructor)solver_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Solver(method, rhs, t0, y0, t_bound, rtol, atol, first_step=0, max_step=0, min_step=0, "
              "max_steps=1000000): an integrator running in C",
    .tp_methods = solver_methods,
    .tp_members = solver_members,
    .tp_getset = solver_getset,
    .tp_new = solver_new,
};

/* ---- module ------------------------------------------------------------------------------------ */

static PyObject *module_init_errors(PyObject *self, PyObject *cls)
{
    (void)self;
    Py_INCREF(cls);
    Py_XSETREF(mbs_error_class, cls);
    Py_RETURN_NONE;
}

static PyMethodDef module_methods[] = {
    {"_init", module_init_errors, METH_O, "_init(error_class): exception type for a model status != 0"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module_def = {
    PyModuleDef_HEAD_INIT, "mbs_model", "A Baukasten model compiled to C.", -1, module_methods,
    NULL, NULL, NULL, NULL,
};

static PyObject *module_create(void)
{
    PyObject *m, *functions, *methods;
    int i;
    import_array();
    if (PyType_Ready(&FunctionType) < 0 || PyType_Ready(&SolverType) < 0) return NULL;
    m = PyModule_Create(&module_def);
    if (!m) return NULL;
    functions = PyTuple_New(mbs_model->table_size);
    methods = PyTuple_New(MBS_METHODS_SIZE);
    if (!functions || !methods) goto fail;
    for (i = 0; i < mbs_model->table_size; i++) {
        const mbs_entry *e = &mbs_model->table[i];
        PyObject *row = e->cols ? Py_BuildValue("(s(ii))", e->name, e->rows, e->cols)
                                : Py_BuildValue("(s(i))", e->name, e->rows);
        if (!row) goto fail;
        PyTuple_SET_ITEM(functions, i, row);
    }
    for (i = 0; i < MBS_METHODS_SIZE; i++) {
        PyObject *name = PyUnicode_FromString(MBS_METHODS[i].name);
        if (!name) goto fail;
        PyTuple_SET_ITEM(methods, i, name);
    }
    if (PyModule_AddObject(m, "FUNCTIONS", functions) < 0) goto fail;
    functions = NULL;
    if (PyModule_AddObject(m, "METHODS", methods) < 0) goto fail;
    methods = NULL;
    Py_INCREF(&FunctionType);
    Py_INCREF(&SolverType);
    if (PyModule_AddObject(m, "Function", (PyObject *)&FunctionType) < 0
        || PyModule_AddObject(m, "Solver", (PyObject *)&SolverType) < 0
        || PyModule_AddIntConstant(m, "NQ", mbs_model->nq) < 0
        || PyModule_AddIntConstant(m, "NV", mbs_model->nv) < 0
        || PyModule_AddIntConstant(m, "NX", mbs_model->nx) < 0 || PyModule_AddIntConstant(m, "NP", mbs_model->np) < 0
        || PyModule_AddIntConstant(m, "NWORK", mbs_model->nwork) < 0
        || PyModule_AddIntConstant(m, "NY", mbs_model->ny) < 0
        || PyModule_AddIntConstant(m, "STATUS_RUNNING", MBS_ODE_RUNNING) < 0)
        goto fail;
    return m;
fail:
    Py_XDECREF(functions);
    Py_XDECREF(methods);
    Py_DECREF(m);
    return NULL;
}

void *mbs_python_module(const char *name, const mbs_model_info *info)
{
    /* the types' qualified names tell which module a function belongs to (runtime/integrators/native.py) */
    static char function_name[200], solver_name[200];
    mbs_huge_text();  /* the library's code on a huge page (c/huge_text.c: the same speed in every process) */
    mbs_model = info;
    snprintf(function_name, sizeof function_name, "%s.Function", name);
    snprintf(solver_name, sizeof solver_name, "%s.Solver", name);
    FunctionType.tp_name = function_name;
    SolverType.tp_name = solver_name;
    module_def.m_name = name;
    return module_create();
}
