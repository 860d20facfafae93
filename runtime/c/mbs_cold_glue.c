/* The glue of the library of a tree's cold functions: those no integrator calls (runtime/translation_units.py
 * COLD_FUNCTIONS), which a tree's fresh compile leaves out (its file defines MBS_COLD_APART; a compile that asks
 * for the dynamics functions keeps them all: mbs/pipeline.py cold_apart_applies, so the table holds the mass matrix
 * and the forces, runtime/backends.py COLD_APART_FUNCTIONS) and runtime/build.py build_cold builds from the whole
 * file when one is first called.  Its model.h is the whole file's shared header with their prototypes; the library has its own module,
 * with their function table alone, and is called with the model's own parameters and work (the same sizes:
 * runtime/backends.py checks them).  A small unit of the build (build.py _init_unit) calls mbs_module_init.
 */
#if !defined(MBS_NQ) || !defined(MBS_NV) || !defined(MBS_NX) || !defined(MBS_NP) || !defined(MBS_NWORK)
#error "the model must define MBS_NQ, MBS_NV, MBS_NX, MBS_NP and MBS_NWORK"
#endif

#include "mbs_python.h"

/* Rows {name, function, rows, cols[, nin]} as in c/mbs_glue.c. */
static const mbs_entry MBS_COLD_TABLE[] = {
    {"mass_matrix", mbs_mass_matrix, MBS_NV, MBS_NV, 0},
    {"forces", mbs_forces, MBS_NV, 0, 0},
};

/* No right-hand side, Jacobian, outputs nor loops: nothing of this library is integrated. */
static const mbs_model_info MBS_COLD_INFO = {
    MBS_NQ, MBS_NV, MBS_NX, MBS_NP, MBS_NWORK, -1,
    MBS_COLD_TABLE, (int)(sizeof MBS_COLD_TABLE / sizeof MBS_COLD_TABLE[0]),
    NULL, NULL, NULL, NULL, NULL, NULL, NULL, NULL,
};

void *mbs_module_init(const char *name);
void *mbs_module_init(const char *name)
{
    return mbs_python_module(name, &MBS_COLD_INFO);
}
