/* The glue of the library of a tree's cold functions: those no integrator calls (runtime/translation_units.py
 * COLD_FUNCTIONS: the mass matrix, the forces, the dynamics functions), which a model's fresh compile leaves out
 * (its file defines MBS_COLD_APART) and runtime/build.py build_cold builds from the whole file when one is first
 * called.  Its model.h is the whole file's shared header with their prototypes; the library has its own module,
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
};

/* No right-hand side, Jacobian, outputs nor loops: nothing of this library is integrated. */
static const mbs_model_info MBS_COLD_INFO = {
    MBS_NQ, MBS_NV, MBS_NX, MBS_NP, MBS_NWORK, -1,
    MBS_COLD_TABLE, (int)(sizeof MBS_COLD_TABLE / sizeof MBS_COLD_TABLE[0]),
    NULL, NULL, NULL, NULL, NULL, NULL, NULL,
};

void *mbs_module_init(const char *name);
void *mbs_module_init(const char *name)
{
    return mbs_python_module(name, &MBS_COLD_INFO);
}
