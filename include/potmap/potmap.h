/* potmap C API: continuous occupancy maps on OpenCL, for embedding in another program (a ROS
 * node, a SLAM system) and for bindings (Python ctypes/cffi, Rust, ...). Plain C99; also valid
 * C++. Link with -lpotmap (pkg-config potmap) or potmap::potmap (find_package(potmap)).
 *
 * Conventions, for every function below unless its comment says otherwise:
 *   - It returns a potmap_status: POTMAP_SUCCESS (0); an OpenCL error code, negative, passed
 *     through unchanged (CL_OUT_OF_RESOURCES, CL_BUILD_PROGRAM_FAILURE, ...); or one of potmap's
 *     own codes, positive (potmap_status_code). potmap_status_string() names any of them.
 *   - On failure, potmap_last_error() gives the full message for the calling thread: the file,
 *     line and value for bad input, the OpenCL call and code, a kernel's build log.
 *   - No C++ exception ever leaves a function of this API.
 *   - A null handle or a null required pointer gives POTMAP_ERROR_NULL_ARGUMENT and changes
 *     nothing. On failure, the *out of a create or load call is left unchanged.
 *   - Handles (potmap_context*, potmap_map*, potmap_evaluator*) are created by *_create or
 *     *_load and freed by the matching *_destroy, exactly once; *_destroy(NULL) does nothing
 *     and succeeds, like free(). A handle of the wrong type, or one already destroyed, gives
 *     POTMAP_ERROR_INVALID_HANDLE where it can be seen: each handle carries a type tag that
 *     *_destroy clears. This is best effort: the memory of a destroyed handle may be reused,
 *     and a sanitizer build reports such a use as the error it is.
 *   - Objects made from a context keep it alive: handles may be destroyed in any order.
 *   - Units: coordinates in metres, kernel widths gamma in 1/m^2 (SPEC section 2).
 *
 * Threads: a potmap_context may be shared by threads (creating evaluators on it concurrently is
 * fine; their device work is serialised on its one in-order queue). A potmap_map may be read by
 * several threads at once (save, size, read, bias, evaluator_create); potmap_map_set_bias must
 * not overlap any other call on the same map. A potmap_evaluator is used by one thread at a
 * time; different evaluators may run concurrently, on the same context too. The last-error
 * message is per thread.
 *
 * Dictionaries and mappers (POT / RePOT, issue #6) will add potmap_dictionary and
 * potmap_mapper functions; their handle types are declared below already. */
#ifndef POTMAP_POTMAP_H
#define POTMAP_POTMAP_H

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>
#include <stddef.h>

#include "potmap/export.h"
#include "potmap/version.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- status codes ---------------------------------------------------------------------- */

/** 0: success; < 0: an OpenCL error code (CL_*); > 0: a potmap_status_code. */
typedef int potmap_status;

enum potmap_status_code {
  POTMAP_SUCCESS = 0,
  /** A handle or a required pointer argument is null. */
  POTMAP_ERROR_NULL_ARGUMENT = 1001,
  /** A handle of the wrong type, or one already destroyed (best effort, see above). */
  POTMAP_ERROR_INVALID_HANDLE = 1002,
  /** An argument outside its documented range (dimension not 2 or 3, gamma <= 0, NaN, ...). */
  POTMAP_ERROR_INVALID_ARGUMENT = 1003,
  /** Points or a grid of another dimension than the map's. */
  POTMAP_ERROR_DIMENSION_MISMATCH = 1004,
  /** An output array or cl_mem buffer smaller than the call needs. */
  POTMAP_ERROR_BUFFER_TOO_SMALL = 1005,
  /** A cl_mem, cl_event or cl_device_id that belongs to another OpenCL context (or platform). */
  POTMAP_ERROR_CONTEXT_MISMATCH = 1006,
  /** A file that cannot be read, of unknown format, or with bad content. */
  POTMAP_ERROR_INPUT = 1007,
  /** A file that cannot be written. */
  POTMAP_ERROR_IO = 1008,
  /** No OpenCL device, or none whose name matches. */
  POTMAP_ERROR_NO_DEVICE = 1009,
  /** Host memory ran out. */
  POTMAP_ERROR_OUT_OF_MEMORY = 1010,
  /** Anything else (a bug: please report potmap_last_error()). */
  POTMAP_ERROR_INTERNAL = 1011
};

/** Symbolic name of a status ("POTMAP_ERROR_INPUT", "CL_INVALID_VALUE"; unknown codes give
 *  "POTMAP_UNKNOWN_STATUS"). Never null; static storage, never freed. Does not return a status. */
POTMAP_EXPORT const char* potmap_status_string(potmap_status status);

/** Full message of the most recent failed call on the calling thread; "" after a call that
 *  succeeded (every call of this API but this one and potmap_status_string clears it first).
 *  Never null. Owned by potmap: valid until the next potmap call on the same thread; copy it to
 *  keep it. Does not return a status. */
POTMAP_EXPORT const char* potmap_last_error(void);

/* ---- version --------------------------------------------------------------------------- */

/** The library's version at run time (compare with POTMAP_VERSION_* of the headers compiled
 *  against). Any pointer may be null. Always succeeds. */
POTMAP_EXPORT potmap_status potmap_version(int* major, int* minor, int* patch);
/** "major.minor.patch" of the library at run time; static storage. */
POTMAP_EXPORT const char* potmap_version_string(void);

/* ---- handles --------------------------------------------------------------------------- */

/** One OpenCL device, its in-order queue and potmap's cache of built kernels. */
typedef struct potmap_context potmap_context;
/** A kernel map (host memory): M kernels of position, width gamma and weight mean/variance. */
typedef struct potmap_map potmap_map;
/** A map uploaded to one context's device, ready to evaluate. Holds its own copy of the map. */
typedef struct potmap_evaluator potmap_evaluator;
/** Reserved for issue #6 (dictionary of atoms, POT/RePOT mapper): no functions yet. */
typedef struct potmap_dictionary potmap_dictionary;
typedef struct potmap_mapper potmap_mapper;

/* ---- context --------------------------------------------------------------------------- */

/** Creates a context on the first device whose platform or device name contains `device`
 *  (case-insensitive, e.g. "pocl", "nvidia"). `device` NULL or "": the POTMAP_DEVICE
 *  environment variable if set, else the first GPU, else the first CPU device. Compiled kernels
 *  are cached on disk under POTMAP_CACHE_DIR when that is set.
 *  *out receives a new handle; free it with potmap_context_destroy.
 *  Errors: POTMAP_ERROR_NO_DEVICE (the message lists the devices), OpenCL codes. */
POTMAP_EXPORT potmap_status potmap_context_create(const char* device, potmap_context** out);

/** Creates a context on the host's own OpenCL context and one of its devices; potmap makes its
 *  own in-order queue on them. Both are retained (the caller may release its references).
 *  Errors: POTMAP_ERROR_NULL_ARGUMENT, POTMAP_ERROR_CONTEXT_MISMATCH (device not in context). */
POTMAP_EXPORT potmap_status potmap_context_create_from_cl(cl_context context, cl_device_id device,
                                                          potmap_context** out);

/** Creates a context on the host's own command queue (retained): work potmap enqueues is
 *  ordered with the host's own on that queue. Its context and device are used. */
POTMAP_EXPORT potmap_status potmap_context_create_from_queue(cl_command_queue queue,
                                                             potmap_context** out);

/** Releases the handle. Evaluators made from it keep the device objects alive until they are
 *  destroyed too. NULL: does nothing. */
POTMAP_EXPORT potmap_status potmap_context_destroy(potmap_context* context);

/** What potmap knows of a context's device. Strings are UTF-8, never null. */
typedef struct potmap_device_info {
  const char* platform;         /**< platform name, e.g. "Portable Computing Language" */
  const char* platform_version; /**< e.g. "OpenCL 3.0 PoCL ..." */
  const char* name;             /**< device name */
  const char* driver_version;
  int is_gpu;   /**< 1 or 0 */
  int is_cpu;   /**< 1 or 0 */
  int has_fp64; /**< 1 if cl_khr_fp64 is supported */
  size_t compute_units;
  size_t max_work_group_size;
  size_t global_mem_bytes;
  size_t max_alloc_bytes;
} potmap_device_info;

/** *out receives a pointer to the context's device description, owned by the context: valid
 *  until potmap_context_destroy; do not free it. (Fields may be added at the end in later
 *  versions; the caller never allocates this struct.) */
POTMAP_EXPORT potmap_status potmap_context_device_info(const potmap_context* context,
                                                       const potmap_device_info** out);

/** The context's OpenCL objects, borrowed (not retained): valid while the handle lives; retain
 *  them to keep them longer. Any out-pointer may be null to skip it. */
POTMAP_EXPORT potmap_status potmap_context_cl(const potmap_context* context, cl_context* cl_ctx,
                                              cl_device_id* device, cl_command_queue* queue);

/* ---- maps ------------------------------------------------------------------------------ */

/** Creates a map of `count` kernels in `dim` (2 or 3) dimensions, copying the arrays:
 *  positions: count * dim doubles, row-major (x0, y0[, z0], x1, ...), metres;
 *  gamma: count widths, 1/m^2, > 0; w_mean: count weight means; w_var: count variances >= 0.
 *  count 0 makes an empty map (the arrays may then be null). No bias (see potmap_map_set_bias).
 *  *out receives a new handle; free it with potmap_map_destroy.
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT names the first bad kernel and value. */
POTMAP_EXPORT potmap_status potmap_map_create(int dim, size_t count, const double* positions,
                                              const double* gamma, const double* w_mean,
                                              const double* w_var, potmap_map** out);

/** Reads a map file; the format follows the extension: .csv, .npz (the paper authors'
 *  layout) or .potmap (native binary); see potmap/map_io.hpp for each layout.
 *  *out receives a new handle; free it with potmap_map_destroy.
 *  Errors: POTMAP_ERROR_INPUT (unreadable file, unknown extension, bad content: the message
 *  names the file, line or byte offset, and value). */
POTMAP_EXPORT potmap_status potmap_map_load(const char* path, potmap_map** out);

/** Writes the map, format from the extension (.csv, .npz, .potmap), through a temporary file
 *  renamed into place. Errors: POTMAP_ERROR_INVALID_ARGUMENT (unknown extension),
 *  POTMAP_ERROR_IO (cannot write). */
POTMAP_EXPORT potmap_status potmap_map_save(const potmap_map* map, const char* path);

/** Frees the map. Evaluators made from it hold their own copy and stay valid. NULL: no-op. */
POTMAP_EXPORT potmap_status potmap_map_destroy(potmap_map* map);

/** *dim receives 2 or 3, *count the number of kernels. Both pointers required. */
POTMAP_EXPORT potmap_status potmap_map_size(const potmap_map* map, int* dim, size_t* count);

/** Copies the map's kernels out. Each array may be null to skip it (at least one must not):
 *  positions receives count * dim doubles and must hold positions_capacity >= count * dim;
 *  gamma, w_mean and w_var receive count doubles each and must hold capacity >= count.
 *  Errors: POTMAP_ERROR_BUFFER_TOO_SMALL (nothing is written). */
POTMAP_EXPORT potmap_status potmap_map_read(const potmap_map* map, double* positions,
                                            size_t positions_capacity, double* gamma,
                                            double* w_mean, double* w_var, size_t capacity);

/** Sets the bias weight (phi = 1 everywhere): has_bias 0 removes it; mean any finite value,
 *  var >= 0. Evaluators already made keep the bias they were made with. */
POTMAP_EXPORT potmap_status potmap_map_set_bias(potmap_map* map, int has_bias, double mean,
                                                double var);

/** *has_bias receives 1 or 0, *mean and *var the bias weight (0 when there is none). Any
 *  out-pointer may be null to skip it. */
POTMAP_EXPORT potmap_status potmap_map_bias(const potmap_map* map, int* has_bias, double* mean,
                                            double* var);

/* ---- evaluation ------------------------------------------------------------------------ */

/** Validates the map and uploads a copy of it to the context's device. `tau`: kernels with
 *  gamma * d^2 > tau are skipped; 0 means the default 18 (each dropped term below 1.6e-8 of its
 *  weight). *out receives a new handle; free it with potmap_evaluator_destroy. The evaluator
 *  keeps the context alive. Errors: POTMAP_ERROR_INVALID_ARGUMENT (bad map, tau < 0 or NaN). */
POTMAP_EXPORT potmap_status potmap_evaluator_create(potmap_context* context, const potmap_map* map,
                                                    double tau, potmap_evaluator** out);

/** Frees the evaluator and its device memory. NULL: no-op. */
POTMAP_EXPORT potmap_status potmap_evaluator_destroy(potmap_evaluator* evaluator);

/** Values of the map at n points given on the host: `points` holds n * dim doubles, row-major,
 *  metres; dim must be the map's. Outputs (float): mean mu(x), variance s2(x) and occupancy
 *  probability p(x) in [0, 1]; each may be null to skip it (at least one must not); each
 *  non-null one must hold capacity >= n floats. Blocks until the values are written.
 *  Non-finite coordinates give NaN values. n == 0 does nothing (points may then be null).
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH, POTMAP_ERROR_BUFFER_TOO_SMALL. */
POTMAP_EXPORT potmap_status potmap_evaluate(potmap_evaluator* evaluator, const double* points,
                                            size_t n, int dim, float* mean, float* var, float* prob,
                                            size_t capacity);

/** Values on a regular grid of cell centres origin[d] + (i + 0.5) * resolution, i < count[d]
 *  (metres; count[2] is ignored in 2D); flattened x fastest, then y, then z. origin and count
 *  hold 3 values each (the third unused in 2D). Outputs as in potmap_evaluate, each holding
 *  capacity >= count[0] * count[1] (* count[2] in 3D) floats. */
POTMAP_EXPORT potmap_status potmap_evaluate_grid(potmap_evaluator* evaluator, int dim,
                                                 const double origin[3], double resolution,
                                                 const size_t count[3], float* mean, float* var,
                                                 float* prob, size_t capacity);

/** Values at n points that live in the host's own device buffers. Does not block: the work is
 *  enqueued on the context's queue after the `num_wait_events` events of `wait_events` and
 *  finishes when *event completes.
 *    points: cl_mem of at least n * dim floats (x, y[, z] per point), metres relative to
 *            `origin` (dim doubles, in the map's frame; keep points within a few km of it);
 *    mean, var, prob: cl_mem of at least n floats each, or NULL to skip (at least one not);
 *    event:  if not null, receives a new event that completes when the outputs are written;
 *            the caller owns it and frees it with clReleaseEvent. If null, potmap keeps no
 *            reference; wait with clFinish on the queue instead.
 *  Every buffer and event must belong to the evaluator's OpenCL context. The caller keeps its
 *  references: potmap retains what it needs until the work is done. n == 0 enqueues only a
 *  marker (after the wait list), so *event is always a valid event.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH, POTMAP_ERROR_BUFFER_TOO_SMALL (from CL_MEM_SIZE),
 *  POTMAP_ERROR_CONTEXT_MISMATCH (a buffer or event of another context or platform, seen
 *  through clGetMemObjectInfo/clGetEventInfo), CL_INVALID_MEM_OBJECT and other OpenCL codes.
 *  A pointer that is not an OpenCL object at all cannot be detected (the OpenCL loader
 *  dereferences it). */
POTMAP_EXPORT potmap_status potmap_evaluate_device(potmap_evaluator* evaluator, cl_mem points,
                                                   size_t n, int dim, const double* origin,
                                                   cl_mem mean, cl_mem var, cl_mem prob,
                                                   cl_uint num_wait_events,
                                                   const cl_event* wait_events, cl_event* event);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* POTMAP_POTMAP_H */
