// What the map kernels (map_eval.cl, map_eval_cells.cl, map_raster.cl) share: the occupancy
// probability of a weight's mean and variance, and Neumaier's compensated sum. Included by them
// (resolved when they are embedded, see cmake/EmbedKernels.cmake), never built alone. Macros,
// so that one text serves float and every vector width.

#ifndef POTMAP_KERNELS_MAP_MATH_CL
#define POTMAP_KERNELS_MAP_MATH_CL

#define PI_OVER_8 0.39269908169872414f

// Occupancy probability sigma(mean / sqrt(1 + pi var / 8)), the probit approximation of the
// predictive probability (SPEC section 2).
#define OCCUPANCY_PROB(mean, var) (1.0f / (1.0f + exp(-(mean) * rsqrt(1.0f + PI_OVER_8 * (var)))))

// Neumaier: adds x to (s, c) where s + c is the running sum; T is the type of s, c and x.
#define NEUMAIER_ADD_T(T, s, c, x)                                     \
  do {                                                                 \
    T t_ = (s) + (x);                                                  \
    (c) += select((x) - t_ + (s), (s) - t_ + (x), fabs(s) >= fabs(x)); \
    (s) = t_;                                                          \
  } while (0)

#endif
