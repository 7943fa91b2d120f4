/* The Sinkhorn launch table: what host/ot/sinkhorn.cpp hands to kernels/ot/sinkhorn.cl and
 * kernels/ot/sinkhorn_stab.cl for every problem of a batch, and the results the kernels hand back.
 * Read by both sides: the kernels include it (resolved when they are embedded, see
 * cmake/EmbedKernels.cmake) and the host fills the same structs by field name. Every field is a
 * 32-bit int or float, so OpenCL C and C++ lay the structs out alike, without padding (the host
 * checks the sizes). */
#ifndef POTMAP_KERNELS_SINKHORN_LAUNCH_H
#define POTMAP_KERNELS_SINKHORN_LAUNCH_H

/* Where a problem's data lie in the batch's buffers. A slot is one entry of the padded
 * structure-of-arrays buffers (transformed points, duals, log weights); every problem's slots
 * are padded to a multiple of the kernels' vector width VW. */
typedef struct {
  int src;      /* first source point in `src` (points, AoS, DIM floats each) */
  int n;        /* number of source points */
  int src_slot; /* first slot of this problem in the padded source arrays */
  int npad;     /* padded number of source slots (multiple of VW) */
  int tgt;      /* first target point in `tgt` */
  int m;        /* number of target points */
  int tgt_slot; /* first slot in the padded target arrays */
  int mpad;     /* padded number of target slots */
  int plan;     /* first element of the coupling in `plan`, or -1 for none */
  int max_it;   /* iteration limit at the target epsilon */
} SinkhornLaunchInts;

/* A problem's real parameters (SinkhornProblem and SinkhornOptions, in float). */
typedef struct {
  float eps;       /* target epsilon */
  float tol;       /* tolerance on the 1-norm marginal error */
  float cos_angle; /* rotation of the source points about the centre (about z in 3D) */
  float sin_angle;
  float cx, cy, cz; /* centre of the rotation */
  float scale;      /* applied to both clouds after the rotation */
  float normalise;  /* 1: divide the cost by its maximum over the problem */
  float eps0;       /* first epsilon of the annealing schedule (<= eps: none) */
  float decay;      /* factor between successive epsilons of the schedule, in (0, 1) */
  float check;      /* check convergence every this many iterations */
  float omega;      /* over-relaxation: 0 adaptive, else the fixed factor in [1, 2) */
} SinkhornLaunchParams;

/* Results per problem, the `stats` buffer of SinkhornDeviceResult (4 floats). */
typedef struct {
  float cost; /* <P, C> */
  float iterations;
  float marginal_error; /* 1-norm error of the row marginal of the plan handed back */
  float converged;      /* 0 or 1 */
} SinkhornLaunchStats;

#endif
