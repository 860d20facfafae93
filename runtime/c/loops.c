/* Closed kinematic loops at run time: projection of a tree state onto the loop-closure constraints, coordinate
 * partitioning, constrained accelerations by the null-space method, and Lagrange multipliers.
 *
 * Compiled after a generated model that defines MBS_NC > 0 (compiler/ccode_loops.py): the constraint functions
 * mbs_constraints (g, nc rows), mbs_constraint_velocity (gdot = G v + g_t) and mbs_constraint_acceleration
 * (gddot with vdot = 0), the tree functions mbs_mass_matrix, mbs_forces, mbs_qdot, and the sizes MBS_NQ, MBS_NV,
 * MBS_NC, MBS_NQUAT, mbs_quaternion_slots[], MBS_TREE_NWORK and MBS_LOOP_NWORK.
 *
 * The state x = [q; v] stays the spanning tree's.  Every function below has the one model signature
 * f(t, x, p, out, work), allocates nothing, and returns a status: 0 ok, 1 singular reduced mass matrix,
 * 2 non-finite value, 3 the constraints cannot be satisfied (mbs_loop_report tells where).  Everything lives in
 * the caller's work array of MBS_NWORK doubles; the one thing kept there from call to call is the partition
 * (below), so each workspace has its own:
 *
 *   mbs_loop_rhs         x' = [qdot(q_c, v_c); vdot] at the projected state x_c      (NX)
 *   mbs_loop_rhs_direct  x' at x itself, no projection (the same where x is on the constraints)      (NX)
 *   mbs_project          x_c: q by Newton iterations on the dependent coordinates, then v      (NX)
 *   mbs_loop_project_step  mbs_project of DOPRI5's accepted state from the factors its last stage left    (NX)
 *   mbs_loop_accept      [mbs_loop_rhs_direct; mbs_loop_project_step] at x: a step's end, for timing   (2 NX)
 *   mbs_loop_multipliers lambda with M vdot = f + G^T lambda at x_c (0 for redundant rows)   (NC)
 *   mbs_loop_rates       [x'; lambda] at x_c from one projection and one solve (the outputs)   (NX + NC)
 *   mbs_loop_jacobian    G = d(gdot)/dv at the positions of x, no projection        (NC x NV, row-major)
 *   mbs_loop_normalize   x with unit quaternions                                    (NX)
 *   mbs_loop_report      the projection's diagnostics, always status 0        (MBS_LOOP_NREPORT, see below)
 *
 * G comes from mbs_constraint_matrix when the model defines MBS_CONSTRAINT_MATRIX (d gdot / d v printed from the
 * tape, compiler/ccode_loops.py); otherwise from evaluations of gdot: column j is gdot(e_j) - gdot(0), and
 * columns that share no row (one loop's against another's) come from one evaluation (the colouring of
 * compiler/jacobian_colours.py, MBS_NCOLOUR).  Loops that close below a body are written relative to it
 * (compiler/relative_motion.py), so independent loops give G exact zeros outside their own columns; the
 * factorisations, the triangular solves and the null-space basis T (stored by its nonzeros) skip them, so the
 * cost follows the loops' own sizes rather than NC x NV.
 *
 * Partitioning: the pivot columns of G are the dependent velocities, the others independent.  A partition is
 * kept from call to call and G factored with it (row exchanges among its pivot rows only) while its smallest
 * relative pivot stays above MBS_LOOP_KEEP_RATIO times its value when chosen; when it degrades, Gaussian
 * elimination with complete pivoting chooses afresh, and the new partition is kept when the caller is between
 * steps (the projection of an accepted state, the projecting rhs), so that x' does not jump within a step.
 * Elimination stops at the first pivot below MBS_LOOP_RANK_TOL times the largest entry of G: the rank r,
 * DOF = nv - r; the rows not chosen as pivot rows are redundant and dropped (they hold when the redundancy is
 * consistent; mbs_loop_rows_hold checks that on the accelerations and chooses afresh when they do not).
 *
 * Singular positions (a four-bar stretched flat: the rank of G drops where two branches of motion cross) are
 * told from rows redundant everywhere by the rank a little way along the allowed motion; there the accelerations
 * are those of the limit of the motion through the position (mbs_loop_singular_rows), and such a partition is
 * never kept.  So is a band around such a position (pivots between MBS_LOOP_RANK_TOL and MBS_LOOP_BAND_TOL
 * whose rank returns a little further along the motion): there the rows with small pivots fix the
 * accelerations as the ratio of two small numbers, and the round-off of the positions bends them by about
 * 1e-15 / d^3 at the distance d (docs/numerics.md, "Closed loops through singular positions"); the band drops
 * those rows from the velocities and takes the limit rows for the accelerations, while the position Newton
 * keeps all rows (w->newton).
 *
 * Newton on positions: dq = qdot(q, dv) with dv_I = 0 and G_D dv_D = -g (the pivot rows), quaternions
 * renormalised after each update; the Jacobian is refreshed when the residual falls by less than a factor
 * MBS_LOOP_SLOW per iteration.  Converged when max |g| <= MBS_LOOP_TOL, or at the round-off floor.
 *
 * Accelerations: vdot = T a + c0 with T = [I; -G_D^-1 G_I] (in pivot order), c0_I = 0, G_D c0_D = -gddot0;
 * (T^T M T) a = T^T (f - M c0).  T^T M T is factored as L D L^T; a pivot below MBS_LOOP_MASS_TOL times the
 * largest diagonal entry is a motion without inertia (a massless part spinning about its own axis) whose
 * acceleration is set to 0.  M may be singular (massless parts): only T^T M T must be definite on the motions
 * that carry mass.  With the kept partition (w->blocked) every step follows its plan's blocks: G gathered at its
 * structural nonzeros, each block factored with gddot0's forward substitution riding along when it is at hand,
 * T's columns and c0 from each block's U11 in one pass, and T^T M T in the plan's order of columns (the loops'
 * independent velocities, then those no loop moves, whose entries are M's) with exact zeros between the blocks of
 * loops that M does not couple (mbs_loop_blocks_coupled).  The same arithmetic in the same order as before these
 * (the same bits), in fewer instructions: the Iltis's loop_rhs 50,000 a call against 52,700 (bench/rhs_instructions.py
 * --baseline with the former runtime/c).  Each block's kernels (its elimination, the solves and multipliers) are
 * inlined with the block's size a constant for 6 rows, the Iltis corner's (MBS_LOOP_BY_SIZE), their loops unrolled:
 * the same arithmetic again, the loop algebra of a bump_10 rhs 17,023 -> 15,868 instructions and the projection of
 * an accepted step 15,706 -> 13,873 (bench/loop_work.py --baseline).  Then M T_j of a block's column of T by the
 * plan's chunks of 4 columns (mbs_loop_plan_mass_chunks) in vector registers, T^T M T's L D L^T by columns
 * (mbs_loop_reduced_factor), the gather of G and the copies into T and c0 with less control: the same bits again
 * (exact zeros added or not), the loop algebra of a bump_10 rhs 14,744 -> 11,981 instructions (the kept factors of G
 * 4,184 -> 3,716, the rest 9,132 -> 7,139), a whole simulate 344.5 M -> 328.9 M (bench/loop_work.py --baseline).
 * Then T^T M T's L D L^T and solve with its size a constant (NV - NC, MBS_LOOP_BY_REDUCED_SIZE), its columns of the
 * loops' blocks, M T_j, vdot and the null space's back substitutions with T_j's size a constant, T's pattern kept
 * with the plan, the pivots' quotients taken once: the same bits, the loop algebra of a bump_10 rhs 11,986 -> 9,097
 * instructions (the kept factors 3,717 -> 3,636, the rest 7,144 -> 4,705), the rhs 32,121 -> 29,233, a whole
 * simulate 281.4 M -> 263.6 M (bench/loop_work.py --baseline --simulate), the code of mbs_loop_accelerations 11 -> 28
 * kB; loop_rhs's CPU time over fresh copies of each library 0.96 and 0.996 of the former's in two runs
 * (bench/rhs_placement.py, medians of 20 rounds; the same build against itself 0.99): within the pages' luck.
 *
 * Left alone, the integrated state would drift off the constraints by the integration error (the derivative
 * of its distance from x_c is zero, not negative).  The C integrators therefore replace every accepted state
 * by mbs_project(x) (ode.c, mbs_ode_accept; the glue switches it on for this rhs; for DOPRI5 it is
 * mbs_loop_project_step, which reuses the factors of G its last stage left at that state), and the driver stores
 * mbs_project(x) at output points.  For integrators that cannot project (scipy's), compiling with
 * -DMBS_LOOP_STABILIZE=k (a rate in 1/s, e.g. 10) adds k (x_c - x) to x', which leaves the motion on the
 * constraints unchanged and pulls the drift back.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#if !defined(MBS_NC) || !defined(MBS_NQUAT) || !defined(MBS_TREE_NWORK) || !defined(MBS_LOOP_NWORK) \
    || !defined(MBS_NCOLOUR)
#error "loops.c needs a model with loops: MBS_NC, MBS_NQUAT, MBS_TREE_NWORK, MBS_LOOP_NWORK, MBS_NCOLOUR"
#endif

/* Doubles of work beyond the tree functions' (compiler/ccode_loops.py: loop_work_size, the same formula). */
#define MBS_LOOP_NWORK_NEEDED (4 * MBS_NV * MBS_NV + 3 * MBS_NC * MBS_NV + 7 * MBS_NC + 2 * MBS_NX \
                               + 10 * MBS_NV + MBS_NQ + 4 + 16 + MBS_LOOP_STAMP_SIZE + MBS_LOOP_PLAN_SIZE)
/* The stamp of the factors mbs_loop_rhs_direct leaves (mbs_loop_stamp_store): marker, t, the drift an accepted step
 * keeps (mbs_loop_step_drift: not part of the stamp, which leaves it alone), rank, q, p. */
#define MBS_LOOP_STAMP_SIZE (MBS_NQ + MBS_NP + 4)
/* The plan of the kept partition's independent blocks (mbs_loop_plan_build): a marker, a copy of the kept
 * partition (MBS_LOOP_KEEP_SIZE = 4 + NV + NC, defined below), then at most 6 + 12 NC + 4 NV + 2 NC NV ints in
 * the room of 3 + 6 NC + 2 NV + NC NV doubles (mbs_loop_blocks; 8 NC of the ints: 1 + MBS_LOOP_MASS_CHUNKS a block; the
 * last NV the offsets of T's columns). */
#define MBS_LOOP_PLAN_SIZE (1 + (4 + MBS_NV + MBS_NC) + 3 + 6 * MBS_NC + 2 * MBS_NV + MBS_NC * MBS_NV)
#define MBS_LOOP_MASS_CHUNKS 7
#if MBS_LOOP_NWORK < MBS_LOOP_NWORK_NEEDED || MBS_NWORK < MBS_TREE_NWORK + MBS_LOOP_NWORK
#error "MBS_NWORK is too small for the loop solver"
#endif

/* Newton tolerance on max |g| [m or rad]: absolute, since angle coordinates grow without bound. */
#define MBS_LOOP_TOL 1e-12
/* Below this residual an iteration (with a fresh Jacobian) that no longer halves it has reached the round-off
 * floor (positions far from the origin): converged. */
#define MBS_LOOP_FLOOR 1e-9
/* A converged projection above this residual takes more (simplified) Newton steps while they halve it ... */
#define MBS_LOOP_POLISH 1e-15
/* ... at most this many. */
#define MBS_LOOP_POLISH_STEPS 3
/* Iteration cap of the position projection (a converging Newton run takes 2-5). */
#define MBS_LOOP_MAXIT 30
/* Refresh the Jacobian when an iteration reduces the residual by less than this factor. */
#define MBS_LOOP_SLOW 0.25
/* Pivots below this fraction of the largest |G_ij| count as zero: rank deficiency (redundant rows or a
 * bifurcation point); exactly redundant rows leave pivots near 1e-16, genuine ones stay far above. */
#define MBS_LOOP_RANK_TOL 1e-9
/* The band around a singular position: pivots of G below this fraction of max |G_ij| (above
 * MBS_LOOP_RANK_TOL) where the rank returns a little way along the motion (MBS_LOOP_BAND_PROBE in the largest
 * coordinate).  Within it the rows with such pivots are treated as at the singular position (the limit rows
 * of mbs_loop_singular_rows): their own second derivatives amplify the round-off of the positions by the
 * inverse cube of the distance from the singular position (see mbs_loop_partition). */
#ifndef MBS_LOOP_BAND_TOL
#define MBS_LOOP_BAND_TOL 1e-3
#endif
#define MBS_LOOP_BAND_PROBE (10.0 * MBS_LOOP_BAND_TOL)
/* Pivots of T^T M T below this fraction of its largest diagonal entry are motions without inertia. */
#define MBS_LOOP_MASS_TOL 1e-12
/* The rows a partition drops hold on its accelerations to this fraction of the size of their terms. */
#define MBS_LOOP_ROWS_HOLD 1e-6
/* -DMBS_LOOP_ROWS_FORMER=1: the former rows of a run (bench/bump_cost.py): each projected afresh by mbs_project,
 * and the multipliers solved over the whole factors rather than block by block (mbs_loop_lambda). */
#ifndef MBS_LOOP_ROWS_FORMER
#define MBS_LOOP_ROWS_FORMER 0
#endif
/* -DMBS_LOOP_LAMBDA_FORMER=1: the multipliers' rows of M times vdot over all NV columns (bench/bump_cost.py
 * --former lambda), instead of over the structural nonzeros of M (mbs_loop_lambda). */
#ifndef MBS_LOOP_LAMBDA_FORMER
#define MBS_LOOP_LAMBDA_FORMER 0
#endif
/* An accepted step whose positions drifted off the constraints by more than MBS_LOOP_TOL but at most this is polished
 * with the factors of G its last stage left at these very positions (Newton's steps, converging quadratically from
 * there) and held to MBS_LOOP_TOL after them, instead of projected afresh by mbs_project (a fresh Jacobian and
 * partition): the Iltis over the bump at 10 m/s drifts by 1e-12 to 1e-10 in one accepted step in eight, each
 * projected afresh for 41,000 instructions against about 20,000.  -DMBS_MACHINERY_FORMER=1: every drift above
 * MBS_LOOP_TOL projected afresh (bench/event_instructions.py --machinery). */
#ifdef MBS_MACHINERY_FORMER
#define MBS_LOOP_STEP_DRIFT MBS_LOOP_TOL
#else
#define MBS_LOOP_STEP_DRIFT 1e-9
#endif
/* ... and one that drifted by at most this keeps its positions (its velocities are made consistent with them): the
 * polish took a residual of 1e-16 to 1e-13, one accepted step's drift, down to the round-off floor for some 6,000
 * instructions a step.  Not up to MBS_LOOP_TOL: keeping drifts of up to 1e-12 saved 0.9 % of a bump_10 simulate but
 * raised the round-off floor of DOPRI5 at rtol 1e-10 through the 40 four-bars' flat positions (the median crank
 * error of tests/runtime/test_fourbar_chain.py's five round-off starts 3.7e-6 -> 8.6e-5 rad, above the 1e-8 run's
 * 3.3e-5).  -DMBS_MACHINERY_FORMER=1: every accepted step polished. */
#ifdef MBS_MACHINERY_FORMER
#define MBS_LOOP_STEP_KEPT 0.0
#else
#define MBS_LOOP_STEP_KEPT 1e-13
#endif
/* ... or, where the run's integrator told its tolerances (mbs_loop_step_drift: the glue's Solver), by at most this
 * fraction of its smallest atol when that is more (at most MBS_LOOP_STEP_KEPT_MAX), with a kept partition clear of
 * singular positions (MBS_LOOP_STEP_KEPT_PIVOT): a drift two orders below what each step's error test lets through in
 * any coordinate changes nothing the run resolves.  The Iltis over the bump at 10 m/s (atol 2e-9: 2e-11 kept)
 * polished 2,527 of its 3,685 accepted steps, now 657 of 3,692: the projection of a step 7,695 -> 5,426
 * instructions, a whole simulate 0.977 of its instructions (`python bench/loop_work.py --former kept --simulate`); its
 * errors against a tight reference the same within the spread of tolerances a hair apart (`--accuracy --scales ...`,
 * the mean of the columns' median errors: over 40 such runs 0.95 of the former's, each run's between 2.5e-6 and
 * 8.7e-6; with DOPRI5 at rtol 1e-7, atol 1e-9 over 24, `--dopri5`, 1.00; bump_5, atol 2e-10, over 24, 0.97).  A
 * thousandth of atol saved 0.9 % of the simulate (its errors 1.06 of the former's over the 40 runs).  The integrated
 * state stays within this drift of the constraints instead of 1e-12 (tests/runtime/test_loops.py).
 * -DMBS_LOOP_STEP_KEPT_ATOL=0: MBS_LOOP_STEP_KEPT alone. */
#ifndef MBS_LOOP_STEP_KEPT_ATOL
#ifdef MBS_MACHINERY_FORMER
#define MBS_LOOP_STEP_KEPT_ATOL 0.0
#else
#define MBS_LOOP_STEP_KEPT_ATOL 1e-2
#endif
#endif
#define MBS_LOOP_STEP_KEPT_MAX 1e-10
/* ... and only with a kept partition whose smallest relative pivot was at least this when chosen (keep[2]; at least a
 * tenth of it while kept): near a singular position a drift d of the positions bends the accelerations by about
 * d / pivot^3 (docs/numerics.md), and Adams evaluates its f at the projected states (DOPRI5's stages lie off the
 * constraints anyway).  The 40 four-bars (pivots of 2e-3) keeping drifts of 1e-11 at atol 1e-8 had Adams' median
 * crank error over 11 round-off starts 7.4e-3 rad against 2.7e-3 polished (DOPRI5's 6.1e-3 either way:
 * `python bench/kept_drift.py`, its build `ungated`); the Iltis's pivots are 0.35.  -DMBS_LOOP_STEP_KEPT_PIVOT=0:
 * every kept partition. */
#ifndef MBS_LOOP_STEP_KEPT_PIVOT
#define MBS_LOOP_STEP_KEPT_PIVOT 0.1
#endif
/* A row of the results (mbs_loop_project_row) within this of the position constraints keeps its positions as an
 * accepted step does (its velocities and accelerations are solved at them), where the polish took them to the
 * round-off floor with the previous row's factors: the Iltis over the bump at 10 m/s, two rows in three of those
 * polished, for 6,400 instructions each.  The rows feed nothing back into the run; they are mbs_project's to
 * round-off, which holds for a residual of 1e-13 (as for an accepted step, MBS_LOOP_STEP_KEPT).
 * -DMBS_LOOP_ROW_POLISH_FORMER=1: every row polished (bench/loop_work.py). */
#ifdef MBS_MACHINERY_FORMER
#define MBS_LOOP_ROW_KEPT 0.0
#else
#define MBS_LOOP_ROW_KEPT 1e-13
#endif
#ifndef MBS_LOOP_ROW_POLISH_FORMER
#define MBS_LOOP_ROW_POLISH_FORMER 0
#endif
/* -DMBS_LOOP_RECHECK_FORMER=1: the constraints evaluated once more after the polish of an accepted step that drifted
 * beyond MBS_LOOP_TOL, where its last Newton step left their residual at those very positions (bench/loop_work.py). */
#ifndef MBS_LOOP_RECHECK_FORMER
#define MBS_LOOP_RECHECK_FORMER 0
#endif

/* The projections of an accepted step and of a row end with the residuals g and their rate gdot = G v + g_t at the
 * same positions: where the model has mbs_constraints_with_velocity (compiler/ccode_loops.py), the evaluations that
 * may be the last give both from one pass over the kinematics, the sines and cosines of the loops' angles once
 * (mbs_loop_residuals).  -DMBS_LOOP_RATES_FORMER=1: g and gdot each from its own function. */
#ifndef MBS_LOOP_RATES_FORMER
#define MBS_LOOP_RATES_FORMER 0
#endif
#if defined(MBS_CONSTRAINTS_WITH_VELOCITY) && MBS_NV >= 2 && !MBS_LOOP_RATES_FORMER  /* (gdot in the room of K) */
#define MBS_LOOP_RATES 1
#else
#define MBS_LOOP_RATES 0
#endif

/* ... and a row's too where G comes from mbs_constraint_matrix, which has no g_t: the row then needs no
 * mbs_constraint_velocity at v = 0 for it (with G from evaluations of gdot, g_t comes with them). */
#if MBS_LOOP_RATES && defined(MBS_CONSTRAINT_MATRIX)
#define MBS_LOOP_ROW_RATES 1
#else
#define MBS_LOOP_ROW_RATES 0
#endif

#define MBS_LOOP_SINGULAR 1
#define MBS_LOOP_NONFINITE 2
#define MBS_LOOP_NOT_ASSEMBLED 3

#ifndef MBS_LOOP_STABILIZE
#define MBS_LOOP_STABILIZE 0  /* rate [1/s] at which x' pulls the integrated state onto x_c (0: off) */
#endif

/* mbs_loop_report: status, Newton iterations, max |g| before and after, worst row (-1: none), rank, DOF,
 * Jacobian evaluations, then the velocity columns in pivot order (the first `rank` are dependent). */
#define MBS_LOOP_NREPORT (8 + MBS_NV)

typedef struct {
    double *tree;               /* MBS_TREE_NWORK: work of the generated functions */
    double *G;                  /* NC x NV: the constraint Jacobian, then its factors (rows, columns permuted) */
    double *G0, *K;             /* NC x NV each: a copy of G; its rate along the motion (singular positions) */
    double *rp, *cp;            /* NC, NV: original row / column at each pivot position (stored as doubles) */
    double *rp2, *cp2;          /* NC, NV: the same for the probe of the generic rank (mbs_loop_generic_rank) */
    double *xc, *xt;            /* NX each: the projected state, a scratch state for evaluations */
    double *g, *h, *y, *c3;     /* NC each: residuals, g_t or gddot0, solve scratch, third-order rates */
    double *dv, *f, *c0, *b, *a, *vd;  /* NV each */
    double *dq;                 /* NQ */
    double *M, *A, *T;          /* NV x NV each: mass matrix, reduced mass matrix, null-space basis (packed) */
    int *Ti;                    /* NV x NV ints: the velocity of each packed entry of T */
    double *keep;               /* the partition kept between calls (see mbs_loop_keep_*) */
    double *stamp;              /* the state whose factors w->G holds after mbs_loop_rhs_direct (mbs_loop_stamp_*) */
    double *plan;               /* the blocks of the kept partition (mbs_loop_plan_build), kept between calls */
    int blocked;                /* w->G holds the factors of the kept partition, block by block (its plan) */
    int terms;                  /* M, f, G0 and h = gddot0 hold at w->xc (mbs_loop_terms_at, used once) */
    int forward;                /* w->y holds L11^-1 (-gddot0) on the pivot rows, from the blocks' elimination
                                 * (mbs_loop_factor_blocks, when w->terms), for mbs_loop_null_space_blocks */
    int fresh;                  /* the last factors came from complete pivoting (not the kept partition) */
    int singular;               /* ... and their rank is below that of the positions around (a singular one),
                                 * or they are in the band around one (mbs_loop_partition) */
    int rband;                  /* the leading pivots of the last complete pivoting above MBS_LOOP_BAND_TOL */
    int newton;                 /* the position projection is iterating: the band keeps the full rank */
    double pivot;               /* the smallest pivot of the last factors relative to max |G| */
} mbs_loop_work;

typedef struct {
    int status, iterations, worst, rank, jacobians, refreshed, singular;
    double residual0, residual;
} mbs_loop_info;

/* The kept partition, the one piece of state the loop functions carry from call to call (in the caller's work,
 * so one per workspace): keep[0] a marker (valid when equal to MBS_LOOP_KEEP_MARK), keep[1] its rank r,
 * keep[2] the smallest relative pivot when it was chosen, keep[3] 1 when all its pivots were above
 * MBS_LOOP_BAND_TOL then (0: a mechanism whose regular positions have smaller ones), then the NV columns in pivot
 * order (the first r dependent) and the r pivot rows.  Anything else
 * (zeroed or overwritten work) reads as "no partition" and is chosen afresh. */
#define MBS_LOOP_KEEP_MARK 1517.0
#define MBS_LOOP_KEEP_SIZE (4 + MBS_NV + MBS_NC)
/* Keep the partition while its smallest relative pivot stays above this fraction of its value when chosen
 * (the hysteresis: a fresh choice happens only when the dependent block has clearly degraded). */
#define MBS_LOOP_KEEP_RATIO 0.1

static inline mbs_loop_work mbs_loop_layout_keeping(double *work)
{
    mbs_loop_work w;
    double *s = work + MBS_TREE_NWORK;
    w.tree = work;
    w.fresh = w.singular = w.rband = w.newton = w.blocked = w.terms = w.forward = 0;
    w.pivot = 0.0;
    w.keep = s; s += MBS_LOOP_KEEP_SIZE;
    w.M = s; s += MBS_NV * MBS_NV;  /* [M; f; G0; h] in a row: what mbs_loop_terms writes */
    w.f = s; s += MBS_NV;
    w.G0 = s; s += MBS_NC * MBS_NV;
    w.h = s; s += MBS_NC;
    w.G = s; s += MBS_NC * MBS_NV;
    w.K = s; s += MBS_NC * MBS_NV;
    w.rp = s; s += MBS_NC;
    w.cp = s; s += MBS_NV;
    w.rp2 = s; s += MBS_NC;
    w.cp2 = s; s += MBS_NV;
    w.xc = s; s += MBS_NX;
    w.xt = s; s += MBS_NX;
    w.g = s; s += MBS_NC;
    w.y = s; s += MBS_NC;
    w.c3 = s; s += MBS_NC;
    w.dv = s; s += MBS_NV;
    w.c0 = s; s += MBS_NV;
    w.b = s; s += MBS_NV;
    w.a = s; s += MBS_NV;
    w.vd = s; s += MBS_NV;
    w.dq = s; s += MBS_NQ;
    w.A = s; s += MBS_NV * MBS_NV;
    w.T = s; s += MBS_NV * MBS_NV;
    w.Ti = (int *)s;  /* NV * NV ints in the room of NV * NV doubles */
    s += MBS_NV * MBS_NV;
    w.stamp = s; s += MBS_LOOP_STAMP_SIZE;
    w.plan = s;
    return w;
}

/* The layout of every exported function but mbs_loop_project_step: any of them may overwrite the factors of G,
 * so the stamp of mbs_loop_rhs_direct is void after it. */
static mbs_loop_work mbs_loop_layout(double *work)
{
    mbs_loop_work w = mbs_loop_layout_keeping(work);
    w.stamp[0] = 0.0;
    return w;
}

static double mbs_loop_maxabs(const double *a, int n, int *where)
{
    double m = 0.0;
    int i;
    if (!where) {  /* nobody asks where: four independent chains without a branch (as mbs_loop_gmax), the loop below
                    * only for a value that is not finite (which it tells: the first NaN, or infinity) */
        double c[4] = {0.0, 0.0, 0.0, 0.0}, probe[4] = {0.0, 0.0, 0.0, 0.0};
        int k;
        for (i = 0; i + 4 <= n; i += 4)
            for (k = 0; k < 4; k++) {
                const double e = fabs(a[i + k]);
                c[k] = e > c[k] ? e : c[k];
                probe[k] += 0.0 * e;
            }
        for (; i < n; i++) {
            const double e = fabs(a[i]);
            c[0] = e > c[0] ? e : c[0];
            probe[0] += 0.0 * e;
        }
        if ((probe[0] + probe[1]) + (probe[2] + probe[3]) == 0.0) {
            c[0] = c[1] > c[0] ? c[1] : c[0];
            c[2] = c[3] > c[2] ? c[3] : c[2];
            return c[2] > c[0] ? c[2] : c[0];
        }
    }
    if (where) *where = -1;
    for (i = 0; i < n; i++) {
        if (!(fabs(a[i]) <= m)) {  /* NaN wins, so that it is reported */
            m = fabs(a[i]);
            if (where) *where = i;
            if (m != m) return m;
        }
    }
    return m;
}

/* Are all n entries of a finite?  (0 x is 0 for a finite x, NaN for an infinite one or NaN: no branch per entry,
 * where mbs_loop_maxabs, which also says where, takes one.)  Four independent sums, which the compiler makes one
 * vector's (a single running sum of zeros keeps its order: one scalar product and sum an entry). */
static int mbs_loop_finite(const double *a, int n)
{
    double probe[4] = {0.0, 0.0, 0.0, 0.0};  /* four independent chains (as mbs_loop_gmax): NaN reaches the sum */
    int i, k;
    for (i = 0; i + 4 <= n; i += 4)
        for (k = 0; k < 4; k++) probe[k] += 0.0 * a[i + k];
    for (; i < n; i++) probe[0] += 0.0 * a[i];
    return (probe[0] + probe[1]) + (probe[2] + probe[3]) == 0.0;
}

/* y += x (n entries, apart): in fours, which the compiler puts in vector registers, where a plain loop of a length not
 * a multiple of the vectors' stays scalar at -O2 (the same sums). */
static inline void mbs_loop_add(double *restrict y, const double *restrict x, int n)
{
    int i, k;
    for (i = 0; i + 4 <= n; i += 4)
        for (k = 0; k < 4; k++) y[i + k] += x[i + k];
    for (; i < n; i++) y[i] += x[i];
}

/* Unit quaternions in the position part of x. */
static void mbs_loop_normalize_q(double *x)
{
    int k;
    for (k = 0; k < MBS_NQUAT; k++) {
        double *e = x + mbs_quaternion_slots[k];
        double n = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3]);
        if (n > 0.0) { e[0] /= n; e[1] /= n; e[2] /= n; e[3] /= n; }
    }
}

/* Gout (NC x NV) and hout = g_t at the positions of x: gdot is affine in v, so column j is gdot(e_j) - gdot(0),
 * and columns of one colour (sharing no row, compiler/jacobian_colours.py) come from one evaluation. */
static int mbs_loop_jacobian_into(double t, const double *x, const double *p, mbs_loop_work *w, double *Gout,
                                  double *hout)
{
    int i, j, c, s;
    if (x != w->xt) memcpy(w->xt, x, MBS_NQ * sizeof(double));
    memset(w->xt + MBS_NQ, 0, MBS_NV * sizeof(double));
#ifdef MBS_CONSTRAINT_MATRIX  /* G generated (d gdot / d v on the tape): one call */
    (void)i; (void)j; (void)c;
    if (hout != NULL && (s = mbs_constraint_velocity(t, w->xt, p, hout, w->tree)) != 0) return s;
    return mbs_constraint_matrix(t, w->xt, p, Gout, w->tree);
#endif
    if (hout == NULL) hout = w->c3;
    memset(Gout, 0, MBS_NC * MBS_NV * sizeof(double));
    if ((s = mbs_constraint_velocity(t, w->xt, p, hout, w->tree)) != 0) return s;
    for (c = 0; c < MBS_NCOLOUR; c++) {
        for (j = 0; j < MBS_NV; j++) w->xt[MBS_NQ + j] = mbs_column_colour[j] == c ? 1.0 : 0.0;
        if ((s = mbs_constraint_velocity(t, w->xt, p, w->y, w->tree)) != 0) return s;
        for (i = 0; i < MBS_NC; i++) {
            j = mbs_colour_column[i * MBS_NCOLOUR + c];
            if (j >= 0) Gout[i * MBS_NV + j] = w->y[i] - hout[i];
        }
    }
    memset(w->xt + MBS_NQ, 0, MBS_NV * sizeof(double));
    return 0;
}

/* G (NC x NV) at the positions of x into w->G0 (each factorisation takes what it needs from there into w->G),
 * and h = g_t there when `rate` (only the velocity projection reads it; the accelerations replace h by gddot0). */
static int mbs_loop_jacobian_at(double t, const double *x, const double *p, mbs_loop_work *w, int rate)
{
    return mbs_loop_jacobian_into(t, x, p, w, w->G0, rate ? w->h : NULL);
}

static double mbs_loop_gmax(const mbs_loop_work *w)
{
    /* every call runs this: comparisons, not the library's fmax, and four independent chains (a single running
     * maximum and sum would wait for each other's latency at every entry); probe stays 0 unless an entry is
     * infinite or NaN */
    double m[4] = {0.0, 0.0, 0.0, 0.0}, probe[4] = {0.0, 0.0, 0.0, 0.0};
    int i, k;
    for (i = 0; i + 4 <= MBS_NC * MBS_NV; i += 4)
        for (k = 0; k < 4; k++) {
            const double a = fabs(w->G0[i + k]);
            m[k] = a > m[k] ? a : m[k];
            probe[k] += 0.0 * w->G0[i + k];
        }
    for (; i < MBS_NC * MBS_NV; i++) {
        const double a = fabs(w->G0[i]);
        m[0] = a > m[0] ? a : m[0];
        probe[0] += 0.0 * w->G0[i];
    }
    if (!(probe[0] + probe[1] + probe[2] + probe[3] == 0.0)) return -1.0;
    m[0] = m[1] > m[0] ? m[1] : m[0];
    m[2] = m[3] > m[2] ? m[3] : m[2];
    return m[2] > m[0] ? m[2] : m[0];
}

/* Exchange rows k and pi of the factors w->G and their original indices rp. */
static void mbs_loop_swap_rows(mbs_loop_work *w, int k, int pi)
{
    double *A = w->G, tmp;
    int j;
    for (j = 0; j < MBS_NV; j++) {
        tmp = A[k * MBS_NV + j]; A[k * MBS_NV + j] = A[pi * MBS_NV + j]; A[pi * MBS_NV + j] = tmp;
    }
    tmp = w->rp[k]; w->rp[k] = w->rp[pi]; w->rp[pi] = tmp;
}

/* One elimination step with pivot A[k][k]: rows k+1 .. rows-1 lose their column k (multipliers stored there). */
static void mbs_loop_eliminate(double *A, int k, int rows)
{
    int i, j, n = -1, nz[MBS_NV];
    for (i = k + 1; i < rows; i++) {
        double l;
        if (A[i * MBS_NV + k] == 0.0) continue;  /* another loop's row (independent blocks): nothing to do */
        if (n < 0)  /* the pivot row's nonzero columns, listed once (a loop's row touches a few columns), */
            for (n = 0, j = k + 1; j < MBS_NV; j++) {  /* without a branch per entry */
                nz[n] = j;
                n += A[k * MBS_NV + j] != 0.0;
            }
        l = A[i * MBS_NV + k] /= A[k * MBS_NV + k];
        for (j = 0; j < n; j++) A[i * MBS_NV + nz[j]] -= l * A[k * MBS_NV + nz[j]];
    }
}

static void mbs_loop_plan_dirty(const mbs_loop_work *w);

/* Gaussian elimination with complete pivoting of G in place (rows and columns physically exchanged; rp, cp
 * record the original indices).  Returns the rank, or -1 if G is not finite; *minpivot: the smallest pivot
 * relative to max |G|. */
static int mbs_loop_factor(mbs_loop_work *w, double *minpivot)
{
    double *A = w->G, amax0 = mbs_loop_gmax(w);
    int i, j, k, r = 0;
    *minpivot = 0.0;
    w->rband = 0;
    w->blocked = w->forward = 0;
    mbs_loop_plan_dirty(w);
    if (amax0 < 0.0) return -1;
    for (i = 0; i < MBS_NC; i++) w->rp[i] = i;
    for (j = 0; j < MBS_NV; j++) w->cp[j] = j;
    for (k = 0; k < MBS_NC && k < MBS_NV; k++) {
        int pi = k, pj = k;
        double amax = 0.0, tmp;
        for (i = k; i < MBS_NC; i++)
            for (j = k; j < MBS_NV; j++)
                if (fabs(A[i * MBS_NV + j]) > amax) { amax = fabs(A[i * MBS_NV + j]); pi = i; pj = j; }
        if (!(amax > MBS_LOOP_RANK_TOL * amax0)) break;
        *minpivot = k == 0 ? amax / amax0 : fmin(*minpivot, amax / amax0);
        if (w->rband == k && amax >= MBS_LOOP_BAND_TOL * amax0) w->rband = k + 1;
        if (pi != k) mbs_loop_swap_rows(w, k, pi);
        if (pj != k) {
            for (i = 0; i < MBS_NC; i++) {
                tmp = A[i * MBS_NV + k]; A[i * MBS_NV + k] = A[i * MBS_NV + pj]; A[i * MBS_NV + pj] = tmp;
            }
            tmp = w->cp[k]; w->cp[k] = w->cp[pj]; w->cp[pj] = tmp;
        }
        mbs_loop_eliminate(A, k, MBS_NC);
        r++;
    }
    return r;
}

/* Is w->keep a partition (marker, rank in range, columns a permutation, rows distinct and in range)? */
static int mbs_loop_plan_holds(const mbs_loop_work *w);

static int mbs_loop_keep_valid(const mbs_loop_work *w)
{
    const double *kp = w->keep;
    int r, j, seen = 0;
    if (kp[0] != MBS_LOOP_KEEP_MARK) return 0;
    if (mbs_loop_plan_holds(w)) return 1;  /* checked when its plan was made */
    r = (int)kp[1];
    if (kp[1] != r || r < 1 || r > MBS_NC || r > MBS_NV) return 0;
    for (j = 0; j < MBS_NV; j++) {  /* a permutation: every index in range, all distinct (dv as marks) */
        double c = kp[4 + j];
        if (c != (int)c || c < 0 || c >= MBS_NV) return 0;
    }
    memset(w->dv, 0, MBS_NV * sizeof(double));
    for (j = 0; j < MBS_NV; j++) {
        int c = (int)kp[4 + j];
        if (w->dv[c] != 0.0) return 0;
        w->dv[c] = 1.0;
        seen++;
    }
    for (j = 0; j < r; j++) {
        double row = kp[4 + MBS_NV + j];
        if (row != (int)row || row < 0 || row >= MBS_NC) return 0;
    }
    return seen == MBS_NV;
}

/* Remember the partition of the factors in w->G (rank r, smallest relative pivot `pivot`; `clean`: all its
 * pivots above MBS_LOOP_BAND_TOL, so that one falling below it tells a singular position near). */
static void mbs_loop_keep_store(mbs_loop_work *w, int r, double pivot, int clean)
{
    double *kp = w->keep;
    kp[0] = MBS_LOOP_KEEP_MARK;
    kp[1] = r;
    kp[2] = pivot;
    kp[3] = clean ? 1.0 : 0.0;
    memcpy(kp + 4, w->cp, MBS_NV * sizeof(double));
    memcpy(kp + 4 + MBS_NV, w->rp, r * sizeof(double));
}

/* The plan of the kept partition (w->plan, rebuilt whenever the kept partition is not the one it was made for):
 * its pivots grouped into independent blocks.  Loops closed relative to a body (compiler/relative_motion.py) give
 * G rows that share no column with another loop's: G is block diagonal up to the order of its rows and columns,
 * and so are its factors.  A block is a connected set of pivot rows and the columns they touch (the structural
 * nonzeros of mbs_colour_column, compiler/jacobian_colours.py); the kept pivots are reordered block by block (the
 * order within a block, and so its factors, unchanged), and each block is factored and solved on its own (the
 * Iltis: four of 6 rows and 7 columns instead of one of 24 rows and 34 columns, whose zeros cost more than the
 * blocks' arithmetic).  The ints after the copy of the kept partition: */
typedef struct {
    int *nb;     /* the number of blocks */
    int *k0;     /* NC + 1: block b holds the pivot positions k0[b] .. k0[b + 1] - 1 */
    int *j0;     /* NC + 1: and the independent column positions jl[j0[b]] .. jl[j0[b + 1] - 1] */
    int *jl;     /* NV */
    int *block;  /* NV: the block of each column position, -1 for an independent one that no pivot row touches */
    int *clean;  /* 1: the r rows of w->G are zero outside the blocks and w->cp holds the kept columns (the last
                  * factors were these blocks': only mbs_loop_factor writes either otherwise); 3: besides, w->T, w->Ti
                  * and w->c0 hold the pattern of mbs_loop_null_space_blocks (only mbs_loop_null_space writes them
                  * otherwise, after mbs_loop_factor), and start its columns' offsets */
    int *col;    /* NV: the kept columns in pivot order as ints (keep[4 ..] as the plan reordered them) */
    int *row;    /* NC: the kept pivot rows as ints, likewise (before the blocks' row exchanges) */
    int *ng;     /* the entries of G the blocks hold (at most NC x NV), */
    int *nz;     /* the first nz of them G's structural nonzeros, the others its structural zeros: */
    int *src;    /* ng: each one's offset in G (row-major, w->G0) */
    int *dst;    /* ng: and in the factors (w->G), block by block, row by row, as mbs_loop_factor_blocks reads them */
    int *reach;  /* NC: the last block whose velocities M couples with block b's (b itself at least): T_i^T M T_j
                  * is an exact zero for a column i of T beyond it and a column j of b (mbs_loop_reduced_mass_blocks) */
    int *mchunk; /* NC x (1 + MBS_LOOP_MASS_CHUNKS): block b's chunks of columns of M T_j (mbs_loop_plan_mass_chunks) */
    int *start;  /* NV - r + 1 (at most NV, the room's last NV ints): the offsets of T's columns in w->T, w->Ti
                  * (clean 3) */
} mbs_loop_blocks;

static inline mbs_loop_blocks mbs_loop_plan_blocks(const mbs_loop_work *w)
{
    mbs_loop_blocks b;
    int *s = (int *)(w->plan + 1 + MBS_LOOP_KEEP_SIZE);
    b.nb = s; s += 1;
    b.k0 = s; s += MBS_NC + 1;
    b.j0 = s; s += MBS_NC + 1;
    b.jl = s; s += MBS_NV;
    b.block = s; s += MBS_NV;
    b.clean = s; s += 1;
    b.col = s; s += MBS_NV;
    b.row = s; s += MBS_NC;
    b.ng = s; s += 1;
    b.nz = s; s += 1;
    b.src = s; s += MBS_NC * MBS_NV;
    b.dst = s; s += MBS_NC * MBS_NV;
    b.reach = s; s += MBS_NC;
    b.mchunk = s; s += MBS_NC * (1 + MBS_LOOP_MASS_CHUNKS);
    b.start = s;
    return b;
}

/* Was the plan made for the kept partition as it stands (then that partition is valid: plans are made from
 * valid ones only)? */
static int mbs_loop_plan_holds(const mbs_loop_work *w)
{
    return w->plan[0] == MBS_LOOP_KEEP_MARK
           && memcmp(w->plan + 1, w->keep, MBS_LOOP_KEEP_SIZE * sizeof(double)) == 0;
}

static int mbs_loop_root(const int *parent, int j)
{
    while (parent[j] != j) j = parent[j];
    return j;
}

/* Is G's entry (row i, column j) a structural nonzero (mbs_colour_column, compiler/jacobian_colours.py)? */
static int mbs_loop_structural(int i, int j)
{
    int c;
    for (c = 0; c < MBS_NCOLOUR; c++)
        if (mbs_colour_column[i * MBS_NCOLOUR + c] == j) return 1;
    return 0;
}

/* The plan's gather offsets from entry n on: those of the blocks' entries that are structural nonzeros of G
 * (`nonzero`) or zeros, block by block, row by row, dependent then independent columns; returns the next entry. */
static int mbs_loop_plan_gather(const mbs_loop_blocks *bl, int nonzero, int n)
{
    int b, k, c, e;
    for (b = 0; b < *bl->nb; b++)
        for (k = bl->k0[b]; k < bl->k0[b + 1]; k++) {
            for (c = bl->k0[b]; c < bl->k0[b + 1]; c++)
                if (mbs_loop_structural(bl->row[k], bl->col[c]) == nonzero) {
                    bl->src[n] = bl->row[k] * MBS_NV + bl->col[c];
                    bl->dst[n++] = k * MBS_NV + c;
                }
            for (e = bl->j0[b]; e < bl->j0[b + 1]; e++)
                if (mbs_loop_structural(bl->row[k], bl->col[bl->jl[e]]) == nonzero) {
                    bl->src[n] = bl->row[k] * MBS_NV + bl->col[bl->jl[e]];
                    bl->dst[n++] = k * MBS_NV + bl->jl[e];
                }
        }
    return n;
}

/* Does M couple the velocities of block b (its dependent and independent columns) with those of block c: is
 * any of the latter among the structural nonzeros of a row of M at one of the former (the runs of
 * mbs_mass_row, the rows mbs_loop_mass_axpy adds up)?  Without the table: yes. */
static int mbs_loop_blocks_coupled(const mbs_loop_blocks *bl, int b, int c)
{
#ifdef MBS_MASS_PATTERN
    int x, y, run;
    for (x = bl->k0[b]; x < bl->k0[b + 1] + bl->j0[b + 1] - bl->j0[b]; x++) {
        const int u = bl->col[x < bl->k0[b + 1] ? x : bl->jl[bl->j0[b] + x - bl->k0[b + 1]]];
        for (y = bl->k0[c]; y < bl->k0[c + 1] + bl->j0[c + 1] - bl->j0[c]; y++) {
            const int v = bl->col[y < bl->k0[c + 1] ? y : bl->jl[bl->j0[c] + y - bl->k0[c + 1]]];
            for (run = mbs_mass_row[u]; run < mbs_mass_row[u + 1]; run++)
                if (mbs_mass_begin[run] <= v && v < mbs_mass_end[run]) return 1;
        }
    }
    return 0;
#else
    (void)bl; (void)b; (void)c;
    return 1;
#endif
}

/* Block b's columns of M T_j for its columns j of T (mbs_loop_mass_times_block): every column that a row of M at one
 * of the block's velocities reaches (M's structural nonzeros, the generator's table; without it all), covered by
 * chunks of 4 columns from left to right, at most MBS_LOOP_MASS_CHUNKS (else none: the block takes
 * mbs_loop_mass_times_column).  A chunk may reach columns none of these rows does, where M's entries are exact zeros
 * (its structural zeros), and may overlap the one before it (at the last column): its entries of mt are computed
 * whole, the same values again.  mchunk[b * (1 + MBS_LOOP_MASS_CHUNKS)]: their number (-1: none), then their
 * first columns. */
static void mbs_loop_plan_mass_chunks(const mbs_loop_blocks *bl, int b)
{
    int mark[MBS_NV], *chunk = bl->mchunk + (1 + MBS_LOOP_MASS_CHUNKS) * b, x, v, n = 0;
    memset(mark, 0, sizeof mark);
    for (x = bl->k0[b]; x < bl->k0[b + 1] + bl->j0[b + 1] - bl->j0[b]; x++) {
        const int u = bl->col[x < bl->k0[b + 1] ? x : bl->jl[bl->j0[b] + x - bl->k0[b + 1]]];
#ifdef MBS_MASS_PATTERN
        int k;
        for (k = mbs_mass_row[u]; k < mbs_mass_row[u + 1]; k++)
            for (v = mbs_mass_begin[k]; v < mbs_mass_end[k]; v++) mark[v] = 1;
#else
        (void)u;
        for (v = 0; v < MBS_NV; v++) mark[v] = 1;
#endif
    }
    for (v = 0; v < MBS_NV; v++) {
        if (!mark[v]) continue;
        if (n == MBS_LOOP_MASS_CHUNKS || MBS_NV < 4) { n = -1; break; }
        chunk[1 + n++] = v + 4 <= MBS_NV ? v : MBS_NV - 4;
        v = chunk[n] + 3;  /* (the loop's v++: the column after the chunk) */
    }
    chunk[0] = n;
}

/* The plan of the kept partition (valid, rank r): its blocks, the kept pivots and independent columns reordered
 * block by block (the independent columns no pivot row touches last), each in its former order. */
static void mbs_loop_plan_build(mbs_loop_work *w)
{
    double *kp = w->keep, cols[MBS_NV], rows[MBS_NC];
    const int r = (int)kp[1];
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    int parent[MBS_NV], id[MBS_NV], i, j, k, c, b, n, e;
    for (j = 0; j < MBS_NV; j++) parent[j] = j;
    for (k = 0; k < r; k++) {  /* join the columns of each pivot row */
        int first = -1;
        i = (int)kp[4 + MBS_NV + k];
        for (c = 0; c < MBS_NCOLOUR; c++) {
            int col = mbs_colour_column[i * MBS_NCOLOUR + c];
            if (col < 0) continue;
            col = mbs_loop_root(parent, col);
            if (first < 0) first = col;
            else if (col != first) parent[col] = first;
        }
    }
    for (j = 0; j < MBS_NV; j++) id[j] = -1;  /* block ids by first appearance among the pivots */
    *bl.nb = 0;
    for (k = 0; k < r; k++) {
        const int root = mbs_loop_root(parent, (int)kp[4 + k]);
        if (id[root] < 0) id[root] = (*bl.nb)++;
    }
    for (b = 0, n = 0, e = 0; b < *bl.nb; b++) {
        bl.k0[b] = n;
        for (k = 0; k < r; k++)
            if (id[mbs_loop_root(parent, (int)kp[4 + k])] == b) {
                cols[n] = kp[4 + k];
                rows[n] = kp[4 + MBS_NV + k];
                bl.block[n++] = b;
            }
        bl.j0[b] = e;
        for (j = r; j < MBS_NV; j++)
            if (id[mbs_loop_root(parent, (int)kp[4 + j])] == b) {
                cols[r + e] = kp[4 + j];
                bl.jl[e] = r + e;
                bl.block[r + e++] = b;
            }
    }
    bl.k0[*bl.nb] = n;
    bl.j0[*bl.nb] = e;
    for (j = r; j < MBS_NV; j++)
        if (id[mbs_loop_root(parent, (int)kp[4 + j])] < 0) {
            cols[r + e] = kp[4 + j];
            bl.block[r + e++] = -1;
        }
    memcpy(kp + 4, cols, MBS_NV * sizeof(double));
    memcpy(kp + 4 + MBS_NV, rows, r * sizeof(double));
    for (j = 0; j < MBS_NV; j++) bl.col[j] = (int)cols[j];
    for (k = 0; k < r; k++) bl.row[k] = (int)rows[k];
    /* the gather: each block's rows, its dependent then independent columns; G's structural nonzeros first (read
     * from G0), then its structural zeros within the blocks (set to 0: the elimination fills some of them in) */
    *bl.nz = mbs_loop_plan_gather(&bl, 1, 0);
    *bl.ng = mbs_loop_plan_gather(&bl, 0, *bl.nz);
    for (b = 0; b < *bl.nb; b++) {
        for (bl.reach[b] = b, c = b + 1; c < *bl.nb; c++)
            if (mbs_loop_blocks_coupled(&bl, b, c)) bl.reach[b] = c;
        mbs_loop_plan_mass_chunks(&bl, b);
    }
    memcpy(w->plan + 1, kp, MBS_LOOP_KEEP_SIZE * sizeof(double));
    w->plan[0] = MBS_LOOP_KEEP_MARK;
    *bl.clean = 0;
}

/* The kernels of one block of the kept partition (its elimination, solve, null-space columns and multipliers) are
 * inlined with the block's size, its number of pivot rows, a constant for the sizes MBS_LOOP_BY_SIZE lists, so that
 * their loops over the block's rows and columns unroll: tiny loops (a spatial loop's 6 rows and fewer) whose control
 * and index arithmetic cost more than their products.  (The null space's columns, mbs_loop_null_space_block, kept their
 * loops for a while: unrolled, they took 500 instructions fewer a call but the Iltis's loop_rhs measured 10 % slower
 * in CPU time.  The luck of the library's pages in physical memory moves loop_rhs by up to 20 % with the same code,
 * build to build: over fresh copies of each build, bench/rhs_placement.py, they run 0.99 of the loops'.)  Other sizes
 * take the same kernels with the size a variable; the same arithmetic in the same order either way (the same bits).
 * -DMBS_LOOP_BLOCK_FORMER=1: every size a variable (bench/loop_work.py). */
#ifndef MBS_LOOP_BLOCK_FORMER
#define MBS_LOOP_BLOCK_FORMER 0
#endif
#if defined(__GNUC__) && !defined(__clang__) && !MBS_LOOP_BLOCK_FORMER
#define MBS_LOOP_UNROLL _Pragma("GCC unroll 8")
#elif defined(__clang__) && !MBS_LOOP_BLOCK_FORMER
#define MBS_LOOP_UNROLL _Pragma("unroll 8")
#else
#define MBS_LOOP_UNROLL
#endif
/* ... and the loops of T^T M T's factors and solve (mbs_loop_reduced_factor_solve), whose size is NV - NC where every
 * row is a pivot row (the Iltis's 10): unrolled whole. */
#if defined(__GNUC__) && !defined(__clang__) && !MBS_LOOP_BLOCK_FORMER
#define MBS_LOOP_UNROLL_ALL _Pragma("GCC unroll 16")
#elif defined(__clang__) && !MBS_LOOP_BLOCK_FORMER
#define MBS_LOOP_UNROLL_ALL _Pragma("unroll 16")
#else
#define MBS_LOOP_UNROLL_ALL
#endif
#if defined(__GNUC__)
#define MBS_LOOP_INLINE static inline __attribute__((always_inline))
#else
#define MBS_LOOP_INLINE static inline
#endif
/* CALL(size) with size n, a constant for the sizes listed, else a variable: two loops closed by spherical joints
 * (3 rows each) and coupled, 6 rows (the Iltis's corners, whose wheel carrier closes the leaf spring's loop and the
 * steering rod's).  Each size listed costs compiler CPU once per model (the glue unit's 0.66 s grew to 0.93 s with
 * size 6, 1.07 s with sizes 3 and 6, 1.32 s with every size from 2 to 6); other sizes gain a little all the same
 * (the 10-four-bar chain's one block of 20 rows: 1 % fewer instructions a call). */
#if MBS_LOOP_BLOCK_FORMER || MBS_NC < 6 || MBS_NV < 6  /* (no block of 6 rows: no instance that could not run) */
#define MBS_LOOP_BY_SIZE(n, CALL) CALL(n)
#else
#define MBS_LOOP_BY_SIZE(n, CALL) \
    do {                          \
        switch (n) {              \
        case 6: CALL(6); break;   \
        default: CALL(n); break;  \
        }                         \
    } while (0)
#endif
/* CALL(size) with the size m of T^T M T, a constant for NV - NC (the rank where every row is a pivot row, no loop
 * redundant: the Iltis's 10), else a variable. */
#if MBS_LOOP_BLOCK_FORMER || MBS_NV - MBS_NC < 2 || MBS_NV - MBS_NC > 16
#define MBS_LOOP_BY_REDUCED_SIZE(m, CALL) CALL(m)
#else
#define MBS_LOOP_BY_REDUCED_SIZE(m, CALL)   \
    do {                                    \
        if ((m) == MBS_NV - MBS_NC) {       \
            CALL(MBS_NV - MBS_NC);          \
        } else {                            \
            CALL(m);                        \
        }                                   \
    } while (0)
#endif
/* One block's elimination with partial pivoting among its n rows (from pivot position k0), its independent columns jl
 * (nj) and y riding along (the forward substitution of gddot0 when the caller has it, else of zeros: one more column
 * either way, no test an entry); returns the smallest pivot so far (its size: the caller divides the smallest by
 * max |G| once, where a quotient a pivot took a division each; the quotients' order is the pivots', so the smallest
 * quotient is the same), or -1 when a pivot vanishes.  Inlined with n a constant for the sizes MBS_LOOP_BY_SIZE lists,
 * so that its loops unroll. */
MBS_LOOP_INLINE double mbs_loop_eliminate_block(double *A, double *rp, double *y, const int k0, const int n,
                                             const int *jl, const int nj, const double amax0,
                                             double minpivot)
{
    double *B = A + k0 * MBS_NV + k0, tmp;
    int k, i, c, e;
    MBS_LOOP_UNROLL
    for (k = 0; k < n; k++) {
        int pi = k;
        double amax = fabs(B[k * MBS_NV + k]);  /* (G is finite here: the probe above) */
        MBS_LOOP_UNROLL
        for (i = k + 1; i < n; i++) {
            const double v = fabs(B[i * MBS_NV + k]);
            if (v > amax) { amax = v; pi = i; }
        }
        if (!(amax > MBS_LOOP_RANK_TOL * amax0)) return -1.0;
        minpivot = amax < minpivot ? amax : minpivot;
        if (pi != k) {
            double *x = B + k * MBS_NV, *z = B + pi * MBS_NV;
            for (c = 0; c < n; c++) { tmp = x[c]; x[c] = z[c]; z[c] = tmp; }
            x = A + (k0 + k) * MBS_NV;
            z = A + (k0 + pi) * MBS_NV;
            for (e = 0; e < nj; e++) { tmp = x[jl[e]]; x[jl[e]] = z[jl[e]]; z[jl[e]] = tmp; }
            tmp = rp[k0 + k]; rp[k0 + k] = rp[k0 + pi]; rp[k0 + pi] = tmp;
            tmp = y[k0 + k]; y[k0 + k] = y[k0 + pi]; y[k0 + pi] = tmp;
        }
        MBS_LOOP_UNROLL
        for (i = k + 1; i < n; i++) {
            double l, *bi = B + i * MBS_NV, *ai = A + (k0 + i) * MBS_NV;
            const double *bk = B + k * MBS_NV, *ak = A + (k0 + k) * MBS_NV;
            if (bi[k] == 0.0) continue;
            l = bi[k] /= bk[k];
            MBS_LOOP_UNROLL
            for (c = k + 1; c < n; c++) bi[c] -= l * bk[c];
            if (nj == 1)  /* a loop's block with one independent column (the Iltis's): no loop for it */
                ai[jl[0]] -= l * ak[jl[0]];
            else
                for (e = 0; e < nj; e++) ai[jl[e]] -= l * ak[jl[e]];
            y[k0 + i] -= l * y[k0 + k];  /* the forward substitution's terms, in its order */
        }
    }
    return minpivot;
}

/* Factor G (w->G0, as mbs_loop_jacobian_at left it) with the kept partition, block by block (its plan): each
 * block's pivot rows in the kept column order into w->G, the rest of its r rows zero, row exchanges among the
 * block's rows only (they leave the partition unchanged).  rp, cp set.  Returns the smallest pivot relative to
 * max |G| over all rows (read at the structural nonzeros only), 0 when a pivot vanishes, -1 when G is not
 * finite.  With gddot0 at hand (w->terms: mbs_loop_rhs_direct) the forward substitution of c0_D rides along as one
 * more column, y = L11^-1 (-gddot0) in w->y (w->forward): the same terms in the same order as its own pass in
 * mbs_loop_null_space_blocks, one product a row instead of a pass over L11. */
static double mbs_loop_factor_blocks(mbs_loop_work *w)
{
    const double *kp = w->keep, *G0 = w->G0;
    const int r = (int)kp[1];
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    double *A = w->G, *y = w->y, amax0 = 0.0, probe = 0.0, minpivot = HUGE_VAL;
    const int forward = w->terms;  /* gddot0 at hand: its forward substitution rides along (w->forward) */
    int i, k, c, b, e;
    w->forward = 0;
    memcpy(w->rp, kp + 4 + MBS_NV, r * sizeof(double));
    if (forward) {  /* (bl.row: rp as ints, before the row exchanges; 4 a loop) */
        const double *restrict h = w->h;
        for (k = 0; k + 4 <= r; k += 4) {
            y[k] = -h[bl.row[k]];
            y[k + 1] = -h[bl.row[k + 1]];
            y[k + 2] = -h[bl.row[k + 2]];
            y[k + 3] = -h[bl.row[k + 3]];
        }
        for (; k < r; k++) y[k] = -h[bl.row[k]];
    } else
        memset(y, 0, (size_t)r * sizeof(double));
    if (!*bl.clean) {  /* another factorisation wrote w->G and w->cp since these blocks' last one (clean 1 or 3 else) */
        memset(A, 0, (size_t)r * MBS_NV * sizeof(double));
        memcpy(w->cp, kp + 4, MBS_NV * sizeof(double));  /* (the blocks' row exchanges leave it) */
        *bl.clean = 1;
    }
    /* every block's rows into w->G: its dependent columns, then its independent ones.  With every row a pivot
     * row (r = NC) these entries hold all the structural nonzeros of G (a block holds every column its rows
     * touch), so max |G| comes with them; otherwise the dropped rows are read as well. */
    {  /* by the plan's offsets (mbs_loop_plan_build), 4 a loop into two maxima and probes (neither max nor a probe's
        * sum of zeros depends on the order) */
        const int *restrict src = bl.src, *restrict dst = bl.dst, nz = *bl.nz, ng = *bl.ng;
        double m0 = 0.0, m1 = 0.0, p0 = 0.0, p1 = 0.0;
        for (e = 0; e + 4 <= nz; e += 4) {
            const double g0 = G0[src[e]], g1 = G0[src[e + 1]], a0 = fabs(g0), a1 = fabs(g1);
            const double g2 = G0[src[e + 2]], g3 = G0[src[e + 3]], a2 = fabs(g2), a3 = fabs(g3);
            A[dst[e]] = g0;
            A[dst[e + 1]] = g1;
            A[dst[e + 2]] = g2;
            A[dst[e + 3]] = g3;
            m0 = a0 > m0 ? a0 : m0;
            m1 = a1 > m1 ? a1 : m1;
            m0 = a2 > m0 ? a2 : m0;
            m1 = a3 > m1 ? a3 : m1;
            p0 += 0.0 * g0 + 0.0 * g2;
            p1 += 0.0 * g1 + 0.0 * g3;
        }
        for (; e < nz; e++) {
            const double g = G0[src[e]], a = fabs(g);
            A[dst[e]] = g;
            m0 = a > m0 ? a : m0;
            p0 += 0.0 * g;
        }
        for (; e + 4 <= ng; e += 4) {  /* G's structural zeros (exact zeros in G0) */
            A[dst[e]] = 0.0;
            A[dst[e + 1]] = 0.0;
            A[dst[e + 2]] = 0.0;
            A[dst[e + 3]] = 0.0;
        }
        for (; e < ng; e++) A[dst[e]] = 0.0;
        amax0 = m1 > m0 ? m1 : m0;
        probe = p0 + p1;
    }
    if (r < MBS_NC)
        for (i = 0; i < MBS_NC; i++)
            for (c = 0; c < MBS_NCOLOUR; c++) {
                const int col = mbs_colour_column[i * MBS_NCOLOUR + c];
                if (col >= 0) {
                    const double a = fabs(G0[i * MBS_NV + col]);
                    amax0 = a > amax0 ? a : amax0;
                    probe += 0.0 * G0[i * MBS_NV + col];
                }
            }
    if (!(probe == 0.0)) return -1.0;
    if (!(amax0 > 0.0)) return 0.0;
    for (b = 0; b < *bl.nb; b++) {
        const int k0 = bl.k0[b], n = bl.k0[b + 1] - k0, nj = bl.j0[b + 1] - bl.j0[b], *jl = bl.jl + bl.j0[b];
#define MBS_LOOP_ELIMINATE(size) \
        minpivot = mbs_loop_eliminate_block(A, w->rp, y, k0, size, jl, nj, amax0, minpivot)
        MBS_LOOP_BY_SIZE(n, MBS_LOOP_ELIMINATE);
#undef MBS_LOOP_ELIMINATE
        if (minpivot < 0.0) return 0.0;
    }
    w->forward = forward;
    return minpivot < HUGE_VAL ? minpivot / amax0 : minpivot;  /* (the smallest pivot relative to max |G|) */
}

/* Another factorisation is about to write w->G: the blocks' rows are no longer zero outside them. */
static void mbs_loop_plan_dirty(const mbs_loop_work *w)
{
    *mbs_loop_plan_blocks(w).clean = 0;
}

/* mbs_loop_solve with the factors of mbs_loop_factor_blocks: each block's rows from its own columns (the same
 * arithmetic in the same order: the other blocks' entries of a row are exact zeros); the columns' velocities as the
 * plan's ints (col: w->cp as it holds them). */
/* One block's part of mbs_loop_solve_blocks (n pivot rows from position k0, its independent columns jl), inlined with n
 * a constant for the sizes MBS_LOOP_BY_SIZE lists. */
MBS_LOOP_INLINE void mbs_loop_solve_block(const mbs_loop_work *w, const double *h, double *z, const int k0, const int n,
                                        const int *jl, const int nj, const int *col)
{
    const double *restrict B = w->G + k0 * MBS_NV + k0;
    double *restrict y = w->y + k0;
    int c, e, k;
    MBS_LOOP_UNROLL
    for (k = 0; k < n; k++) {  /* y = L11^-1 (-h_R) - U12 z_I */
        double s = h ? -h[(int)w->rp[k0 + k]] : 0.0;
        MBS_LOOP_UNROLL
        for (c = 0; c < k; c++) s -= B[k * MBS_NV + c] * y[c];
        y[k] = s;
    }
    for (e = 0; e < nj; e++) {
        const double zj = z[col[jl[e]]];
        const double *a = w->G + k0 * MBS_NV + jl[e];
        if (zj != 0.0) {
            MBS_LOOP_UNROLL
            for (k = 0; k < n; k++) y[k] -= a[k * MBS_NV] * zj;
        }
    }
    MBS_LOOP_UNROLL
    for (k = n - 1; k >= 0; k--) {  /* U11 z_D = y */
        double s = y[k];
        MBS_LOOP_UNROLL
        for (c = k + 1; c < n; c++) s -= B[k * MBS_NV + c] * y[c];
        y[k] = s / B[k * MBS_NV + k];
    }
    MBS_LOOP_UNROLL
    for (k = 0; k < n; k++) z[col[k0 + k]] = y[k];
}

static void mbs_loop_solve_blocks(const mbs_loop_work *w, const double *h, double *z)
{
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    int b;
    for (b = 0; b < *bl.nb; b++) {
        const int k0 = bl.k0[b], n = bl.k0[b + 1] - k0, nj = bl.j0[b + 1] - bl.j0[b], *jl = bl.jl + bl.j0[b];
#define MBS_LOOP_SOLVE(size) mbs_loop_solve_block(w, h, z, k0, size, jl, nj, bl.col)
        MBS_LOOP_BY_SIZE(n, MBS_LOOP_SOLVE);
#undef MBS_LOOP_SOLVE
    }
}

/* Factor G with the kept partition (valid), by its plan (made first unless `planned`: the plan holds for it). */
static double mbs_loop_factor_kept(mbs_loop_work *w, int planned)
{
    if (!planned) mbs_loop_plan_build(w);
    return mbs_loop_factor_blocks(w);
}

/* Given the independent entries of z (NV, original column order), set its dependent entries so that the pivot
 * rows of G z + h vanish: G_D z_D = -(G_I z_I + h) on the r pivot rows.  h may be NULL (zero). */
static void mbs_loop_solve_blocks(const mbs_loop_work *w, const double *h, double *z);

static void mbs_loop_solve(const mbs_loop_work *w, int r, const double *h, double *z)
{
    const double *A = w->G;
    double *y = w->y;
    int j, k;
    if (w->blocked) {  /* the kept partition's factors: block by block */
        mbs_loop_solve_blocks(w, h, z);
        return;
    }
    for (k = 0; k < r; k++) {  /* y = L11^-1 (-h_R) - U12 z_I; the zeros of the factors (other loops) skipped */
        double s = h ? -h[(int)w->rp[k]] : 0.0;
        for (j = 0; j < k; j++)
            if (A[k * MBS_NV + j] != 0.0) s -= A[k * MBS_NV + j] * y[j];
        y[k] = s;
    }
    for (j = r; j < MBS_NV; j++) {  /* column by column, each y[k] still in the order of j; zeros skipped */
        const double zj = z[(int)w->cp[j]];
        if (zj != 0.0)
            for (k = 0; k < r; k++) y[k] -= A[k * MBS_NV + j] * zj;
    }
    for (k = r - 1; k >= 0; k--) {  /* U11 z_D = y */
        double s = y[k];
        for (j = k + 1; j < r; j++)
            if (A[k * MBS_NV + j] != 0.0) s -= A[k * MBS_NV + j] * y[j];
        y[k] = s / A[k * MBS_NV + k];
    }
    for (k = 0; k < r; k++) z[(int)w->cp[k]] = y[k];
}

/* The rank of G at positions near q along a motion the factors in w->G allow (dv in their null space, a fixed
 * mix of the independent velocities, `distance` in the largest coordinate): the rank of the regular positions
 * around q.  Where q is regular, or the rows are redundant along the whole motion (an overconstrained but
 * mobile mechanism), the rank stays (the deviation from the motion is of second order, about 1e-11 at 3e-6);
 * at a singular position (a bifurcation) the lost rank returns at first order.  *rband: the number of leading
 * pivots above MBS_LOOP_BAND_TOL there. */
static int mbs_loop_generic_rank(double t, const double *q, const double *p, mbs_loop_work *w, int r,
                                 double distance, int *rband)
{
    mbs_loop_work v = *w;
    double pivot, scale;
    int i;
    for (i = 0; i < MBS_NV; i++) w->dv[i] = 1.0 + 0.5 * sin(12.9898 * (i + 1));
    mbs_loop_solve(w, r, NULL, w->dv);
    memcpy(w->xt, q, MBS_NQ * sizeof(double));
    memcpy(w->xt + MBS_NQ, w->dv, MBS_NV * sizeof(double));
    if (mbs_qdot(t, w->xt, p, w->dq, w->tree) != 0) return -1;
    scale = mbs_loop_maxabs(w->dq, MBS_NQ, NULL);
    if (!(scale > 0.0) || !isfinite(scale)) return -1;
    for (i = 0; i < MBS_NQ; i++) w->xt[i] = q[i] + distance / scale * w->dq[i];
    mbs_loop_normalize_q(w->xt);
    if (mbs_loop_jacobian_into(t, w->xt, p, w, w->K, w->c3) != 0) return -1;
    v.G = v.G0 = w->K;
    v.rp = w->rp2;
    v.cp = w->cp2;
    i = mbs_loop_factor(&v, &pivot);
    *rband = v.rband;
    return i;
}

/* Factor G (just evaluated at the positions q by mbs_loop_jacobian_at) and return the rank, -1 if not finite.
 * The kept partition is used while its pivots have not degraded (hysteresis, MBS_LOOP_KEEP_RATIO); otherwise
 * complete pivoting chooses afresh, and the new choice is kept when `adopt` (or when none was kept), unless the
 * position is singular (w->singular: rank below that of the positions around it).  `adopt` is set between
 * steps (the projection of an accepted state), so that within a step the partition does not change; -1 asks
 * for the choice of complete pivoting at q, the kept partition neither used nor changed (mbs_loop_report). */
static int mbs_loop_partition(double t, const double *q, const double *p, mbs_loop_work *w, int adopt,
                              mbs_loop_info *info)
{
    double pivot;
    const int planned = adopt >= 0 && mbs_loop_plan_holds(w);  /* (a plan is made for a valid partition only) */
    int r, rb, valid = planned || (adopt >= 0 && mbs_loop_keep_valid(w));
    w->fresh = w->singular = w->blocked = 0;
    if (valid) {
        pivot = mbs_loop_factor_kept(w, planned);
        if (pivot < 0.0) return -1;
        w->pivot = pivot;
        if (pivot >= MBS_LOOP_KEEP_RATIO * w->keep[2] && (pivot >= MBS_LOOP_BAND_TOL || w->keep[3] == 0.0)) {
            w->blocked = 1;
            return (int)w->keep[1];
        }
    }
    memcpy(w->G, w->G0, MBS_NC * MBS_NV * sizeof(double));
    r = mbs_loop_factor(w, &pivot);
    w->fresh = 1;
    w->pivot = pivot;
    if (r > 0 && r < MBS_NC && r < MBS_NV
        && r < (valid ? (int)w->keep[1] : mbs_loop_generic_rank(t, q, p, w, r, 3e-6, &rb)))
        w->singular = 1;
    if (!w->singular && r > 0 && w->rband < r) {  /* pivots in the band: near a singular position, or ill-scaled */
        if (mbs_loop_generic_rank(t, q, p, w, w->rband, MBS_LOOP_BAND_PROBE, &rb) >= 0 && rb > w->rband) {
            w->singular = 1;
            if (!w->newton) r = w->rband;
        }
    }
    if (r > 0 && (adopt > 0 || (adopt == 0 && !valid)) && !w->singular) {
        mbs_loop_keep_store(w, r, pivot, w->rband == r);
        if (info) info->refreshed++;
    }
    return r;
}

/* The residuals g at the positions of x into w->g; with `rates` (where the model has mbs_constraints_with_velocity)
 * also their rate gdot = G v + g_t at x, from the same pass over the kinematics, into mbs_loop_rates_of(w). */
static inline double *mbs_loop_rates_of(const mbs_loop_work *w)
{
    return w->K + MBS_NC;  /* [g; gdot] in the room of K, scratch here (MBS_LOOP_RATES: NV >= 2) */
}

static int mbs_loop_residuals(double t, const double *x, const double *p, mbs_loop_work *w, int rates)
{
#if MBS_LOOP_RATES
    if (rates) {
        const int s = mbs_constraints_with_velocity(t, x, p, w->K, w->tree);
        memcpy(w->g, w->K, MBS_NC * sizeof(double));
        return s;
    }
#endif
    (void)rates;
    return mbs_constraints(t, x, p, w->g, w->tree);
}

/* One Newton step on g(q) = 0 with the factors at hand: the correction solved in speeds (minimum norm over the
 * kept partition of rank r), mapped to the coordinates by q' = qdot(q, dv), w->dq the step taken; w->g is the
 * residual at the new q (and the rate of the residuals there with `rates`, q then a whole state: mbs_loop_residuals). */
static int mbs_loop_newton_step(double t, double *q, const double *p, mbs_loop_work *w, int r, int rates)
{
    int i;
    memset(w->dv, 0, MBS_NV * sizeof(double));
    mbs_loop_solve(w, r, w->g, w->dv);
    memcpy(w->xt, q, MBS_NQ * sizeof(double));
    memcpy(w->xt + MBS_NQ, w->dv, MBS_NV * sizeof(double));
    if ((i = mbs_qdot(t, w->xt, p, w->dq, w->tree)) != 0) return i;
    mbs_loop_add(q, w->dq, MBS_NQ);
    mbs_loop_normalize_q(q);
    return mbs_loop_residuals(t, q, p, w, rates);
}

/* The polishing Newton steps with the factors at hand after a converged projection from factors kept from before
 * (mbs_loop_project_stamped, mbs_loop_project_from_row): at most MBS_LOOP_POLISH_STEPS while the residual `res` is
 * above MBS_LOOP_POLISH and each halves it; a step that does not reduce it is undone (the round-off floor).
 * *after (when not NULL): max |g| at the positions left, which w->g holds, or -1 when a step was undone (w->g then
 * holds the residual of the positions undone, not of those left).  `rates`: each step's evaluation also gives the rate
 * of the residuals (mbs_loop_residuals), so the one the polish ends with is at the positions left unless *after < 0. */
static int mbs_loop_polish(double t, double *q, const double *p, mbs_loop_work *w, int r, double res, double *after,
                           int rates)
{
    int i, k, s;
    if (after) *after = res;
    for (k = 0; k < MBS_LOOP_POLISH_STEPS && res > MBS_LOOP_POLISH; k++) {
        const double before = res;
        if ((s = mbs_loop_newton_step(t, q, p, w, r, rates)) != 0) return s;
        res = mbs_loop_maxabs(w->g, MBS_NC, NULL);
        if (after) *after = res;
        if (!(res < before)) {  /* at the round-off floor: undo this step */
            for (i = 0; i < MBS_NQ; i++) q[i] -= w->dq[i];
            mbs_loop_normalize_q(q);
            if (after) *after = -1.0;
            break;
        }
        if (res > 0.5 * before) break;
    }
    return 0;
}

/* Project the positions of w->xc onto g = 0 (velocities of w->xc untouched as a state, used as scratch). */
static int mbs_loop_positions_iterate(double t, const double *p, mbs_loop_work *w, int adopt, mbs_loop_info *info)
{
    double *q = w->xc, res;
    int s, i, k, keep = 0;
    mbs_loop_normalize_q(q);
    if ((s = mbs_constraints(t, q, p, w->g, w->tree)) != 0) return s;
    res = info->residual0 = info->residual = mbs_loop_maxabs(w->g, MBS_NC, &info->worst);
    while (!(res <= MBS_LOOP_TOL)) {
        double previous = res;
        if (!isfinite(res)) return MBS_LOOP_NONFINITE;
        if (info->iterations >= MBS_LOOP_MAXIT) return MBS_LOOP_NOT_ASSEMBLED;
        if (!keep) {
            if ((s = mbs_loop_jacobian_at(t, q, p, w, 0)) != 0) return s;
            info->jacobians++;
            if ((info->rank = mbs_loop_partition(t, q, p, w, adopt, info)) < 0) return MBS_LOOP_NONFINITE;
            if (info->rank == 0) return MBS_LOOP_NOT_ASSEMBLED;
        }
        if ((s = mbs_loop_newton_step(t, q, p, w, info->rank, 0)) != 0) return s;
        res = info->residual = mbs_loop_maxabs(w->g, MBS_NC, &info->worst);
        info->iterations++;
        if (!keep && !(res < 0.5 * previous) && res <= MBS_LOOP_FLOOR) break;  /* round-off floor */
        /* keep the factors while they converge fast (simplified Newton), refresh them when they do not */
        keep = res <= MBS_LOOP_SLOW * previous;
    }
    /* a few more steps with the factors at hand (fresh ones if none yet) while they halve the residual: they
     * take a linearly converged run, or a state that was just inside the tolerance, down to round-off */
    for (k = 0; k < MBS_LOOP_POLISH_STEPS && res > MBS_LOOP_POLISH; k++) {
        double before = res;
        if (info->iterations == 0 && k == 0) {
            if ((s = mbs_loop_jacobian_at(t, q, p, w, 0)) != 0) return s;
            info->jacobians++;
            if ((info->rank = mbs_loop_partition(t, q, p, w, adopt, info)) <= 0) return 0;
        }
        if ((s = mbs_loop_newton_step(t, q, p, w, info->rank, 0)) != 0) return s;
        res = mbs_loop_maxabs(w->g, MBS_NC, NULL);
        if (!(res < before)) {  /* at the round-off floor: undo this step */
            for (i = 0; i < MBS_NQ; i++) q[i] -= w->dq[i];
            mbs_loop_normalize_q(q);
            if ((s = mbs_constraints(t, q, p, w->g, w->tree)) != 0) return s;
            break;
        }
        info->residual = mbs_loop_maxabs(w->g, MBS_NC, &info->worst);
        if (res > 0.5 * before) break;  /* no longer converging: the floor is near */
    }
    return 0;
}

/* The positions by Newton on all the rows of full rank, also in the band around a singular position: there the
 * rows with small pivots move the positions onto the branch to the round-off of g over the pivot. */
static int mbs_loop_positions(double t, const double *p, mbs_loop_work *w, int adopt, mbs_loop_info *info)
{
    int s;
    w->newton = 1;
    s = mbs_loop_positions_iterate(t, p, w, adopt, info);
    w->newton = 0;
    return s;
}

/* w->xc = x projected onto the position and velocity constraints; leaves G factored at the projected
 * positions with info->rank pivots (the partition) and h = g_t there.  `adopt`: a new partition chosen here is
 * kept for the following calls (see mbs_loop_partition). */
static int mbs_loop_project_state(double t, const double *x, const double *p, mbs_loop_work *w, int adopt,
                                  mbs_loop_info *info)
{
    int s;
    memset(info, 0, sizeof *info);
    info->worst = -1;
    memcpy(w->xc, x, MBS_NX * sizeof(double));
    s = mbs_loop_positions(t, p, w, adopt, info);
    if (s != 0 && adopt >= 0 && mbs_loop_keep_valid(w)) {  /* far off: Newton again, choosing afresh */
        w->keep[0] = 0.0;
        memset(info, 0, sizeof *info);
        info->worst = -1;
        memcpy(w->xc, x, MBS_NX * sizeof(double));
        s = mbs_loop_positions(t, p, w, -1, info);
    }
    if (s == 0) {
        s = mbs_loop_jacobian_at(t, w->xc, p, w, 1);
        info->jacobians++;
        if (s == 0 && (info->rank = mbs_loop_partition(t, w->xc, p, w, adopt, info)) < 0) s = MBS_LOOP_NONFINITE;
    }
    if (s == 0)  /* keep v_I, solve G_D v_D = -(G_I v_I + g_t) */
        mbs_loop_solve(w, info->rank, w->h, w->xc + MBS_NQ);
    info->status = s;
    return s;
}

/* At a singular position (the rank of G below that of the regular positions around it, e.g. a four-bar
 * stretched flat) the accelerations are not fixed by G vdot + gddot0 = 0: the limit of the motion through
 * the position is.  For each row i that the factors found dependent, with u its left null vector (u^T G = 0),
 * the third time derivative of u^T g along the motion gives u^T (3 K vdot + c3) = 0 with K = dG/dt and
 * c3 = d(gddot0)/dq qdot (both by central differences along the motion).  Rows of exactly redundant
 * constraints have u^T K = 0 and stay dropped.  Replaces w->G0 and w->h by the extended rows (the pivot rows
 * kept) and returns 1 when a row was added, 0 when none (at rest the velocities give no direction). */
static int mbs_loop_singular_rows(double t, const double *p, mbs_loop_work *w, int r, int *status)
{
    const double *A = w->G;
    double eps, vmax = 0.0, kmax;
    int i, j, k, added = 0, s;
    *status = 0;
    memcpy(w->xt, w->xc, MBS_NX * sizeof(double));
    if ((s = mbs_qdot(t, w->xt, p, w->dq, w->tree)) != 0) { *status = s; return 0; }
    vmax = mbs_loop_maxabs(w->dq, MBS_NQ, NULL);
    if (!(vmax > 0.0) || !isfinite(vmax)) return 0;
    eps = 6e-6 / vmax;  /* about the cube root of the round-off: balances truncation and cancellation */
    /* K = (G(q + eps qdot) - G(q - eps qdot)) / (2 eps); c3 likewise from gddot0 (velocities of x kept) */
    for (i = 0; i < MBS_NQ; i++) w->xt[i] = w->xc[i] + eps * w->dq[i];
    if ((s = mbs_loop_jacobian_into(t, w->xt, p, w, w->K, w->g)) != 0) { *status = s; return 0; }
    for (i = 0; i < MBS_NQ; i++) w->xt[i] = w->xc[i] + eps * w->dq[i];
    memcpy(w->xt + MBS_NQ, w->xc + MBS_NQ, MBS_NV * sizeof(double));
    if ((s = mbs_constraint_acceleration(t, w->xt, p, w->c3, w->tree)) != 0) { *status = s; return 0; }
    for (i = 0; i < MBS_NQ; i++) w->xt[i] = w->xc[i] - eps * w->dq[i];
    memcpy(w->xt + MBS_NQ, w->xc + MBS_NQ, MBS_NV * sizeof(double));
    if ((s = mbs_constraint_acceleration(t, w->xt, p, w->g, w->tree)) != 0) { *status = s; return 0; }
    for (i = 0; i < MBS_NC; i++) w->c3[i] = (w->c3[i] - w->g[i]) / (2.0 * eps);
    /* the minus side column by column: K = (K - G(q - eps qdot)) / (2 eps) */
    for (i = 0; i < MBS_NQ; i++) w->xt[i] = w->xc[i] - eps * w->dq[i];
    memset(w->xt + MBS_NQ, 0, MBS_NV * sizeof(double));
    if ((s = mbs_constraint_velocity(t, w->xt, p, w->g, w->tree)) != 0) { *status = s; return 0; }
    for (k = 0; k < MBS_NV; k++) {
        w->xt[MBS_NQ + k] = 1.0;
        s = mbs_constraint_velocity(t, w->xt, p, w->y, w->tree);
        w->xt[MBS_NQ + k] = 0.0;
        if (s != 0) { *status = s; return 0; }
        for (i = 0; i < MBS_NC; i++)
            w->K[i * MBS_NV + k] = (w->K[i * MBS_NV + k] - (w->y[i] - w->g[i])) / (2.0 * eps);
    }
    kmax = mbs_loop_maxabs(w->K, MBS_NC * MBS_NV, NULL);
    if (!(kmax > 0.0) || !isfinite(kmax)) return 0;
    /* each dependent row (pivot position i >= r): u = e_i - L21_i L11^-1 in pivot-row order */
    for (i = r; i < MBS_NC; i++) {
        int row = (int)w->rp[i];
        double rmax = 0.0, c = 0.0;
        for (k = 0; k < r && k < MBS_NV; k++) w->y[k] = A[i * MBS_NV + k];
        for (k = r - 1; k >= 0; k--)  /* L11^T y = L21_i^T (L11 unit lower triangular) */
            for (j = k + 1; j < r; j++) w->y[k] -= A[j * MBS_NV + k] * w->y[j];
        for (j = 0; j < MBS_NV; j++) {  /* the new row 3 u^T K into dv */
            double sum = w->K[row * MBS_NV + j];
            for (k = 0; k < r; k++) sum -= w->y[k] * w->K[(int)w->rp[k] * MBS_NV + j];
            w->dv[j] = 3.0 * sum;
            rmax = fmax(rmax, fabs(w->dv[j]));
        }
        c = w->c3[row];
        for (k = 0; k < r; k++) c -= w->y[k] * w->c3[(int)w->rp[k]];
        if (!(rmax > 1e-6 * kmax)) continue;  /* exactly redundant: u^T G stays zero along the motion */
        memcpy(w->G0 + row * MBS_NV, w->dv, MBS_NV * sizeof(double));
        w->h[row] = c;
        added++;
    }
    return added > 0;
}

/* The nonzeros of the factors in w->G (rank r) by rows: for pivot row k, col[at[k]] .. col[at[k] + nl[k] - 1] the
 * columns j < k of L11, then up to col[u[k] - 1] those of U11 (k < j < r), then up to col[at[k + 1] - 1] those
 * of U12 (j >= r).  Independent loops leave a row a few nonzeros among NV columns: the solves of
 * mbs_loop_accelerations then follow the loops' own sizes rather than NC x NV.  The columns live in the unused
 * half of the room of Ti (NV x NV doubles hold 2 NV^2 ints; Ti takes at most NV^2, the lists r (NV - 1)). */
typedef struct {
    int *col;
    int at[MBS_NC + 1], nl[MBS_NC], u[MBS_NC];
} mbs_loop_rows;

static void mbs_loop_row_lists(const mbs_loop_work *w, int r, mbs_loop_rows *rows, int *cpi)
{
    const double *A = w->G;
    int j, k, e = 0;
    rows->col = w->Ti + MBS_NV * MBS_NV;
    for (j = 0; j < MBS_NV; j++) cpi[j] = (int)w->cp[j];
    for (k = 0; k < r; k++) {  /* branch-free compaction: whether an entry is zero follows no pattern the */
        const double *row = A + k * MBS_NV;   /* branch predictor learns (it cost a fifth of the solve) */
        int *col = rows->col;
        rows->at[k] = e;
        for (j = 0; j < k; j++) { col[e] = j; e += row[j] != 0.0; }
        rows->nl[k] = e - rows->at[k];
        for (j = k + 1; j < r; j++) { col[e] = j; e += row[j] != 0.0; }
        rows->u[k] = e;
        for (j = r; j < MBS_NV; j++) { col[e] = j; e += row[j] != 0.0; }
    }
    rows->at[r] = e;
}

/* The null-space basis T (NV x m) by packed columns and c0 from the factors in w->G (rank r), whatever their
 * order: column j holds entries e = start[j] .. start[j + 1] - 1, the value T[e] at velocity Ti[e], for the
 * independent velocity cp[r + j] (1) and the dependent ones it moves, in velocity order; c0_D solves
 * G_D c0_D = -gddot0 (w->h) on the pivot rows, c0_I = 0 (c0_D also left in w->y, in pivot order).  Independent loops (blocks of G that share no column)
 * leave most of T zero: only its nonzeros are stored. */
static void mbs_loop_null_space(mbs_loop_work *w, int r, int *start, int *cpi)
{
    double *T = w->T;
    int *Ti = w->Ti, j, k;
    const int m = MBS_NV - r;
    mbs_loop_rows rows;
    mbs_loop_row_lists(w, r, &rows, cpi);
    {  /* U11 Y = -U12 (L11^-1 0 = 0): the dependent rows of all columns at once (Y in K, row stride NV), row by
        * row upwards, each row from the nonzeros of U11 and U12 (independent loops: a few per row) */
        const double *G = w->G;
        double *Y = w->K;
        int e = 0;
        for (k = r - 1; k >= 0; k--) {
            double *yk = Y + k * MBS_NV;
            const double d = G[k * MBS_NV + k];
            memset(yk, 0, m * sizeof(double));
            for (e = rows.u[k]; e < rows.at[k + 1]; e++) yk[rows.col[e] - r] = -G[k * MBS_NV + rows.col[e]];
            for (e = rows.at[k] + rows.nl[k]; e < rows.u[k]; e++) {
                const double u = G[k * MBS_NV + rows.col[e]];
                const double *yi = Y + rows.col[e] * MBS_NV;
                for (j = 0; j < m; j++) yk[j] -= u * yi[j];
            }
            for (j = 0; j < m; j++) yk[j] /= d;  /* other loops' columns stay 0 (no branch: it mispredicts) */
        }
        e = 0;
        for (j = 0; j < m; j++) {
            int first = start[j] = e;
            T[e] = 1.0;
            Ti[e++] = cpi[r + j];
            for (k = 0; k < r; k++)
                if (Y[k * MBS_NV + j] != 0.0) {  /* inserted in velocity order (the sums below read M along */
                    int at = e++;                 /* its rows in order) */
                    for (; at > first && Ti[at - 1] > cpi[k]; at--) {
                        T[at] = T[at - 1];
                        Ti[at] = Ti[at - 1];
                    }
                    T[at] = Y[k * MBS_NV + j];
                    Ti[at] = cpi[k];
                }
        }
        start[m] = e;
        /* c0: G_D c0_D = -gddot0 on the pivot rows, c0_I = 0 (mbs_loop_solve, by the row lists) */
        for (k = 0; k < r; k++) {
            double sum = -w->h[(int)w->rp[k]];
            for (e = rows.at[k]; e < rows.at[k] + rows.nl[k]; e++) sum -= G[k * MBS_NV + rows.col[e]] * w->y[rows.col[e]];
            w->y[k] = sum;
        }
        for (k = r - 1; k >= 0; k--) {
            double sum = w->y[k];
            for (e = rows.at[k] + rows.nl[k]; e < rows.u[k]; e++) sum -= G[k * MBS_NV + rows.col[e]] * w->y[rows.col[e]];
            w->y[k] = sum / G[k * MBS_NV + k];
        }
        memset(w->c0, 0, MBS_NV * sizeof(double));
        for (k = 0; k < r; k++) w->c0[cpi[k]] = w->y[k];
    }
}

/* T, start and c0 as mbs_loop_null_space, from factors of the kept partition made block by block (w->blocked,
 * mbs_loop_factor_blocks): each independent column's dependent velocities are those of its block, from that
 * block's U11 and U12 alone (the blocks' sizes, not r), and c0 likewise (c0_D in w->y too, in pivot order).  Block
 * by block (the plan lists the independent columns a block moves block by block, the unit ones last): c0_D's
 * forward substitution (unless the elimination did it, w->forward), then the back substitutions with U11 of c0_D
 * and of the block's first independent column in one pass (a loop's block has one such column on the Iltis: one
 * pass over U11 instead of two), then those of its other columns.  T's pattern depends on the plan alone (the
 * offsets of its columns, in the plan's start, their unit entries and velocities, and c0_I = 0): written by the
 * first call after another factorisation (the plan's clean flag 1), kept by the next ones (3), as are the exact zeros
 * of T^T M T between blocks that M does not couple (mbs_loop_accelerations). */
/* One block's part of mbs_loop_null_space_blocks (n pivot rows from position k0, its independent columns jl[j0 .. j1 - 1]
 * the plan lists), T's entries from *e on; inlined with n a constant for the sizes MBS_LOOP_BY_SIZE lists, its back
 * substitutions and its copies into T and c0 unrolled (the Iltis's loop algebra of a bump_10 rhs 9,945 -> 9,540
 * instructions, bench/loop_work.py; see MBS_LOOP_UNROLL for the CPU time). */
MBS_LOOP_INLINE void mbs_loop_null_space_block(mbs_loop_work *w, const int k0, const int n, const int j0, const int j1,
                                             const int *jl, int *start, const int *cpi, int *at, int pattern)
{
    const double *B = w->G + k0 * MBS_NV + k0;
    double *restrict T = w->T, *restrict c0 = w->c0, *y = w->y + k0, yt[MBS_NC];
    int *restrict Ti = w->Ti, j, k, c, e = *at;  /* (locals: a store through T, Ti or c0 changes none of them) */
    if (!w->forward) {
        for (k = 0; k < n; k++) {  /* L11 y = -gddot0 on the block's rows */
            const double *g = B + k * MBS_NV;
            double sum = -w->h[(int)w->rp[k0 + k]];
            for (c = 0; c < k; c++) sum -= g[c] * y[c];
            y[k] = sum;
        }
    }
    for (j = j0; j < j1; j++) {  /* U11 c0_D = y with (first column) U11 yt = -U12 e_j, upwards */
        const int col = jl[j] - k0;  /* relative to the block's first column */
        if (pattern) {  /* the column's offset, its unit entry and its velocities: the plan's, written once */
            start[j] = e;
            T[e] = 1.0;
            Ti[e] = cpi[jl[j]];
            MBS_LOOP_UNROLL
            for (k = 0; k < n; k++) Ti[e + 1 + k] = cpi[k0 + k];
        }
        e++;
        MBS_LOOP_UNROLL
        for (k = n - 1; k >= 0; k--) {
            const double *g = B + k * MBS_NV;
            double sum = -g[col];
            if (j == j0) {
                double s0 = y[k];
                MBS_LOOP_UNROLL
                for (c = k + 1; c < n; c++) {
                    s0 -= g[c] * y[c];
                    sum -= g[c] * yt[c];
                }
                y[k] = s0 / g[k];
            } else {
                MBS_LOOP_UNROLL
                for (c = k + 1; c < n; c++) sum -= g[c] * yt[c];
            }
            yt[k] = sum / g[k];
        }
        MBS_LOOP_UNROLL
        for (k = 0; k < n; k++) T[e + k] = yt[k];
        e += n;
    }
    if (j0 == j1) {  /* no independent column moves this block: c0_D alone */
        for (k = n - 1; k >= 0; k--) {
            double sum = y[k];
            for (c = k + 1; c < n; c++) sum -= B[k * MBS_NV + c] * y[c];
            y[k] = sum / B[k * MBS_NV + k];
        }
    }
    MBS_LOOP_UNROLL
    for (k = 0; k < n; k++) c0[cpi[k0 + k]] = y[k];
    *at = e;
}

static void mbs_loop_null_space_blocks(mbs_loop_work *w, int r, int *start, const int *cpi, const int pattern)
{
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    double *T = w->T;
    int *Ti = w->Ti, b, j, e = 0;
    const int m = MBS_NV - r;
    if (pattern) memset(w->c0, 0, MBS_NV * sizeof(double));  /* c0_I = 0, the blocks write c0_D */
    for (b = 0; b < *bl.nb; b++) {
        const int k0 = bl.k0[b], n = bl.k0[b + 1] - k0, j0 = bl.j0[b], j1 = bl.j0[b + 1];
#define MBS_LOOP_NULL_SPACE(size) mbs_loop_null_space_block(w, k0, size, j0, j1, bl.jl, start, cpi, &e, pattern)
        MBS_LOOP_BY_SIZE(n, MBS_LOOP_NULL_SPACE);
#undef MBS_LOOP_NULL_SPACE
    }
    w->forward = 0;  /* y is c0_D now */
    if (pattern) {
        for (j = bl.j0[*bl.nb]; j < m; j++) {  /* the unit columns */
            start[j] = e;
            T[e] = 1.0;
            Ti[e++] = cpi[r + j];
        }
        start[m] = e;
    }
}

/* r = the rank of G (just factored), or the rank of the extended rows at a singular position (then w->G holds
 * their factors and w->G0, w->h the rows themselves). */
static int mbs_loop_limit_rows(double t, const double *p, mbs_loop_work *w, int r, int *status)
{
    double pivot;
    *status = 0;
    if (!w->singular || !mbs_loop_singular_rows(t, p, w, r, status)) return r;
    memcpy(w->G, w->G0, MBS_NC * MBS_NV * sizeof(double));
    return mbs_loop_factor(w, &pivot);
}

#ifdef MBS_NLOADED
static int mbs_loop_lambda(mbs_loop_work *w, int r, double *lambda);

/* Bearing friction in the loops (compiler/friction_loops.py): the m kinetic forces F grow with the bearings'
 * loads, which come from the accelerations and multipliers, which depend on F.  All of it is affine in F: the
 * solve at F = 0 (f without them, mbs_forces) gives (a0, lambda0), the same factors give the response (Wv, Wl)
 * to each bearing's generalized force E_j (mbs_friction_directions), and mbs_friction_loads solves the bearing
 * laws exactly (a quadratic, or Newton's method on the tape for several); then f += E F, vdot += Wv F, and
 * each F_l rides on its row's multiplier (mbs_loop_multipliers_of).  The room: MBS_FRICTION_NWORK doubles at
 * the end of the loop solver's work, [x; a0; lambda0; Wv; Wl] first (the input of mbs_friction_loads). */
static double *mbs_loop_friction_area(const mbs_loop_work *w)
{
    return w->tree + MBS_TREE_NWORK + MBS_LOOP_NWORK - MBS_FRICTION_NWORK;
}

static int mbs_loop_bearing_friction(double t, const double *p, mbs_loop_work *w, int r, int dof, const int *start)
{
    const int m = MBS_NLOADED;
    double *xin = mbs_loop_friction_area(w), *a0 = xin + MBS_NX, *l0 = a0 + MBS_NV, *Wv = l0 + MBS_NC;
    double *Wl = Wv + MBS_NV * m, *E = Wl + MBS_NC * m, *F = E + MBS_NV * m, *g = F + m, *a = g + MBS_NV;
    double *vj = a + MBS_NV, *f0 = vj + MBS_NV, *lj = f0 + MBS_NV;
    const double *A = w->A, *T = w->T;
    const int *Ti = w->Ti;
    int i, j, k, l, e, s;
    memcpy(xin, w->xc, MBS_NX * sizeof(double));
    memcpy(a0, w->vd, MBS_NV * sizeof(double));
    memcpy(f0, w->f, MBS_NV * sizeof(double));
    if ((s = mbs_loop_lambda(w, r, l0)) != 0) return s;
    if ((s = mbs_friction_directions(t, w->xc, p, E, w->tree)) != 0) return s;
    for (l = 0; l < m; l++) {
        mbs_loop_work wj = *w;
        for (i = 0; i < MBS_NV; i++) g[i] = E[i * m + l];
        for (j = 0; j < dof; j++) {  /* T^T g, then the factors of T^T M T (as mbs_loop_accelerations) */
            double sum = 0.0;
            for (e = start[j]; e < start[j + 1]; e++) sum += T[e] * g[Ti[e]];
            a[j] = sum;
        }
        for (j = 0; j < dof; j++)
            for (k = 0; k < j; k++) a[j] -= A[k * MBS_NV + j] * a[k];  /* (L by columns: L_jk at A[k NV + j]) */
        for (j = 0; j < dof; j++) a[j] = A[j * MBS_NV + j] > 0.0 ? a[j] / A[j * MBS_NV + j] : 0.0;
        for (j = dof - 1; j >= 0; j--)
            for (k = j + 1; k < dof; k++) a[j] -= A[j * MBS_NV + k] * a[k];
        memset(vj, 0, MBS_NV * sizeof(double));
        for (j = 0; j < dof; j++)
            for (e = start[j]; e < start[j + 1]; e++) vj[Ti[e]] += T[e] * a[j];
        wj.f = g;  /* the multipliers of that response: M vj = g + G^T lj */
        wj.vd = vj;
        if ((s = mbs_loop_lambda(&wj, r, lj)) != 0) return s;
        for (i = 0; i < MBS_NV; i++) Wv[i * m + l] = vj[i];
        for (i = 0; i < MBS_NC; i++) Wl[i * m + l] = lj[i];
    }
    if ((s = mbs_friction_loads(t, xin, p, F, w->tree)) != 0) return s;
    for (i = 0; i < MBS_NV; i++)
        for (l = 0; l < m; l++) {
            w->f[i] += E[i * m + l] * F[l];
            w->vd[i] += Wv[i * m + l] * F[l];
        }
    return isfinite(mbs_loop_maxabs(w->vd, MBS_NV, NULL)) ? 0 : MBS_LOOP_NONFINITE;
}
#endif

/* mt += c times row u of M (symmetric: its column u), over the row's structural nonzeros (the generator's
 * table, compiler/ccode_loops.py mass_pattern) when the model has one, else the whole row (a contiguous run the
 * compiler vectorises; restrict: mt aliases no row of M). */
static inline void mbs_loop_mass_axpy(const double *restrict M, int u, double c, double *restrict mt)
{
    const double *restrict row = M + u * MBS_NV;
    int e;
#ifdef MBS_MASS_PATTERN
    int k;
    for (k = mbs_mass_row[u]; k < mbs_mass_row[u + 1]; k++)
        for (e = mbs_mass_begin[k]; e < mbs_mass_end[k]; e++) mt[e] += row[e] * c;
#else
    for (e = 0; e < MBS_NV; e++) mt[e] += row[e] * c;
#endif
}

/* M t for t given by its n nonzeros (values tv at velocities ti): a row of M itself when t is a unit column (an
 * independent velocity no loop moves, e.g. the car body's: nothing computed), else the rows of M (symmetric) at
 * those velocities summed into mt over their structural nonzeros, in the order of t's entries. */
static const double *mbs_loop_mass_times_column(const double *restrict M, const double *restrict tv,
                                                const int *ti, int n, double *restrict mt)
{
    int e;
    if (n == 1 && tv[0] == 1.0) return M + ti[0] * MBS_NV;
    memset(mt, 0, MBS_NV * sizeof(double));
    for (e = 0; e < n; e++) mbs_loop_mass_axpy(M, ti[e], tv[e], mt);
    return mt;
}

/* M T_j for a column j of T from block b of the kept plan (mbs_loop_reduced_mass_blocks) by the block's chunks of 4
 * columns (mbs_loop_plan_mass_chunks): each chunk's 4 sums over T_j's entries in their order, as
 * mbs_loop_mass_times_column adds them up (the same bits: the chunks' other columns add exact zeros to sums that
 * start at +0), in a vector register, one load, product and sum a row, where the rows' runs of 1 to 6 columns
 * took a scalar loop and its control a column (the Iltis: about 710 -> 360 instructions a column of T). */
MBS_LOOP_INLINE const double *mbs_loop_mass_times_block(const double *restrict M, const double *restrict tv,
                                                        const int *ti, const int n, const int *chunk,
                                                        double *restrict mt)
{
    int e, k, q;
    if (chunk[0] < 0) return mbs_loop_mass_times_column(M, tv, ti, n, mt);
    memset(mt, 0, MBS_NV * sizeof(double));
    for (q = 1; q <= chunk[0]; q += 2) {  /* two chunks at a time (an odd last one twice: the same values) */
        const int v0 = chunk[q], v1 = chunk[q + 1 <= chunk[0] ? q + 1 : q];
        double s0[4] = {0.0, 0.0, 0.0, 0.0}, s1[4] = {0.0, 0.0, 0.0, 0.0};
        MBS_LOOP_UNROLL
        for (e = 0; e < n; e++) {
            const double *restrict row = M + ti[e] * MBS_NV;
            const double c = tv[e];
            for (k = 0; k < 4; k++) s0[k] += row[v0 + k] * c;
            for (k = 0; k < 4; k++) s1[k] += row[v1 + k] * c;
        }
        for (k = 0; k < 4; k++) mt[v0 + k] = s0[k];
        for (k = 0; k < 4; k++) mt[v1 + k] = s1[k];
    }
    return mt;
}

/* a^T b over NV entries in four independent chains (a single running sum waits for its latency at every entry). */
static double mbs_loop_dot(const double *a, const double *b)
{
    double s[4] = {0.0, 0.0, 0.0, 0.0};
    int i, k;
    for (i = 0; i + 4 <= MBS_NV; i += 4)
        for (k = 0; k < 4; k++) s[k] += a[i + k] * b[i + k];
    for (; i < MBS_NV; i++) s[0] += a[i] * b[i];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

/* gddot0 into w->h, M and f at w->xc, and G there into w->G0: one call of the generated mbs_loop_terms (one pass
 * over the kinematics, compiler/ccode_loop_terms.py) when the model has it, else the separate functions (G0 then
 * as the caller left it).  M need not be definite (massless parts): no Cholesky check of it here. */
static int mbs_loop_terms_at(double t, const double *p, mbs_loop_work *w)
{
    int s;
#ifdef MBS_LOOP_TERMS
    s = mbs_loop_terms(t, w->xc, p, w->M, w->tree);
#else
    if ((s = mbs_constraint_acceleration(t, w->xc, p, w->h, w->tree)) != 0) return s;
#ifdef MBS_MASS_MATRIX_UNCHECKED
    s = mbs_mass_matrix_unchecked(t, w->xc, p, w->M, w->tree);
#else
    s = mbs_mass_matrix(t, w->xc, p, w->M, w->tree);  /* status 1 (M singular with massless parts) is no error */
#endif
    if (s != 0 && s != MBS_LOOP_SINGULAR) return s;
    s = mbs_forces(t, w->xc, p, w->f, w->tree);
#endif
    return s;
}

/* The lower triangle of A = T^T M T (m x m) by columns (A_ij at A[j NV + i], i >= j) and a = T^T (f - M c0) for
 * any T (packed columns): per column j of T, mt = M T_j (mbs_loop_mass_times_column: M's structural nonzeros at
 * T_j's few velocities, or a row of M for a unit column), then A_ij = T_i^T mt (i >= j) from the nonzeros of T_i,
 * and a_j = T_j^T f - mt^T c0 (c0 zero on the independent velocities).  Returns the largest diagonal entry of A (0 at
 * least). */
static double mbs_loop_reduced_mass(mbs_loop_work *w, int m, const int *start)
{
    const double *T = w->T, *M = w->M;
    const int *Ti = w->Ti;
    double *A = w->A, dmax = 0.0;
    int i, j;
    for (j = 0; j < m; j++) {
        const double *mt;
        double sum = 0.0;
        int e, f;
        mt = mbs_loop_mass_times_column(M, T + start[j], Ti + start[j], start[j + 1] - start[j], w->b);
        for (e = start[j]; e < start[j + 1]; e++) sum += T[e] * w->f[Ti[e]];
        w->a[j] = sum - mbs_loop_dot(mt, w->c0);
        for (i = j; i < m; i++) {
            f = start[i];
            if (start[i + 1] == f + 1 && T[f] == 1.0) {  /* a unit column: its velocity's entry (0 + 1 x = x) */
                A[j * MBS_NV + i] = mt[Ti[f]];
                continue;
            }
            for (sum = 0.0; f < start[i + 1]; f++) sum += T[f] * mt[Ti[f]];
            A[j * MBS_NV + i] = sum;  /* lower triangle, by columns */
        }
        dmax = A[j * MBS_NV + j] > dmax ? A[j * MBS_NV + j] : dmax;
    }
    return dmax;
}

/* Column j of A (its entries i >= j) and a_j for a column of T a loop's block moves (nt entries, its block's chunks of
 * M, the columns i < coupled of T that M couples with it, na such columns in all), as mbs_loop_reduced_mass_blocks
 * describes; inlined with nt a constant for the sizes MBS_LOOP_BY_SIZE lists (1 + the block's rows), its loops over
 * T_j's entries (and M T_j's, mbs_loop_mass_times_block) unrolled: the same arithmetic in the same order, T, T^T M T,
 * its factors and vdot of a bump_10 rhs 6,034 -> 5,422 instructions (bench/loop_work.py --baseline).  Returns A_jj. */
MBS_LOOP_INLINE double mbs_loop_reduced_column_block(mbs_loop_work *w, int r, const int *start, const int *cpi,
                                                   int j, const int nt, const int *chunk, int coupled, int na, int m,
                                                   int pattern)
{
    const double *T = w->T, *Tj = w->T + start[j], *f = w->f;
    const int *Ti = w->Ti, *Tij = w->Ti + start[j];
    const double *mt = mbs_loop_mass_times_block(w->M, Tj, Tij, nt, chunk, w->b);
    double *Aj = w->A + j * MBS_NV, sum = 0.0;
    int i, e;
    MBS_LOOP_UNROLL
    for (e = 0; e < nt; e++) sum += Tj[e] * f[Tij[e]];
    w->a[j] = sum - mbs_loop_dot(mt, w->c0);
    sum = 0.0;
    MBS_LOOP_UNROLL
    for (e = 0; e < nt; e++) sum += Tj[e] * mt[Tij[e]];
    Aj[j] = sum;
    for (i = j + 1; i < coupled; i++) {
        for (sum = 0.0, e = start[i]; e < start[i + 1]; e++) sum += T[e] * mt[Ti[e]];
        Aj[i] = sum;
    }
    if (pattern)  /* mt is zero at T_i's velocities: the sum is +0 (and L's entry 0 / D_j stays +0 in A) */
        for (; i < na; i++) Aj[i] = 0.0;
    i = na;
    for (; i < m; i++) Aj[i] = mt[cpi[r + i]];
    return Aj[j];
}

/* A and a as mbs_loop_reduced_mass forms them (the same arithmetic in the same order) for T from
 * mbs_loop_null_space_blocks: its first na columns are those a loop moves (its blocks' independent velocities), the
 * others unit columns (independent velocities no loop moves, the plan puts them last), so the kind of each entry
 * of A is known by its place, not tested: an entry of M T_j for a unit row, an entry of M itself where both
 * columns are unit ones, and an exact zero where M couples no velocity of T_i with one of T_j (another loop's
 * block beyond the reach of T_j's, mbs_loop_blocks_coupled).  Returns the largest diagonal entry. */
static double mbs_loop_reduced_mass_blocks(mbs_loop_work *w, int r, const int *start, const int *cpi, int pattern)
{
    const double *M = w->M;
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    const int m = MBS_NV - r, na = bl.j0[*bl.nb];
    double *A = w->A, dmax = 0.0;
    int i, j;
    for (j = 0; j < na; j++) {
        const int b = bl.block[r + j], n = start[j + 1] - start[j] - 1;  /* T_j: 1 + the block's rows (its size) */
        const int *chunk = bl.mchunk + (1 + MBS_LOOP_MASS_CHUNKS) * b;
        const int coupled = bl.j0[bl.reach[b] + 1];  /* the columns of T M couples with T_j's */
        double d;
#define MBS_LOOP_REDUCED_COLUMN(size) \
        d = mbs_loop_reduced_column_block(w, r, start, cpi, j, 1 + (size), chunk, coupled, na, m, pattern)
        MBS_LOOP_BY_SIZE(n, MBS_LOOP_REDUCED_COLUMN);
#undef MBS_LOOP_REDUCED_COLUMN
        dmax = d > dmax ? d : dmax;
    }
    for (; j < m; j++) {  /* a unit column: M T_j is row v of M (symmetric), T_j^T f is 0 + 1 f_v */
        const double *mt = M + cpi[r + j] * MBS_NV;
        w->a[j] = (0.0 + w->f[cpi[r + j]]) - mbs_loop_dot(mt, w->c0);
        for (i = j; i < m; i++) A[j * MBS_NV + i] = mt[cpi[r + i]];
        dmax = A[j * MBS_NV + j] > dmax ? A[j * MBS_NV + j] : dmax;
    }
    return dmax;
}

/* A = L D L^T in place (A's lower triangle by columns, as mbs_loop_reduced_mass writes it: L_ij at A[j NV + i] below
 * the diagonal, D_j on it); a pivot below MBS_LOOP_MASS_TOL times dmax, the largest diagonal entry, is a motion without
 * inertia (L's column and D_j zero).  By columns, each one's updates to the columns after it as they come (column j
 * of A less L_jk D_k times column k of L, for k = 0 .. j - 1 in turn): for each entry the products and differences
 * the rows' inner products took before (L_ik (L_jk D_k), in the order of k), each column one contiguous update
 * instead of a short inner product an entry; a column whose L_jk is zero (another loop's block that M does not
 * couple) is skipped, where the inner products skipped the zeros left of each row's first nonzero: the same values
 * (exact zeros subtracted or not; at most the sign of a zero differs).  The forward substitution L y = a and the
 * division by D ride along, column k of L once it is done (a_k final then), as the solve took them.  Inlined with m a
 * constant for NV - NC (MBS_LOOP_BY_REDUCED_SIZE), its loops unrolled whole: the same arithmetic (the two columns in
 * one pass over column k that it took before gave each entry the same product and difference), the Iltis's loop
 * algebra of a bump_10 rhs 11,986 -> 10,696 instructions (bench/loop_work.py --baseline). */
MBS_LOOP_INLINE int mbs_loop_reduced_factor_sized(double *A, const int m, double dmax, double *restrict a)
{
    int j, k, i;
    MBS_LOOP_UNROLL_ALL
    for (k = 0; k < m; k++) {
        double *ck = A + k * MBS_NV, d = ck[k];
        if (!isfinite(d)) return MBS_LOOP_NONFINITE;
        if (d < -1e3 * MBS_LOOP_MASS_TOL * dmax) return MBS_LOOP_SINGULAR;  /* indefinite: a negative mass */
        if (!(d > MBS_LOOP_MASS_TOL * dmax)) {  /* (and its acceleration 0) */
            MBS_LOOP_UNROLL_ALL
            for (j = k; j < m; j++) ck[j] = 0.0;
            a[k] = 0.0;
            continue;
        }
        MBS_LOOP_UNROLL_ALL
        for (j = k + 1; j < m; j++) ck[j] /= d;  /* L's column */
        MBS_LOOP_UNROLL_ALL
        for (i = k + 1; i < m; i++) a[i] -= ck[i] * a[k];  /* the forward substitution's column k (a_k is final) */
        a[k] /= d;
        MBS_LOOP_UNROLL_ALL
        for (j = k + 1; j < m; j++) {
            double *restrict cj = A + j * MBS_NV;
            const double ld = ck[j] * d;  /* L_jk D_k */
            if (ld == 0.0) continue;
            MBS_LOOP_UNROLL_ALL
            for (i = j; i < m; i++) cj[i] -= ck[i] * ld;
        }
    }
    return 0;
}

/* a = L^-T a with the factors of mbs_loop_reduced_factor, which took a through L^-1 and D^-1 already (zero pivots: 0),
 * by rows of L^T (L's columns), back. */
MBS_LOOP_INLINE void mbs_loop_reduced_solve_sized(const double *A, const int m, double *restrict a)
{
    int j, k;
    MBS_LOOP_UNROLL_ALL
    for (j = m - 1; j >= 0; j--) {
        const double *cj = A + j * MBS_NV;
        double s = a[j];
        MBS_LOOP_UNROLL_ALL
        for (k = j + 1; k < m; k++) s -= cj[k] * a[k];
        a[j] = s;
    }
}

/* a = (T^T M T)^-1 a: its factors (in place of A) and the solve. */
static int mbs_loop_reduced_factor_solve(double *A, int m, double dmax, double *restrict a)
{
    int s = 0;
#define MBS_LOOP_REDUCED(size) \
    if ((s = mbs_loop_reduced_factor_sized(A, size, dmax, a)) == 0) mbs_loop_reduced_solve_sized(A, size, a)
    MBS_LOOP_BY_REDUCED_SIZE(m, MBS_LOOP_REDUCED);
#undef MBS_LOOP_REDUCED
    return s;
}

/* One column of T a (nt entries from e) added into vd; inlined with nt a constant for the sizes MBS_LOOP_BY_SIZE lists
 * (1 + a block's rows). */
MBS_LOOP_INLINE void mbs_loop_vdot_column(double *restrict vd, const double *restrict T, const int *Ti, const int nt,
                                        double aj)
{
    int e;
    MBS_LOOP_UNROLL
    for (e = 0; e < nt; e++) vd[Ti[e]] += T[e] * aj;
}

/* vd += T a for T from mbs_loop_null_space_blocks: its columns of the loops' blocks with their sizes, then its unit
 * columns, one entry 1 each (1 a_j is a_j: the same sums). */
static void mbs_loop_vdot_blocks(mbs_loop_work *w, int r, const int *start)
{
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    const int m = MBS_NV - r, na = bl.j0[*bl.nb];
    const double *T = w->T, *a = w->a;
    const int *Ti = w->Ti;
    double *restrict vd = w->vd;
    int j;
    for (j = 0; j < na; j++) {
        const int n = start[j + 1] - start[j] - 1;
#define MBS_LOOP_VDOT(size) mbs_loop_vdot_column(vd, T + start[j], Ti + start[j], 1 + (size), a[j])
        MBS_LOOP_BY_SIZE(n, MBS_LOOP_VDOT);
#undef MBS_LOOP_VDOT
    }
    for (; j < m; j++) vd[Ti[start[j]]] += a[j];
}

/* vdot at the state w->xc (G factored there with rank r, h = g_t) into w->vd; *r updated at a singular
 * position (mbs_loop_limit_rows). */
static int mbs_loop_accelerations(double t, const double *p, mbs_loop_work *w, int *rank)
{
    int r = *rank, m;
    double *T = w->T, *A = w->A, dmax;
    int *Ti = w->Ti, own_start[MBS_NV + 1], *start = own_start, cpi[MBS_NV];
    int j, k, s;
    if (w->terms)  /* M, f, G0 and gddot0 at w->xc already (mbs_loop_rhs_direct): once only (a second solve at
                    * the same state finds h replaced at a singular position) */
        w->terms = 0;
    else if ((s = mbs_loop_terms_at(t, p, w)) != 0)
        return s;
    r = *rank = mbs_loop_limit_rows(t, p, w, r, &s);
    if (s != 0) return s;
    if (r < 0) return MBS_LOOP_NONFINITE;
    m = MBS_NV - r;
    /* the null-space basis T (NV x m, packed columns) and c0 */
    if (w->blocked) {  /* the kept columns as ints from its plan (w->cp holds them as doubles), T's offsets there */
        const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
        const int pattern = *bl.clean != 3;  /* (clean 1 or 3 here: these blocks' factors) */
        start = bl.start;
        mbs_loop_null_space_blocks(w, r, start, bl.col, pattern);
        /* the kept partition's columns of T in the order of its plan */
        dmax = mbs_loop_reduced_mass_blocks(w, r, start, bl.col, pattern);
        *bl.clean = 3;  /* T's pattern and A's exact zeros between uncoupled blocks written (A's stay: L's entries
                         * there are 0 / D_j, and no update reaches them) */
    } else {
        mbs_loop_null_space(w, r, start, cpi);
        dmax = mbs_loop_reduced_mass(w, m, start);
    }
    if ((s = mbs_loop_reduced_factor_solve(A, m, dmax, w->a)) != 0) return s;
    /* vdot = T a + c0 */
    memcpy(w->vd, w->c0, MBS_NV * sizeof(double));
    if (w->blocked)
        mbs_loop_vdot_blocks(w, r, start);
    else
        for (j = 0; j < m; j++) {
            double *restrict vd = w->vd;
            const double aj = w->a[j];  /* (once: vd's entries are doubles too) */
            for (k = start[j]; k < start[j + 1]; k++) vd[Ti[k]] += T[k] * aj;
        }
#ifdef MBS_NLOADED
    if (mbs_loop_finite(w->vd, MBS_NV)) return mbs_loop_bearing_friction(t, p, w, r, m, start);
#endif
    return mbs_loop_finite(w->vd, MBS_NV) ? 0 : MBS_LOOP_NONFINITE;
}

/* Rows outside the partition were dropped as dependent on its rows: they must hold too.  Checked on the
 * accelerations (max |G vdot + gddot0| over all rows against the size of the terms), it catches a kept
 * partition whose rank has become too small (chosen at a singular position). */
static int mbs_loop_rows_hold(const mbs_loop_work *w)
{
    double worst = 0.0, scale = mbs_loop_maxabs(w->h, MBS_NC, NULL), gmax = 0.0;
    double vmax = mbs_loop_maxabs(w->vd, MBS_NV, NULL);
    int i, c;
    for (i = 0; i < MBS_NC; i++) {  /* over the row's structural nonzeros (mbs_colour_column): the rest are zeros */
        double sum = w->h[i];
        for (c = 0; c < MBS_NCOLOUR; c++) {
            const int j = mbs_colour_column[i * MBS_NCOLOUR + c];
            if (j >= 0) {
                sum += w->G0[i * MBS_NV + j] * w->vd[j];
                gmax = fmax(gmax, fabs(w->G0[i * MBS_NV + j]));
            }
        }
        worst = fmax(worst, fabs(sum));
    }
    return worst <= MBS_LOOP_ROWS_HOLD * (scale + gmax * vmax);
}

/* vdot at w->xc (G evaluated there by mbs_loop_jacobian_at) into w->vd, with the partition (and its rank in
 * *rank) that solved it.  *rank >= 0 on entry: G is factored already (with that rank), e.g. by the projection. */
static int mbs_loop_solve_accelerations(double t, const double *p, mbs_loop_work *w, int adopt, int *rank,
                                        mbs_loop_info *info)
{
    int s;
    if (*rank < 0 && (*rank = mbs_loop_partition(t, w->xc, p, w, adopt, info)) < 0) return MBS_LOOP_NONFINITE;
    s = mbs_loop_accelerations(t, p, w, rank);
    /* with every row a pivot row (rank NC) none was dropped: they hold by construction */
    if (s == 0 && !w->fresh && *rank < MBS_NC && !mbs_loop_rows_hold(w)) {  /* forget it, choose afresh here */
        w->keep[0] = 0.0;
        if ((s = mbs_loop_jacobian_at(t, w->xc, p, w, 0)) != 0) return s;
        if ((*rank = mbs_loop_partition(t, w->xc, p, w, adopt, info)) < 0) return MBS_LOOP_NONFINITE;
        s = mbs_loop_accelerations(t, p, w, rank);
    }
    return s;
}

/* z' of the extra states (MBS_NZ, compiler/ccode_loops.py state_rates_routine) at the state x the solver used,
 * after [qdot; vdot] in xdot; nothing without them.  The projection leaves z alone (it copies all of x). */
static int mbs_loop_state_rates(double t, const double *x, const double *p, double *xdot, mbs_loop_work *w)
{
#if defined(MBS_NZ) && MBS_NZ > 0
    return mbs_state_rates(t, x, p, xdot + MBS_NQ + MBS_NV, w->tree);
#else
    (void)t; (void)x; (void)p; (void)xdot; (void)w;
    return 0;
#endif
}

/* Project x onto the constraints (mode as mbs_loop_project_state) and solve for the accelerations there; r is the
 * rank the solve used. The projection leaves G factored at the projected state w->xc. */
static int mbs_loop_project_and_solve(double t, const double *x, const double *p, mbs_loop_work *w, int mode, int *r)
{
    mbs_loop_info info;
    int s = mbs_loop_project_state(t, x, p, w, mode, &info);
    *r = info.rank;
    if (s == 0) s = mbs_loop_solve_accelerations(t, p, w, mode, r, &info);
    return s;
}

/* x' = [q'; v'; z'] at the projected state after mbs_loop_project_and_solve. */
static int mbs_loop_rates_at_projection(double t, const double *p, double *xdot, mbs_loop_work *w)
{
    int s = mbs_qdot(t, w->xc, p, xdot, w->tree);
    if (s == 0) memcpy(xdot + MBS_NQ, w->vd, MBS_NV * sizeof(double));
    if (s == 0) s = mbs_loop_state_rates(t, w->xc, p, xdot, w);
    return s;
}

/* ---- the functions of the model table (exported: a standalone library offers them too) ------------- */

#ifdef MBS_CLOSED_FORM
/* Loops closed in closed form (compiler/closed_form_loops.py, the model's mbs_closed_form_*): tried first by the
 * right-hand sides and the projection; the numeric path below only where they decline (status != 0: off their
 * branch, near a singular position, a value not finite).  Their scratch follows the kept partition. */
#if MBS_CF_SCRATCH < MBS_TREE_NWORK + MBS_LOOP_KEEP_SIZE
#error "the closed form's scratch overlaps the kept partition"
#endif
/* Where the stamp of mbs_loop_rhs_direct lies: the closed form's scratch overwrites the factors it vouches for.
 * (Inline: the layout's other pointers are dead, what is left is one addition.) */
static inline double *mbs_loop_stamp_of(double *work)
{
    const mbs_loop_work w = mbs_loop_layout_keeping(work);
    return w.stamp;
}
#define MBS_CLOSED_FORM_FIRST(call) \
    do { if ((call) == 0) { mbs_loop_stamp_of(work)[0] = 0.0; return 0; } } while (0)
#else
#define MBS_CLOSED_FORM_FIRST(call) ((void)0)
#endif

/* x' at the projected state: robust for integrators that cannot project (scipy's), and the mbs_rhs of every
 * other consumer (linearisation, outputs, equilibrium). */
int mbs_loop_rhs(double t, const double *x, const double *p, double *xdot, double *work)
{
    mbs_loop_work w;
    int r, s;
    MBS_CLOSED_FORM_FIRST(mbs_closed_form_rhs(t, x, p, xdot, work));  /* before the layout: it costs */
    w = mbs_loop_layout(work);
    s = mbs_loop_project_and_solve(t, x, p, &w, 1, &r);
    if (s == 0) s = mbs_loop_rates_at_projection(t, p, xdot, &w);
    if (s == 0 && MBS_LOOP_STABILIZE > 0) {
        int i;
        for (i = 0; i < MBS_NX; i++) xdot[i] += MBS_LOOP_STABILIZE * (w.xc[i] - x[i]);
    }
    return s;
}

static void mbs_loop_stamp_store(double t, const double *x, const double *p, mbs_loop_work *w, int r);
static void mbs_loop_projected_store(double t, const double *p, mbs_loop_work *w, int r);
int mbs_project(double t, const double *x, const double *p, double *out, double *work);

/* x' at x itself, without projection, by the kept partition: the right-hand side of the C integrators, which
 * project every accepted state (ode.c) so that the state stays on the constraints; between accepted states
 * the partition does not change, so x' is as smooth as the mechanism. */
int mbs_loop_rhs_direct(double t, const double *x, const double *p, double *xdot, double *work)
{
    mbs_loop_work w;
    mbs_loop_info info;
    int r, s;
    MBS_CLOSED_FORM_FIRST(mbs_closed_form_rhs(t, x, p, xdot, work));
    w = mbs_loop_layout(work);
    memset(&info, 0, sizeof info);
    memcpy(w.xc, x, MBS_NX * sizeof(double));
#ifdef MBS_LOOP_TERMS  /* G with M, f and gddot0 from one pass over the kinematics */
    s = mbs_loop_terms_at(t, p, &w);
    w.terms = s == 0;
#else
    s = mbs_loop_jacobian_at(t, x, p, &w, 0);
#endif
    r = -1;
    if (s == 0) s = mbs_loop_solve_accelerations(t, p, &w, 0, &r, &info);
    if (s == 0) s = mbs_qdot(t, x, p, xdot, w.tree);
    if (s == 0) memcpy(xdot + MBS_NQ, w.vd, MBS_NV * sizeof(double));
    if (s == 0) s = mbs_loop_state_rates(t, x, p, xdot, &w);
    if (s == 0 && !w.fresh && !w.singular && r == (int)w.keep[1]) mbs_loop_stamp_store(t, x, p, &w, r);
    return s;
}

/* ---- the projection of an accepted step from the factors its last stage left (mbs_loop_project_step) ---- */

/* The stamp's factors hold for the parameters they were computed with only: the stamp keeps a copy of p after
 * its q (MBS_LOOP_STAMP_SIZE), compared bit for bit.  Every rhs of DOPRI5 stores a stamp: the copy is a memcpy
 * (about 120 instructions for the Iltis's 163 parameters), where a hash of the bits took 830 (1.3 % of its
 * loop_rhs), and it cannot collide. */
static inline double *mbs_loop_stamp_p(const mbs_loop_work *w)
{
    return w->stamp + 4 + MBS_NQ;
}

static void mbs_loop_stamp_p_store(mbs_loop_work *w, const double *p)
{
    memcpy(mbs_loop_stamp_p(w), p, MBS_NP * sizeof(double));
}

static int mbs_loop_stamp_p_holds(const mbs_loop_work *w, const double *p)
{
    return memcmp(mbs_loop_stamp_p(w), p, MBS_NP * sizeof(double)) == 0;
}

/* The factors of G at the stamp's positions serve positions within MBS_LOOP_STAMP_NEAR of them (relative):
 * DOPRI5's last stage is at its accepted state itself (bit for bit); Adams' last evaluation is at the predicted
 * state, which the corrector moves by the step's local error (about rtol).  With G off by that much, each polishing
 * Newton step still cuts the position residual by about that factor, and the velocities' one correction leaves a
 * residual of (G(q_c) - G(q_stamp)) dv: the product of two small quantities.  A residual the polish does not take
 * below MBS_LOOP_TOL still goes the way of mbs_project. */
#define MBS_LOOP_STAMP_NEAR 1e-6

static inline double mbs_loop_stamp_q_off(const double *stamp_q, const double *x, int i)
{
    return fabs(stamp_q[i] - x[i]) - MBS_LOOP_STAMP_NEAR * (1.0 + fabs(x[i]));  /* > 0: off (the sign of a - b is
                                                                                  * exact: b < a for finite ones) */
}

static int mbs_loop_stamp_q_near(const double *stamp_q, const double *x)
{
    /* no exit at the first coordinate off (the stamp holds at almost every step): four independent chains without a
     * branch, as mbs_loop_gmax, 4 coordinates in one vector; probe stays 0 unless a difference is NaN */
    double m[4] = {0.0, 0.0, 0.0, 0.0}, probe[4] = {0.0, 0.0, 0.0, 0.0};
    int i, k;
    for (i = 0; i + 4 <= MBS_NQ; i += 4)
        for (k = 0; k < 4; k++) {
            const double off = mbs_loop_stamp_q_off(stamp_q, x, i + k);
            m[k] = off > m[k] ? off : m[k];
            probe[k] += 0.0 * off;
        }
    for (; i < MBS_NQ; i++) {
        const double off = mbs_loop_stamp_q_off(stamp_q, x, i);
        m[0] = off > m[0] ? off : m[0];
        probe[0] += 0.0 * off;
    }
    return m[0] <= 0.0 && m[1] <= 0.0 && m[2] <= 0.0 && m[3] <= 0.0
           && (probe[0] + probe[1]) + (probe[2] + probe[3]) == 0.0;
}

/* Remember that w->G holds the factors of G at (t, q of x, p) with the kept partition of rank r. */
static void mbs_loop_stamp_store(double t, const double *x, const double *p, mbs_loop_work *w, int r)
{
    w->stamp[0] = MBS_LOOP_KEEP_MARK;
    w->stamp[1] = t;
    w->stamp[3] = r;
    memcpy(w->stamp + 4, x, MBS_NQ * sizeof(double));
    mbs_loop_stamp_p_store(w, p);
}

/* Does the stamp hold for (t, q of x, p), with the partition still the kept one? */
static int mbs_loop_stamp_holds(double t, const double *x, const double *p, const mbs_loop_work *w)
{
    return w->stamp[0] == MBS_LOOP_KEEP_MARK && w->stamp[1] == t && w->keep[0] == MBS_LOOP_KEEP_MARK
           && w->stamp[3] == w->keep[1] && mbs_loop_stamp_q_near(w->stamp + 4, x)
           && mbs_loop_stamp_p_holds(w, p);
}

/* The drift of the positions an accepted step keeps (mbs_loop_project_stamped), as mbs_loop_step_drift set it in this
 * work, with the kept partition's pivots clear of a singular position (MBS_LOOP_STEP_KEPT_PIVOT; the stamp holds for
 * the kept partition only); else MBS_LOOP_STEP_KEPT. */
static double mbs_loop_step_kept(const mbs_loop_work *w)
{
    const double kept = w->stamp[2];
    return kept > MBS_LOOP_STEP_KEPT && kept <= MBS_LOOP_STEP_KEPT_MAX && w->keep[2] >= MBS_LOOP_STEP_KEPT_PIVOT
               ? kept : MBS_LOOP_STEP_KEPT;
}

/* The run's tolerances to the projection of its accepted steps in this work (the glue's Solver, c/mbs_python.c):
 * atol its smallest absolute tolerance.  Without it an accepted step keeps a drift of MBS_LOOP_STEP_KEPT. */
void mbs_loop_step_drift(double *work, double atol)
{
    const mbs_loop_work w = mbs_loop_layout_keeping(work);
    const double kept = MBS_LOOP_STEP_KEPT_ATOL * atol;
    w.stamp[2] = kept > MBS_LOOP_STEP_KEPT ? (kept < MBS_LOOP_STEP_KEPT_MAX ? kept : MBS_LOOP_STEP_KEPT_MAX)
                                           : MBS_LOOP_STEP_KEPT;
}

/* The velocities of w->xc made consistent with its positions from the rate of the residuals there, gdot = G v + g_t:
 * v_D += dv_D with G_D dv_D = -gdot on the pivot rows (factors of rank r at hand), dv_I = 0. */
static void mbs_loop_correct_velocities(mbs_loop_work *w, int r, const double *gdot)
{
    memset(w->dv, 0, MBS_NV * sizeof(double));
    mbs_loop_solve(w, r, gdot, w->dv);
    mbs_loop_add(w->xc + MBS_NQ, w->dv, MBS_NV);
}

/* x projected as mbs_project does, from the factors of G the last mbs_loop_rhs_direct left at these positions or
 * near them (Adams' predicted state: mbs_loop_stamp_q_near): the integrated state of an accepted step is the
 * state of its last stage (DOPRI5's first-same-as-last) or its corrected prediction (Adams), already
 * on the position constraints to the integration's drift (about 1e-13), so the projection is one residual, the
 * polishing Newton steps of mbs_loop_positions_iterate with those factors, and the velocities from one gdot,
 * instead of two fresh evaluations and factorisations of G.  The velocities use G at the positions before the
 * polish (it moves them by the drift: G changes by that relatively).  Anything else (no stamp, another state, a
 * residual above MBS_LOOP_STEP_DRIFT, or above MBS_LOOP_TOL after the polish) goes the way of mbs_project. */
static int mbs_loop_project_stamped(double t, const double *x, const double *p, mbs_loop_work *w)
{
    double *q = w->xc, *gdot = w->c3, res, after, kept = mbs_loop_step_kept(w);
    const int r = (int)w->stamp[3];
    int s, rated;  /* rated: the last evaluation gave gdot at the positions left (mbs_loop_residuals) */
    w->blocked = mbs_loop_plan_holds(w);  /* the stamp holds only for factors of the kept partition: its blocks' */
    memcpy(w->xc, x, MBS_NX * sizeof(double));
    if ((s = mbs_loop_residuals(t, q, p, w, 1)) != 0) return s;
    after = res = mbs_loop_maxabs(w->g, MBS_NC, NULL);
    if (!(res <= MBS_LOOP_STEP_DRIFT)) return -1;
    if (res > kept && (s = mbs_loop_polish(t, q, p, w, r, res, &after, 1)) != 0) return s;
    rated = after >= 0.0;
    if (res > MBS_LOOP_TOL && res > kept) {  /* drifted beyond the tolerance (and the drift kept): within it after
                                              * the polish, else projected afresh; the polish's last residual is that
                                              * of the positions it left unless it undid a step (the same constraints
                                              * at the same positions: the same bits) */
        if (after < 0.0 || MBS_LOOP_RECHECK_FORMER) {
            if ((s = mbs_loop_residuals(t, q, p, w, 1)) != 0) return s;
            after = mbs_loop_maxabs(w->g, MBS_NC, NULL);
            rated = 1;
        }
        if (!(after <= MBS_LOOP_TOL)) return -1;
    }
    /* v_D += dv_D with G_D dv_D = -(G v + g_t) on the pivot rows, dv_I = 0 */
    if (rated && MBS_LOOP_RATES)
        gdot = mbs_loop_rates_of(w);
    else if ((s = mbs_constraint_velocity(t, w->xc, p, gdot, w->tree)) != 0)
        return s;
    mbs_loop_correct_velocities(w, r, gdot);
    return mbs_loop_finite(w->xc, MBS_NX) ? 0 : MBS_LOOP_NONFINITE;  /* (where, as mbs_loop_maxabs tells, unused) */
}

/* mbs_project for the C integrators' accepted steps (ode.c, mbs_ode_accept; the glue sets it with
 * mbs_loop_rhs_direct): the stamped factors of the step's last stage when they hold (mbs_loop_project_stamped),
 * else mbs_project. */
int mbs_loop_project_step(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_loop_work w = mbs_loop_layout_keeping(work);
    const uintptr_t from = (uintptr_t)x, to = (uintptr_t)out, size = MBS_NX * sizeof(double);
    int s = -1;
    if (mbs_loop_stamp_holds(t, x, p, &w)) {
        if (to + size <= from || from + size <= to) w.xc = out;  /* projected in out itself, x left alone: no copy */
        s = mbs_loop_project_stamped(t, x, p, &w);
    }
    w.stamp[0] = 0.0;
    if (s != 0) return mbs_project(t, x, p, out, work);
    if (w.xc != out) memcpy(out, w.xc, MBS_NX * sizeof(double));
    return 0;
}

/* out = [x' at x (NX); x projected as an accepted step (NX)]: the last stage of a DOPRI5 step and the projection
 * of its accepted state, what the glue's integrator does at the end of each step (bench/iltis.py times it
 * against mbs_loop_rhs_direct and mbs_project called one after the other). */
int mbs_loop_accept(double t, const double *x, const double *p, double *out, double *work)
{
    int s = mbs_loop_rhs_direct(t, x, p, out, work);
    return s != 0 ? s : mbs_loop_project_step(t, x, p, out + MBS_NX, work);
}

int mbs_project(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_loop_work w;
    mbs_loop_info info;
    int s;
    MBS_CLOSED_FORM_FIRST(mbs_closed_form_project(t, x, p, out, work));
    w = mbs_loop_layout(work);
    s = mbs_loop_project_state(t, x, p, &w, 1, &info);
    memcpy(out, w.xc, MBS_NX * sizeof(double));
    if (s == 0) mbs_loop_projected_store(t, p, &w, info.rank);
    return s;
}

/* sum + (row c of M) v over the row's structural nonzeros (the generator's table, as mbs_loop_mass_axpy) in column
 * order: the terms of the whole row but its exact zeros (whose products, v being finite, add nothing), so the same
 * sum but for the sign of a zero. */
static double mbs_loop_mass_row_dot(const double *restrict M, int c, const double *restrict v, double sum)
{
    const double *restrict row = M + c * MBS_NV;
    int e;
#ifdef MBS_MASS_PATTERN
    if (!MBS_LOOP_LAMBDA_FORMER) {
        int k;
        for (k = mbs_mass_row[c]; k < mbs_mass_row[c + 1]; k++)
            for (e = mbs_mass_begin[k]; e < mbs_mass_end[k]; e++) sum += row[e] * v[e];
        return sum;
    }
#endif
    for (e = 0; e < MBS_NV; e++) sum += row[e] * v[e];
    return sum;
}

/* One block's part of mbs_loop_lambda (n pivot rows from position k0), inlined with n a constant for the sizes
 * MBS_LOOP_BY_SIZE lists. */
MBS_LOOP_INLINE void mbs_loop_lambda_block(mbs_loop_work *w, const int k0, const int n)
{
    const double *B = w->G + k0 * MBS_NV + k0;
    double *y = w->y + k0;
    int i, j, k;
    MBS_LOOP_UNROLL
    for (k = 0; k < n; k++) {
        double sum = mbs_loop_mass_row_dot(w->M, (int)w->cp[k0 + k], w->vd, -w->f[(int)w->cp[k0 + k]]);
        MBS_LOOP_UNROLL
        for (j = 0; j < k; j++) sum -= B[j * MBS_NV + k] * y[j];  /* U11^T y = b */
        y[k] = sum / B[k * MBS_NV + k];
    }
    MBS_LOOP_UNROLL
    for (k = n - 1; k >= 0; k--) {  /* L11^T z = y */
        MBS_LOOP_UNROLL
        for (i = k + 1; i < n; i++) y[k] -= B[i * MBS_NV + k] * y[i];
    }
}

/* lambda from the accelerations just solved (w->vd, with M, f and the factors of G at w->xc, rank r). */
static int mbs_loop_lambda(mbs_loop_work *w, int r, double *lambda)
{
    const mbs_loop_blocks bl = mbs_loop_plan_blocks(w);
    const int blocks = !MBS_LOOP_ROWS_FORMER && w->blocked && bl.k0[*bl.nb] == r;
    int k, b;
    /* b = (M vdot - f) on the dependent columns; G_RD^T lambda_R = b with G_RD = L11 U11; with the kept
     * partition's factors block by block (the entries of L11 and U11 outside a block are exact zeros) */
    if (!blocks)
        mbs_loop_lambda_block(w, 0, r);
    else
        for (b = 0; b < *bl.nb; b++) {
            const int k0 = bl.k0[b], n = bl.k0[b + 1] - k0;
#define MBS_LOOP_LAMBDA(size) mbs_loop_lambda_block(w, k0, size)
            MBS_LOOP_BY_SIZE(n, MBS_LOOP_LAMBDA);
#undef MBS_LOOP_LAMBDA
        }
    memset(lambda, 0, MBS_NC * sizeof(double));
    for (k = 0; k < r; k++) lambda[(int)w->rp[k]] = w->y[k];
    return isfinite(mbs_loop_maxabs(lambda, MBS_NC, NULL)) ? 0 : MBS_LOOP_NONFINITE;
}

/* The multipliers of the rows; with bearing friction in the loops each bearing's kinetic force on its row's. */
static int mbs_loop_multipliers_of(mbs_loop_work *w, int r, double *lambda)
{
    int s = mbs_loop_lambda(w, r, lambda);
#ifdef MBS_NLOADED
    {
        const double *F = mbs_loop_friction_area(w) + MBS_NX + MBS_NV + MBS_NC
                          + (MBS_NV + MBS_NC + MBS_NV) * MBS_NLOADED;  /* after [x; a0; lambda0; Wv; Wl] and E */
        int l;
        for (l = 0; l < MBS_NLOADED; l++) lambda[mbs_loaded_row[l]] += F[l];
    }
#endif
    return s;
}

int mbs_loop_multipliers(double t, const double *x, const double *p, double *lambda, double *work)
{
    mbs_loop_work w = mbs_loop_layout(work);
    int r, s = mbs_loop_project_and_solve(t, x, p, &w, 0, &r);
    return s != 0 ? s : mbs_loop_multipliers_of(&w, r, lambda);
}

/* The stamp mbs_project leaves (a marker apart from mbs_loop_stamp_store's): w->xc is the state it returned, G is
 * factored there with the partition of rank r and h = g_t (gdot after a row's projection with MBS_LOOP_ROW_RATES:
 * the solve that follows replaces h by gddot0 before reading it), for (t, p); with the flags of those factors
 * (packed, in the room of q: a model with one position coordinate has no room and always projects). */
#define MBS_LOOP_PROJECTED_MARK 2791.0
#define MBS_LOOP_PROJECTED_STAMP (MBS_NQ >= 2)

static void mbs_loop_projected_store(double t, const double *p, mbs_loop_work *w, int r)
{
    w->stamp[0] = MBS_LOOP_PROJECTED_MARK;
    w->stamp[1] = t;
    w->stamp[3] = r;
    mbs_loop_stamp_p_store(w, p);
    if (!MBS_LOOP_PROJECTED_STAMP) {
        w->stamp[0] = 0.0;
        return;
    }
    w->stamp[4] = w->fresh + 2 * w->singular + 4 * w->blocked + 8 * w->rband;
    w->stamp[5] = w->pivot;
}

/* Is x the state the last mbs_project in this work returned, for (t, p)?  Then its factors are restored into w
 * (the flags, and the rank in *r). */
static int mbs_loop_projected_holds(double t, const double *x, const double *p, mbs_loop_work *w, int *r)
{
    if (!(w->stamp[0] == MBS_LOOP_PROJECTED_MARK && w->stamp[1] == t
          && memcmp(w->xc, x, MBS_NX * sizeof(double)) == 0 && mbs_loop_stamp_p_holds(w, p)))
        return 0;
    *r = (int)w->stamp[3];
    w->fresh = (int)w->stamp[4] & 1;
    w->singular = ((int)w->stamp[4] >> 1) & 1;
    w->blocked = ((int)w->stamp[4] >> 2) & 1;
    w->rband = (int)w->stamp[4] >> 3;
    w->pivot = w->stamp[5];
    w->terms = 0;
    return 1;
}

/* ---- the rows of a run (Function.rows with `projected`: the outputs of the samples one after another) ------- */

/* The stamp mbs_loop_rates leaves after a row's solve: w->G holds the factors of the kept partition (its blocks) at
 * that row's projected state, rank stamp[3].  The next row starts from them, whatever its parameters (a row after
 * an event: a switch's flag changed), since they only start its Newton iterations, whose convergence is checked on
 * its own constraints. */
#define MBS_LOOP_ROW_MARK 3307.0
/* Newton steps with the previous row's factors before the row is projected afresh (mbs_project); each must
 * reduce the residual by MBS_LOOP_SLOW, as the simplified Newton of mbs_loop_positions_iterate. */
#define MBS_LOOP_ROW_MAXIT 8

/* Are the factors of the previous row in the work, with the partition still the kept one: its solve's
 * (MBS_LOOP_ROW_MARK), or, when its outputs solved no loops (positions alone: no mbs_loop_rates after the
 * projection), its projection's (the stamp of mbs_project, of the kept partition's blocks)?  Without the latter every
 * row of such outputs was projected afresh (the Iltis over the bump: 40,000 instructions a row against 30,000). */
static int mbs_loop_row_factors_hold(const mbs_loop_work *w)
{
#ifdef MBS_CLOSED_FORM  /* its rows are projected in closed form first (mbs_project), whose scratch overlaps G */
    (void)w;
    return 0;
#else
    const int projected = MBS_LOOP_PROJECTED_STAMP && w->stamp[0] == MBS_LOOP_PROJECTED_MARK
                          && ((int)w->stamp[4] & 7) == 4;  /* blocked, neither fresh nor singular (the flags' packing) */
    return !MBS_LOOP_ROWS_FORMER && (w->stamp[0] == MBS_LOOP_ROW_MARK || projected)
           && w->keep[0] == MBS_LOOP_KEEP_MARK && w->stamp[3] == w->keep[1] && mbs_loop_plan_holds(w);
#endif
}

/* x projected into w->xc as mbs_project projects it, but for the positions' Newton iterations: simplified Newton
 * with the previous row's factors (mbs_loop_row_factors_hold; the kept partition, so the independent coordinates
 * stay as in mbs_project), polished as mbs_loop_positions_iterate does.  Then, as mbs_loop_project_state: G and g_t
 * at the projected positions, factored with the partition (kept while it holds, else chosen afresh and kept), v_I
 * kept and G_D v_D = -(G_I v_I + g_t) solved; with MBS_LOOP_ROW_RATES the residuals' last evaluation gave
 * gdot = G v + g_t there, and v_D += dv_D with G_D dv_D = -gdot instead (the same to round-off, without g_t's
 * mbs_constraint_velocity: h then holds gdot, which nothing after reads).  A row 5 ms after the last one needs no G for its Newton steps
 * (mbs_project: G and its factors twice a row).  Returns the rank, or -1 when the factors do not converge fast (a
 * large step between rows, a jump at an event) or anything fails: the caller projects afresh. */
static int mbs_loop_project_from_row(double t, const double *x, const double *p, mbs_loop_work *w)
{
    double *q = w->xc, res, before, after;
    int k, r = (int)w->stamp[3], rated;  /* rated: the last evaluation gave gdot at the positions left */
    w->blocked = 1;
    memcpy(w->xc, x, MBS_NX * sizeof(double));
    mbs_loop_normalize_q(q);
    if (mbs_loop_residuals(t, q, p, w, MBS_LOOP_ROW_RATES) != 0) return -1;
    res = mbs_loop_maxabs(w->g, MBS_NC, NULL);
    for (k = 0; !(res <= MBS_LOOP_TOL); k++) {
        before = res;
        if (k >= MBS_LOOP_ROW_MAXIT || !isfinite(res)) return -1;
        if (mbs_loop_newton_step(t, q, p, w, r, MBS_LOOP_ROW_RATES) != 0) return -1;
        res = mbs_loop_maxabs(w->g, MBS_NC, NULL);
        if (!(res <= MBS_LOOP_SLOW * before)) return -1;
    }
    after = res;
    if ((res > MBS_LOOP_ROW_KEPT || MBS_LOOP_ROW_POLISH_FORMER)
        && mbs_loop_polish(t, q, p, w, r, res, &after, MBS_LOOP_ROW_RATES) != 0)
        return -1;
    rated = MBS_LOOP_ROW_RATES && after >= 0.0;
    if (rated)  /* gdot into h, where a fresh partition's probe (mbs_loop_generic_rank) leaves it: h = g_t is not needed */
        memcpy(w->h, mbs_loop_rates_of(w), MBS_NC * sizeof(double));
    if (mbs_loop_jacobian_at(t, w->xc, p, w, !rated) != 0) return -1;
    if ((r = mbs_loop_partition(t, w->xc, p, w, 1, NULL)) < 0) return -1;
    if (rated) {  /* as an accepted step's velocities */
        mbs_loop_correct_velocities(w, r, w->h);
    } else {  /* keep v_I, solve G_D v_D = -(G_I v_I + g_t) */
        mbs_loop_solve(w, r, w->h, w->xc + MBS_NQ);
    }
    return r;
}

/* mbs_project of a row of a run (Function.rows with `projected`, c/mbs_glue.c: the outputs' work): from the
 * factors the previous row's solve left when they hold and converge (mbs_loop_project_from_row), else mbs_project.
 * Either leaves the stamp of mbs_project, so the outputs' mbs_loop_rates solves from the factors at the row. */
int mbs_loop_project_row(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_loop_work w = mbs_loop_layout_keeping(work);
    int r;
    if (mbs_loop_row_factors_hold(&w) && (r = mbs_loop_project_from_row(t, x, p, &w)) >= 0) {
        memcpy(out, w.xc, MBS_NX * sizeof(double));
        mbs_loop_projected_store(t, p, &w, r);
        return 0;
    }
    w.stamp[0] = 0.0;
    return mbs_project(t, x, p, out, work);
}

/* out = [x' (NX); lambda (NC)] at the projected state from one projection and one solve: what the outputs read
 * (accelerations and reactions), formerly mbs_loop_rhs and mbs_loop_multipliers, each projecting and solving.  A
 * state mbs_project (or mbs_loop_project_row) just returned in this work (the rows of a run: Function.rows in
 * c/mbs_glue.c projects each row there first) is not projected again: the solve starts from the factors the
 * projection left.  The factors of a solve with the kept partition stay for the next row (MBS_LOOP_ROW_MARK). */
int mbs_loop_rates(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_loop_work w = mbs_loop_layout_keeping(work);
    int r, s;
    if (mbs_loop_projected_holds(t, x, p, &w, &r)) {
        mbs_loop_info info;
        memset(&info, 0, sizeof info);
        info.worst = -1;
        w.stamp[0] = 0.0;
        s = mbs_loop_solve_accelerations(t, p, &w, 1, &r, &info);
    } else {
        w.stamp[0] = 0.0;
        s = mbs_loop_project_and_solve(t, x, p, &w, 1, &r);
    }
    if (s == 0) s = mbs_loop_rates_at_projection(t, p, out, &w);
    if (s == 0) s = mbs_loop_multipliers_of(&w, r, out + MBS_NX);
    if (s == 0 && w.blocked && !w.fresh && !w.singular && r == (int)w.keep[1] && w.keep[0] == MBS_LOOP_KEEP_MARK) {
        w.stamp[0] = MBS_LOOP_ROW_MARK;  /* the factors at this row start the next (mbs_loop_project_row) */
        w.stamp[3] = r;
    }
    return s;
}

int mbs_loop_jacobian(double t, const double *x, const double *p, double *G, double *work)
{
    mbs_loop_work w = mbs_loop_layout(work);
    int s = mbs_loop_jacobian_at(t, x, p, &w, 0);
    memcpy(G, w.G0, MBS_NC * MBS_NV * sizeof(double));
    /* the generated G does not test its entries (the solver's scan for the largest does) */
    return s != 0 ? s : isfinite(mbs_loop_maxabs(G, MBS_NC * MBS_NV, NULL)) ? 0 : MBS_LOOP_NONFINITE;
}

int mbs_loop_normalize(double t, const double *x, const double *p, double *out, double *work)
{
    (void)t; (void)p; (void)work;
    memcpy(out, x, MBS_NX * sizeof(double));
    mbs_loop_normalize_q(out);
    return 0;
}

int mbs_loop_report(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_loop_work w = mbs_loop_layout(work);
    mbs_loop_info info;
    int j, r;
    mbs_loop_project_state(t, x, p, &w, -1, &info);
    if (info.status == 0) {  /* the rank of the motion: at a singular position, with the limit's rows */
        r = info.rank;
        if (mbs_loop_solve_accelerations(t, p, &w, -1, &r, &info) == 0) info.rank = r;
    }
    out[0] = info.status;
    out[1] = info.iterations;
    out[2] = info.residual0;
    out[3] = info.residual;
    out[4] = info.worst;
    out[5] = info.rank;
    out[6] = MBS_NV - info.rank;
    out[7] = info.jacobians;
    for (j = 0; j < MBS_NV; j++) out[8 + j] = w.cp[j];
    return 0;
}

/* The partition the evaluations at x use, for the exact Jacobian (runtime/c/loop_jacobian.c): out = [rank; the
 * velocity columns in pivot order (the first rank dependent); the constraint rows in pivot order; the
 * projected state] (1 + NV + NC + NX).  Status 1 at a singular position (its limit rows are not differentiated). */
int mbs_loop_partition_at(double t, const double *x, const double *p, double *out, double *work)
{
    mbs_loop_work w = mbs_loop_layout(work);
    mbs_loop_info info;
    int s = mbs_loop_project_state(t, x, p, &w, 0, &info);
    out[0] = info.rank;
    memcpy(out + 1, w.cp, MBS_NV * sizeof(double));
    memcpy(out + 1 + MBS_NV, w.rp, MBS_NC * sizeof(double));
    memcpy(out + 1 + MBS_NV + MBS_NC, w.xc, MBS_NX * sizeof(double));
    return s != 0 ? s : (w.singular ? MBS_LOOP_SINGULAR : 0);
}
