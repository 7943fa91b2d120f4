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
 *   - Handles (potmap_context*, potmap_map*, potmap_evaluator*, potmap_dataset*,
 *     potmap_dictionary*, potmap_mapper*) are created by *_create, *_load or *_build (and
 *     potmap_map_learn_bhm, potmap_mapper_*_map for maps) and freed by the matching *_destroy,
 *     exactly once; *_destroy(NULL) does nothing
 *     and succeeds, like free(). A handle of the wrong type, or one already destroyed, gives
 *     POTMAP_ERROR_INVALID_HANDLE where it can be seen: each handle carries a type tag that
 *     *_destroy clears. This is best effort: the memory of a destroyed handle may be reused,
 *     and a sanitizer build reports such a use as the error it is.
 *   - Objects made from a context keep it alive: handles may be destroyed in any order.
 *   - Structs the caller passes in or out (potmap_scan, potmap_dictionary_options,
 *     potmap_mapper_options, potmap_scan_stats) begin with struct_size, the caller's
 *     sizeof: fields are only ever appended in later versions, so the library reads or writes
 *     only the first struct_size bytes and takes defaults for fields the caller does not have.
 *     Fill them with their *_init function (or, for potmap_scan_stats, set struct_size).
 *   - Units: coordinates in metres, kernel widths gamma in 1/m^2 (SPEC section 2).
 *
 * Threads: a potmap_context may be shared by threads (creating evaluators and mappers on it,
 * and using them, concurrently is fine; their device work is serialised on its one in-order
 * queue: give each thread its own context or queue for device work that overlaps). A
 * potmap_map may be read by several threads at once (save, size, read, bias, evaluator_create,
 * dictionary_build); potmap_map_set_bias must not overlap any other call on the same map. A
 * potmap_dataset and a potmap_dictionary never change once made: any number of threads may use
 * them at once (and any number of mappers may share one dictionary). A potmap_evaluator and a
 * potmap_mapper are used by one thread at a time; different ones may run concurrently, on the
 * same context too. The last-error message is per thread. */
#ifndef POTMAP_POTMAP_H
#define POTMAP_POTMAP_H

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>
#include <stddef.h>
#include <stdint.h>

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
  POTMAP_ERROR_INTERNAL = 1011,
  /** A long call stopped by its caller's progress callback. */
  POTMAP_ERROR_CANCELLED = 1012
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
/** Scans read from a dataset file (a CARMEN log, KITTI, ...), kept in host memory. */
typedef struct potmap_dataset potmap_dataset;
/** A dictionary of atoms (POT, SPEC section 4 step 1): sectors of source scans with the kernels
 *  of a map learned over them. Never changes once made. */
typedef struct potmap_dictionary potmap_dictionary;
/** Maps scans one at a time by POT or RePOT with a dictionary, and accumulates them into an
 *  overall map. */
typedef struct potmap_mapper potmap_mapper;
/** The joint BHM over a 3D drive, a keyframe at a time (potmap_drive_mapper_*). */
typedef struct potmap_drive_mapper potmap_drive_mapper;

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
 *  layout) or .potmap (native binary); see potmap/io/map_io.hpp for each layout.
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

/** Merges map files of overlapping places, each learned from its own data, and writes the
 *  result to `out` (.potmap, ready to merge again, through a temporary file renamed into
 *  place): joint BHM maps exactly in information form (precisions and information vectors
 *  added, the prior counted once, the means solved again), POT's averaged maps by adding their
 *  anchors' sums (docs/merging.md). `paths` holds `count` >= 2 .potmap files of one kind
 *  written with what merging needs (potmap_mapper_save_overall_map,
 *  potmap_drive_mapper_save_map, `potmap mapping`). allow_overlap 0 (the default to pass):
 *  joint BHM maps that learned the same scans, a map merged with itself among them, are
 *  refused; 1: merged, those scans counted twice.
 *  Errors: POTMAP_ERROR_INPUT (unreadable file, or one written without its information form:
 *  the message names it), POTMAP_ERROR_INVALID_ARGUMENT (fewer than two maps, kernels or
 *  priors that differ, shared scans, retired tiles: the message names both files and the
 *  value), POTMAP_ERROR_IO (cannot write). */
POTMAP_EXPORT potmap_status potmap_merge_maps(const char* const* paths, size_t count,
                                              const char* out, int allow_overlap);

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

/** Sets the cut-off exponent the map was learned with (potmap::KernelMap::cutoff_tau): its
 *  learner never used terms with gamma * d^2 beyond it, and evaluators cut there when it is
 *  below their own tau. tau > 0; INFINITY (a new map's value) leaves the evaluators' own. A
 *  drive's map (potmap_mapping_run) carries its learner's feature cut-off, 4.5. Evaluators
 *  already made keep the cut-off they were made with. */
POTMAP_EXPORT potmap_status potmap_map_set_cutoff(potmap_map* map, double tau);

/** *tau receives the cut-off exponent the map was learned with (INFINITY when none). */
POTMAP_EXPORT potmap_status potmap_map_cutoff(const potmap_map* map, double* tau);

/* ---- evaluation ------------------------------------------------------------------------ */

/** Validates the map and uploads a copy of it to the context's device. `tau`: kernels with
 *  gamma * d^2 > tau are skipped; 0 means the default 18 (each dropped term below 1.6e-8 of its
 *  weight); a map learned with a smaller cut-off is evaluated at that. *out receives a new handle;
 * free it with potmap_evaluator_destroy. The evaluator keeps the context alive. Errors:
 * POTMAP_ERROR_INVALID_ARGUMENT (bad map, tau < 0 or NaN). */
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

/** Height-band maximum of a 3D map on a grid of (x, y) cells: per cell, the largest occupancy
 *  probability over the heights z_lo to z_hi (metres, map frame) and the variance and mean at
 *  the height where it is reached; what stands between the ground and a vehicle's roof. The
 *  band is sampled at evenly spaced heights at most `step` metres apart, both ends included
 *  (step 0: the standard deviation of the map's narrowest kernel, 1 / sqrt(2 gamma_max), finer
 *  than which the map does not change). Cell centres origin[d] + (i + 0.5) * resolution for
 *  d < 2, i < count[d] (origin and count hold 2 values each); flattened x fastest. Outputs as in
 *  potmap_evaluate, each holding capacity >= count[0] * count[1] floats.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH (a 2D map), POTMAP_ERROR_INVALID_ARGUMENT (z_lo above
 *  z_hi, a non-finite value, step < 0, more than 4096 heights), POTMAP_ERROR_BUFFER_TOO_SMALL. */
POTMAP_EXPORT potmap_status potmap_evaluate_band(potmap_evaluator* evaluator,
                                                 const double origin[2], double resolution,
                                                 const size_t count[2], double z_lo, double z_hi,
                                                 double step, float* mean, float* var, float* prob,
                                                 size_t capacity);

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

/* ---- scans and datasets ---------------------------------------------------------------- */

/** One LIDAR sweep, described by the caller: the arrays are the caller's, only read during the
 *  call that takes the scan (potmap copies what it keeps). World frame, metres. */
typedef struct potmap_scan {
  size_t struct_size; /**< sizeof(potmap_scan) as the caller compiled it (potmap_scan_init) */
  int dim;            /**< 2 or 3 (default 2) */
  /** Sensor pose. 2D: x, y (metres) and yaw (radians, counter-clockwise from +x) in pose[0..2];
   *  3D: the 3 x 4 row-major [R | t] mapping sensor to world coordinates (default: identity). */
  double pose[12];
  double max_range;   /**< metres, > 0: a beam at or beyond it is a no-return (default 0: unset) */
  double timestamp;   /**< seconds: the mappers' clock for forgetting (half_life; default 0) */
  const double* hits; /**< end points of returned beams: num_hits * dim doubles, row-major */
  size_t num_hits;
  const double* no_return; /**< unit directions of beams with no return: num_no_return * dim */
  size_t num_no_return;
} potmap_scan;

/** Fills *scan with the defaults above (2D, identity pose, no beams) and sets struct_size to
 *  `struct_size`, which must be sizeof(potmap_scan) of the caller: potmap_scan_init(&s, sizeof s).
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT (struct_size smaller than the first version's). */
POTMAP_EXPORT potmap_status potmap_scan_init(potmap_scan* scan, size_t struct_size);

/** Reads a dataset file by its name, as `potmap data info` does: *.log[.gz] CARMEN, *.bin KITTI
 *  or nuScenes frames, a 3D drive folder (SLAM keyframes or a KITTI sequence: every keyframe in
 *  the world frame), a KITTI odometry sequence by its poses.txt, *.npz / *.csv labelled
 *  samples, ROS 1 and ROS 2 bags (see potmap/data/scan.hpp, read_dataset). The whole file is
 *  read now.
 *  *out receives a new handle; free it with potmap_dataset_destroy.
 *  Errors: POTMAP_ERROR_INPUT (the message names the file, line or offset, and value). */
POTMAP_EXPORT potmap_status potmap_dataset_load(const char* path, potmap_dataset** out);

/** How a ROS bag is read (potmap/data/bag.hpp, BagOptions). Strings are borrowed for the call;
 *  NULL or "" means the default. */
typedef struct potmap_bag_options {
  size_t struct_size;       /**< the caller's sizeof (potmap_bag_options_init sets it) */
  const char* topic;        /**< LaserScan, MultiEchoLaserScan or PointCloud2 topic (NULL: the
                                 one with the most messages) */
  const char* fixed_frame;  /**< frame to map in (NULL: map when /tf links it, else odom) */
  const char* pose_topic;   /**< Odometry or PoseStamped topic to take poses from (NULL: /tf) */
  double max_range;         /**< metres (0: a LaserScan's range_max; 120 for point clouds) */
  double keyframe_distance; /**< point clouds: metres between keyframes (default 1) */
  double keyframe_angle;    /**< point clouds: radians of turn that start one (default 0.26) */
} potmap_bag_options;

/** Fills *options with the defaults; struct_size is the caller's sizeof(potmap_bag_options). */
POTMAP_EXPORT potmap_status potmap_bag_options_init(potmap_bag_options* options,
                                                    size_t struct_size);

/** Reads a ROS 1 .bag or a ROS 2 bag (folder, metadata.yaml or .db3): the chosen topic's messages
 *  with a pose, as 2D scans (laser topics) or 3D keyframes (point clouds) in the fixed frame
 *  (potmap/data/bag.hpp, read_bag). options NULL: the defaults. potmap_dataset_load reads bags
 *  with the defaults too. Errors: POTMAP_ERROR_INPUT (the message names the bag, the topic and
 *  what is missing), POTMAP_ERROR_INVALID_ARGUMENT (an option out of range). */
POTMAP_EXPORT potmap_status potmap_dataset_load_bag(const char* path,
                                                    const potmap_bag_options* options,
                                                    potmap_dataset** out);

/** Frees the dataset (scans it filled keep pointers into it: they become invalid). NULL: no-op. */
POTMAP_EXPORT potmap_status potmap_dataset_destroy(potmap_dataset* dataset);

/** *count receives the number of scans. */
POTMAP_EXPORT potmap_status potmap_dataset_size(const potmap_dataset* dataset, size_t* count);

/** Describes scan `index` (< the count) in *scan, whose struct_size the caller sets first
 *  (potmap_scan_init). Its hits and no_return point into the dataset: borrowed, valid until
 *  potmap_dataset_destroy; do not free them. Errors: POTMAP_ERROR_INVALID_ARGUMENT (index out
 *  of range, struct_size too small). */
POTMAP_EXPORT potmap_status potmap_dataset_scan(const potmap_dataset* dataset, size_t index,
                                                potmap_scan* scan);

/* ---- learning a source map ------------------------------------------------------------- */

/** Learns a Bayesian Hilbert map (SPEC section 3) from scans on the context's device, to build
 *  a dictionary with: every beam is labelled (hits, and free samples 1 per metre along it; none
 *  held out), kernels are placed on a grid `spacing` metres apart (> 0; 0: 1 m) over the
 *  samples' bounds, all of width `gamma` (1/m^2, > 0; 0: 8 / spacing^2, as `potmap learn
 *  bhm`), prior weight N(0, 1e4), and updated scan by scan (3 EM iterations each). A 3D grid
 *  over a large area is large: choose the spacing accordingly. `scans` holds n pointers to
 *  scans of one dimension. *out receives a new map handle; free it with potmap_map_destroy.
 *  Errors: POTMAP_ERROR_NULL_ARGUMENT (a null scan or array), POTMAP_ERROR_DIMENSION_MISMATCH
 *  (scans of different dimensions), POTMAP_ERROR_INVALID_ARGUMENT (n == 0, no samples, a bad
 *  scan: the message names its index and field). */
POTMAP_EXPORT potmap_status potmap_map_learn_bhm(potmap_context* context,
                                                 const potmap_scan* const* scans, size_t n,
                                                 double spacing, double gamma, potmap_map** out);

/* ---- dictionaries ---------------------------------------------------------------------- */

/** How scans are cut into atoms (potmap/pot/atoms.hpp, DictionaryOptions). */
typedef struct potmap_dictionary_options {
  size_t struct_size; /**< the caller's sizeof (potmap_dictionary_options_init sets it) */
  int sectors;        /**< equal angular sectors per scan, >= 1 (default 5) */
  double max_range;   /**< sector radius, metres (default 0: each scan's own max_range) */
  double scale;       /**< multiplies centred coordinates, > 0 (default 1/50) */
  size_t min_samples; /**< sectors with fewer samples are dropped (default 4) */
  /** Kernels with a larger weight variance stay out of atoms (default 1000: kernels the source
   *  data never reached keep their prior variance and carry no shape). */
  double max_weight_variance;
  size_t min_kernels; /**< atoms with fewer kernels are skipped (default 1) */
} potmap_dictionary_options;

/** Fills *options with the defaults above; struct_size: the caller's sizeof(*options). */
POTMAP_EXPORT potmap_status potmap_dictionary_options_init(potmap_dictionary_options* options,
                                                           size_t struct_size);

/** Builds a dictionary from n source scans (pointers) and a map learned over the same place
 *  (world frame), e.g. by potmap_map_learn_bhm. `options` NULL: the defaults.
 *  *out receives a new handle; free it with potmap_dictionary_destroy.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH (a scan of another dimension than the map's),
 *  POTMAP_ERROR_INVALID_ARGUMENT (bad options or scan; no atom at all: nothing to transport). */
POTMAP_EXPORT potmap_status potmap_dictionary_build(const potmap_scan* const* scans, size_t n,
                                                    const potmap_map* map,
                                                    const potmap_dictionary_options* options,
                                                    potmap_dictionary** out);

/** Reads a .potdict file (potmap/pot/dictionary_io.hpp), e.g. one written by `potmap dict build`.
 *  *out receives a new handle; free it with potmap_dictionary_destroy.
 *  Errors: POTMAP_ERROR_INPUT (unreadable, truncated or corrupt: file, byte offset, value). */
POTMAP_EXPORT potmap_status potmap_dictionary_load(const char* path, potmap_dictionary** out);

/** Writes the dictionary as .potdict through a temporary file renamed into place.
 *  Errors: POTMAP_ERROR_IO (cannot write). */
POTMAP_EXPORT potmap_status potmap_dictionary_save(const potmap_dictionary* dictionary,
                                                   const char* path);

/** Frees the handle. Mappers made from it keep the dictionary alive. NULL: no-op. */
POTMAP_EXPORT potmap_status potmap_dictionary_destroy(potmap_dictionary* dictionary);

/** What the dictionary holds; any out-pointer may be null to skip it. *dim: 2 or 3; *atoms;
 *  *kernels: over every atom; *scale; *max_range: metres; *sectors: per source scan. */
POTMAP_EXPORT potmap_status potmap_dictionary_info(const potmap_dictionary* dictionary, int* dim,
                                                   size_t* atoms, size_t* kernels, double* scale,
                                                   double* max_range, int* sectors);

/* ---- mappers (POT / RePOT) ------------------------------------------------------------- */

/** How a mapper transports and accumulates (potmap/pot/transfer.hpp, labelling.hpp,
 * overall_map.hpp). The defaults are the library's (MapperOptions{}): the settings that map real
 * logs best, those `potmap mapping` runs; potmap_mapper_options_init_paper gives the authors'
 * rules. */
typedef struct potmap_mapper_options {
  size_t struct_size; /**< the caller's sizeof (potmap_mapper_options_init sets it) */
  int sectors;        /**< target sectors per scan, >= 1 (default 5) */
  int rotations;      /**< rotations tried per atom, evenly spaced over 360 degrees (default 8) */
  int refine;        /**< 1: RePOT (refine the transported weights on the scan), 0: POT (default) */
  double max_range;  /**< target sector radius, metres (default 0: the dictionary's) */
  size_t candidates; /**< atoms ranked per sector after a cheap pre-selection (default 0: all) */
  /** Fraction of each scan's beams held out of the transport, in [0, 1) (default 0.2; their
   *  samples are what potmap_scan_stats counts as held out). 0 uses every beam. */
  double holdout_fraction;
  double free_per_metre; /**< free samples per metre of beam, > 0 (default 1) */
  uint64_t seed;         /**< labelling and subsampling seed, with the scan index (default 0) */
  /** Overall map: kernels merge when d^2 * max(gamma) is below this (default 0.25; 0: never). */
  double merge_radius;
  double gamma_ratio; /**< largest ratio of widths that may merge, >= 1 (default 2) */
  size_t max_kernels; /**< cap on the overall map's kernels (default 0: none) */
  /* ---- appended in version 2 (a caller's struct_size without them: their defaults) ---- */
  /** With refine 1: 1 (default) keeps RePOT's overall map as one persistent joint BHM that
   *  every scan updates with its own training samples, the transported kernels seeding only
   *  the space no sample has reached yet (memory grows with the area driven, not the scans;
   *  the instantaneous maps are then the transported kernels, unrefined); 0 refines each
   *  scan on its own and merges the refined maps (merge_radius, gamma_ratio, max_kernels). */
  int persistent_refine;
  /* ---- appended in version 3 ---- */
  /** How each sector's atom is chosen: POTMAP_RANKING_INDEXED (default: the atoms nearest the
   *  sector in an index of rotation-invariant signatures and the previous scan's atoms, at
   *  estimated rotations: the exhaustive ranking's held-out scores in 3.5 to 9 times less time
   *  on dictionaries of hundreds of atoms; built once per mapper) or POTMAP_RANKING_EXHAUSTIVE
   *  (the paper's eq. 6, every atom at every rotation; its cost grows with atoms x rotations).
   *  A caller whose struct predates this field gets the default. */
  int ranking;
  /** Where transported kernels go: POTMAP_PLACEMENT_AUTO (default: target samples for POT and
   *  per-scan RePOT; barycentric for the persistent RePOT map's seeds, since kernels on the
   *  samples are all reached by samples and would seed nothing), POTMAP_PLACEMENT_BARYCENTRIC
   *  (each atom kernel at its sample's barycentric image, the authors' rule) or
   *  POTMAP_PLACEMENT_TARGET_SAMPLES (on the scan's own samples thinned to anchor_spacing, each
   *  reading the atom's logit through the plan: walls stay on the scan's walls). */
  int placement;
  /** With target-sample placement: metres between kernels of one class, > 0 (default 0.5, the
   *  BHM's kernel spacing). */
  double anchor_spacing;
  /** Metres, >= 0 (default 0.5, about the atoms' kernel spacing; 0: off, the authors' rule). A
   *  transported free-space kernel within this distance of a hit of its sector, or a wall
   *  kernel farther than this from every hit, is dropped, so that the free space beside an
   *  atom's wall does not erase the scan's wall. */
  double wall_clearance;
  /** POT's overall map: 1 (default) the instantaneous maps' support-weighted average on a
   *  0.25 m grid, which with target-sample placement depicts the Radish logs best
   *  (docs/pot-measurements.md); 0 their kernels summed with merging (merge_radius,
   *  gamma_ratio, max_kernels; the authors' rule, in which one scan's free space erases another
   *  scan's walls). Not read by the persistent RePOT map. */
  int average_overall;
  /* ---- appended in version 4 ---- */
  /** 1: potmap_mapper_add_scan returns once the scan is transferred, and its merge into the
   *  overall map runs on another thread beside the next add_scan (the same overall map, bit for
   *  bit; every call that reads the overall map, saves or resets first waits for it, and an
   *  error of the merge is returned there). Pass stats NULL to add_scan to keep the overlap:
   *  its overall_* fields wait for the merge. 0 (default): the merge is done when add_scan
   *  returns. */
  int async_merge;
  /* ---- appended in version 5 ---- */
  /** RePOT's persistent map (refine 1, persistent_refine 1): 1 (default) makes a seed yield,
   *  its mean too, when its kernel enters a scan's solve, so the map near the data is BHM's (up
   *  to the solve's tolerance) and transported kernels speak only for space farther from it:
   *  never worse than BHM there. 0 keeps the seeded mean as the start of the scan's bound
   *  (higher F1 and lower NLL on most runs, up to 0.002 lower AUC from a mismatched source;
   *  docs/pot-measurements.md). */
  int seeds_yield_fully;
  /* ---- appended in version 6 ---- */
  /** RePOT's persistent map (refine 1, persistent_refine 1): metres between its kernels, > 0
   *  (default 0.5: about an indoor wall's thickness, so walls come out as walls; a long 3D
   *  drive may want 1). Memory and time per scan grow with the kernels a sample reaches, about
   *  (1 / spacing)^dim. */
  double refine_spacing;
  /** Prior variance of its weights, > 0 (default 10, the BHM authors' demo: with overlapping
   *  kernels a large prior lets neighbours cancel in unobserved gaps). */
  double refine_prior_var;
  /** Jaakkola-Jordan EM rounds per scan, 1 to 100 (default 3: each round costs a solve; more
   *  tighten the bound on the scan's samples). */
  int refine_em_iterations;
  /* ---- appended in version 7 ---- */
  /** RePOT's persistent map (refine 1, persistent_refine 1): weight variance added to its seeds
   *  per square metre the transport moved them, >= 0 (weight units^2 / m^2; default 0.25: a
   *  seed moved 2 m gains variance 1, so a poor match dragged far says less; the paper's rules
   *  0). */
  double seed_displacement_variance;
  /* ---- appended in version 8 ---- */
  /** RePOT's persistent map: forgetting. Its evidence halves every half_life seconds of the
   *  scans' time (potmap_scan::timestamp), so a place seen free after it was seen occupied reads
   *  free within a few scans and a place no longer seen drifts back to its prior; >= 0
   *  (default 0: never forget, the exact posterior of every scan; docs/forgetting.md). */
  double half_life;
  /* ---- appended in version 9 ---- */
  /** With target-sample placement: free-sample kernels within this distance of one of the
   *  sector's hits are dropped, metres, >= 0 (default 0.25, half the atoms' kernel spacing;
   *  wall_clearance applies to barycentric kernels). */
  double anchor_clearance;
  /** With target-sample placement: projected Gauss-Seidel sweeps that solve a scan's kernel
   *  weights together, walls and free space, so that its map reads each kernel's transported
   *  value where the kernel stands, >= 0 (default 10; 0: each class's own partition, which
   *  blurs a wall into the free space beside it). */
  int anchor_sweeps;
  /** With target-sample placement: factor on the transported logits, > 0 (default 1.5, fitted
   *  on the Intel log and checked on three other Radish logs: the averaged map read from atoms
   *  learned on few scans is right about which side of 0.5 a place is, but too near it;
   *  docs/pot-measurements.md). */
  double logit_gain;
} potmap_mapper_options;

/** Values of potmap_mapper_options::ranking. */
enum potmap_ranking { POTMAP_RANKING_EXHAUSTIVE = 0, POTMAP_RANKING_INDEXED = 1 };

/** Values of potmap_mapper_options::placement. */
enum potmap_placement {
  POTMAP_PLACEMENT_BARYCENTRIC = 0,
  POTMAP_PLACEMENT_TARGET_SAMPLES = 1,
  POTMAP_PLACEMENT_AUTO = 2
};

/** Fills *options with the defaults above (the library's, which map real logs best: on the
 *  Intel log, 60 scans, the default dictionary, overall AUC / NLL 0.958 / 0.211 against
 *  0.880 / 1.302 with the paper's rules); struct_size: the caller's sizeof(*options). */
POTMAP_EXPORT potmap_status potmap_mapper_options_init(potmap_mapper_options* options,
                                                       size_t struct_size);

/** Fills *options with the paper's rules (MapperOptions::paper()): the defaults above, then
 *  ranking EXHAUSTIVE, placement BARYCENTRIC, wall_clearance 0, average_overall 0 and
 *  seed_displacement_variance 0. For reproducing the paper; set refine afterwards as wanted.
 *  struct_size as for _init; a caller whose struct predates a field gets only those it has. */
POTMAP_EXPORT potmap_status potmap_mapper_options_init_paper(potmap_mapper_options* options,
                                                             size_t struct_size);

/** Fills *options with the settings `potmap map` maps real logs with: the defaults above with
 *  its RePOT seeds, seed_displacement_variance 0. Set refine afterwards as wanted; struct_size
 *  as for _init. A caller whose struct predates version 3 gets only the fields it has. */
POTMAP_EXPORT potmap_status potmap_mapper_options_init_map_defaults(potmap_mapper_options* options,
                                                                    size_t struct_size);

/** Creates a mapper on the context's device with the dictionary (shared, kept alive by the
 *  mapper). `options` NULL: the defaults. *out receives a new handle; free it with
 *  potmap_mapper_destroy. The mapper keeps the context alive too.
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT (bad options, an empty dictionary). */
POTMAP_EXPORT potmap_status potmap_mapper_create(potmap_context* context,
                                                 const potmap_dictionary* dictionary,
                                                 const potmap_mapper_options* options,
                                                 potmap_mapper** out);

/** Frees the mapper and everything it accumulated. NULL: no-op. */
POTMAP_EXPORT potmap_status potmap_mapper_destroy(potmap_mapper* mapper);

/** What potmap_mapper_add_scan did with one scan. Times in milliseconds (wall clock). */
typedef struct potmap_scan_stats {
  size_t struct_size;     /**< set by the caller to sizeof(potmap_scan_stats) */
  size_t scan_index;      /**< scans added before this one since create or reset */
  size_t sectors;         /**< target sectors that received an atom */
  size_t kernels_placed;  /**< kernels of the instantaneous map */
  size_t kernels_dropped; /**< transported kernels dropped beyond max_range */
  size_t train_samples;   /**< training samples in the target sectors (what is transported to) */
  size_t heldout_samples; /**< held-out samples within the sector radius (not used) */
  size_t overall_added;   /**< instantaneous kernels appended to the overall map (0 for the
                               persistent RePOT map, which seeds instead of merging) */
  size_t overall_merged;  /**< instantaneous kernels merged into existing ones (0 likewise) */
  size_t overall_retired; /**< kernels removed by max_kernels (0 likewise) */
  size_t overall_kernels; /**< overall map size after this scan (persistent RePOT: stored
                               kernels of the joint BHM) */
  double prepare_ms;      /**< labelling, sector cut, batch assembly (host) */
  double ranking_ms;      /**< ranking every (atom, rotation) candidate */
  double transport_ms;    /**< high-quality transport of the chosen candidates */
  double placement_ms;    /**< out-of-sample map and world frame */
  double refine_ms;       /**< RePOT's update (0 for POT; persistent: seeding and updating
                               the joint BHM) */
  double merge_ms;        /**< merging into the overall map (0 for the persistent RePOT map) */
  double total_ms;        /**< the whole call */
} potmap_scan_stats;

/** Maps one scan (POT or RePOT) and merges its instantaneous map into the overall map. The
 *  scan's dimension must be the dictionary's; it must have max_range > 0. `stats` may be null;
 *  if not, its struct_size must be set. Blocks until done. On failure the mapper is unchanged.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH, POTMAP_ERROR_INVALID_ARGUMENT (bad scan: field and
 *  value named), POTMAP_ERROR_BUFFER_TOO_SMALL (stats->struct_size too small), OpenCL codes. */
POTMAP_EXPORT potmap_status potmap_mapper_add_scan(potmap_mapper* mapper, const potmap_scan* scan,
                                                   potmap_scan_stats* stats);

/** The last scan's instantaneous map (empty before the first scan), as a new map handle
 *  (a copy): the caller frees it with potmap_map_destroy; it stays valid after the mapper is
 *  destroyed. */
POTMAP_EXPORT potmap_status potmap_mapper_instantaneous_map(const potmap_mapper* mapper,
                                                            potmap_map** out);

/** The overall map of every scan since create or reset, as a new map handle (a copy; no bias,
 *  except RePOT's persistent joint BHM, which has one): the caller frees it with
 *  potmap_map_destroy. The persistent map is exported (a small solve per kernel) on the first
 *  call after a scan and kept: call it when the map is needed, not after every scan. */
POTMAP_EXPORT potmap_status potmap_mapper_overall_map(const potmap_mapper* mapper,
                                                      potmap_map** out);

/** Writes the overall map to `path`, format from the extension (potmap_map_save). Into a
 *  .potmap, RePOT's persistent joint BHM also carries its information form and POT's averaged
 *  map its anchor sums, which potmap_merge_maps needs; other maps and formats are the map
 *  alone.
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT (unknown extension), POTMAP_ERROR_IO (cannot write). */
POTMAP_EXPORT potmap_status potmap_mapper_save_overall_map(const potmap_mapper* mapper,
                                                           const char* path);

/** Forgets every scan (empty maps, scan index 0); keeps the context, dictionary and options. */
POTMAP_EXPORT potmap_status potmap_mapper_reset(potmap_mapper* mapper);

/** Writes the mapper's whole state to `path` (potmap/pot/mapper.hpp, Mapper::save_state): the
 *  overall map (RePOT's persistent learner with it), the scan count and what the next scans
 *  need, through a temporary file renamed into place (a half-written file never replaces an
 *  earlier one). The last scan's instantaneous map is not saved. Errors: POTMAP_ERROR_IO
 *  (cannot write). */
POTMAP_EXPORT potmap_status potmap_mapper_save_state(const potmap_mapper* mapper, const char* path);

/** Restores a state written by potmap_mapper_save_state into a mapper created with the same
 *  dictionary and options: adding the remaining scans then gives the same overall map, bit for
 *  bit, as a mapper that never stopped. Errors: POTMAP_ERROR_INPUT (missing, truncated or
 *  corrupt file, or a state of another dictionary, options or dimension; the message names the
 *  file and byte offset); the mapper is unchanged then. */
POTMAP_EXPORT potmap_status potmap_mapper_load_state(potmap_mapper* mapper, const char* path);

/* ---- 3D drives --------------------------------------------------------------------------- */

/** How a 3D drive is mapped (potmap/mapping/drive_mapper.hpp, DriveMapperOptions; the defaults are
 *  `potmap mapping DRIVE`'s, chosen on real drives: docs/drives-3d.md). */
typedef struct potmap_drive_mapper_options {
  size_t struct_size;      /**< the caller's sizeof (potmap_drive_mapper_options_init sets it) */
  double range_cut;        /**< horizontal range cut, metres, > 0 (default 40) */
  double free_per_metre;   /**< free samples per metre of beam, > 0 (default 0.5) */
  double holdout_fraction; /**< beams held out of every keyframe for scoring, [0, 1) (0.2) */
  uint64_t seed;           /**< labelling and hold-out seed (default 0) */
  double voxel;            /**< samples gathered per voxel of this edge, metres (0.5; 0: none) */
  /** Tiles farther than this from the sensor (metres, x and y) are retired to their means and
   *  variances after each keyframe (default -1: range_cut + 16; 0: never). */
  double retire_radius;
  /** RePOT (potmap_drive_mapper_create_repot): transfer every this many keyframes, >= 1
   *  (default 4: seeds last until data reaches them). */
  size_t transfer_every;
  /** Where the joint BHM's features and sums run (enum potmap_sums): POTMAP_SUMS_AUTOMATIC
   *  (default: the device when it is a GPU with doubles, else the host), POTMAP_SUMS_HOST or
   *  POTMAP_SUMS_DEVICE (any device with doubles). The map is the same up to the rounding of
   *  sums taken in another order. */
  int sums;
  /* ---- appended in version 2 ---- */
  /** Forgetting: the joint BHM's evidence halves every half_life seconds of the keyframes' time
   *  (potmap_scan::timestamp); >= 0 (default 0: never; docs/forgetting.md). */
  double half_life;
  /* ---- appended in version 3 ---- */
  /** 1: score each keyframe's kept held-out samples on the map before the keyframe is added
   *  (potmap_drive_mapper_lookahead). Default 0. */
  int lookahead;
} potmap_drive_mapper_options;

/** potmap_drive_mapper_options::sums. */
enum potmap_sums { POTMAP_SUMS_AUTOMATIC = 0, POTMAP_SUMS_HOST = 1, POTMAP_SUMS_DEVICE = 2 };

/** Fills *options with the defaults above; struct_size as for potmap_scan_init. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_options_init(potmap_drive_mapper_options* options,
                                                             size_t struct_size);

/** Creates a drive mapper. `context` may be NULL (the update runs on the calling thread alone;
 *  with a context, on its host team too: the same map bit for bit). `options` NULL: the
 *  defaults. *out receives a new handle; free it with potmap_drive_mapper_destroy.
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT (an option out of range: field and value named). */
POTMAP_EXPORT potmap_status potmap_drive_mapper_create(potmap_context* context,
                                                       const potmap_drive_mapper_options* options,
                                                       potmap_drive_mapper** out);

/** A drive mapper that runs RePOT: each keyframe's training samples are transported from the
 *  3D atoms of `dictionary` (shared: the handle may be destroyed after this call) and the
 *  transported kernels seed the joint BHM where no sample has reached (DriveMapperOptions::
 *  dictionary; `potmap mapping DRIVE --method repot`). Otherwise as potmap_drive_mapper_create.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH (a 2D dictionary), as potmap_drive_mapper_create. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_create_repot(
    potmap_context* context, const potmap_drive_mapper_options* options,
    const potmap_dictionary* dictionary, potmap_drive_mapper** out);

/** Frees the mapper. NULL: no-op. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_destroy(potmap_drive_mapper* mapper);

/** What potmap_drive_mapper_add_keyframe did. Times in milliseconds (wall clock). */
typedef struct potmap_keyframe_stats {
  size_t struct_size;  /**< set by the caller to sizeof(potmap_keyframe_stats) */
  size_t samples;      /**< training samples before gathering */
  size_t gathered;     /**< weighted samples the joint BHM took */
  size_t held_out;     /**< held-out samples kept for scoring */
  size_t retired;      /**< tiles retired after the keyframe */
  size_t memory_bytes; /**< what the mapper holds after it */
  double label_ms;     /**< cut, labelling and gathering */
  double update_ms;    /**< the joint BHM's update and the retiring */
  double transfer_ms;  /**< RePOT's transfer and seeding (0 without a dictionary) */
  size_t seeded;       /**< kernels RePOT seeded */
  int sums_on_device;  /**< 1: the joint BHM's features and sums ran on the device */
  /* ---- appended last (a struct_size that ends before it: not written) ---- */
  double lookahead_ms; /**< the look-ahead's scoring (options lookahead; 0 without, and for the
                            first keyframe); not part of the times above */
} potmap_keyframe_stats;

/** Adds keyframe `index` (a 3D scan in the world frame: hits moved by the pose, which gives
 *  the sensor's position; potmap_dataset_load reads a drive folder into such scans). The index
 *  seeds its labelling. `stats` may be NULL. On failure the mapper is unchanged.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH (a 2D scan), POTMAP_ERROR_INVALID_ARGUMENT (a bad
 *  scan: field and value named), POTMAP_ERROR_BUFFER_TOO_SMALL (stats->struct_size). */
POTMAP_EXPORT potmap_status potmap_drive_mapper_add_keyframe(potmap_drive_mapper* mapper,
                                                             const potmap_scan* keyframe,
                                                             int64_t index,
                                                             potmap_keyframe_stats* stats);

/** The map of every keyframe so far (retired tiles included), as a new map handle: the caller
 *  frees it with potmap_map_destroy. It costs a solve and a variance per changed tile: call it
 *  when the map is needed, not after every keyframe. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_map(const potmap_drive_mapper* mapper,
                                                    potmap_map** out);

/** The look-ahead so far (options lookahead): the kept held-out samples of every keyframe
 *  after the first, scored on the map before their keyframe was added: *auc, *nll over all n
 *  of them, and *beyond_auc, *beyond_nll over the *beyond_n that no earlier sample had reached
 *  (NaN where there are none, or only one class). Any out-pointer may be NULL. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_lookahead(const potmap_drive_mapper* mapper,
                                                          double* auc, double* nll, size_t* n,
                                                          double* beyond_auc, double* beyond_nll,
                                                          size_t* beyond_n);

/** Writes the map to `path`, format from the extension (potmap_map_save). Into a .potmap, the
 *  joint BHM's information form (for potmap_merge_maps) goes with it when no tile was retired
 *  (options retire_radius 0); otherwise the map alone.
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT (unknown extension), POTMAP_ERROR_IO (cannot write). */
POTMAP_EXPORT potmap_status potmap_drive_mapper_save_map(const potmap_drive_mapper* mapper,
                                                         const char* path);

/** The held-out samples kept: *n samples, their positions (3 doubles each) and labels (1
 *  occupied, 0 free), borrowed: valid until the next add_keyframe, load_state or destroy. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_held_out(const potmap_drive_mapper* mapper,
                                                         size_t* n, const double** positions,
                                                         const uint8_t** labels);

/** Writes the mapper's whole state to `path` atomically (DriveMapper::save_state); a mapper
 *  with the same options that loads it continues bit for bit. Errors: POTMAP_ERROR_IO. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_save_state(const potmap_drive_mapper* mapper,
                                                           const char* path);

/** Restores a state of potmap_drive_mapper_save_state. Errors: POTMAP_ERROR_INPUT (a damaged
 *  file, or one saved with other options: the message names the file and byte); the mapper is
 *  unchanged then. */
POTMAP_EXPORT potmap_status potmap_drive_mapper_load_state(potmap_drive_mapper* mapper,
                                                           const char* path);

/* ---- a 3D map's volume as files (potmap/mapping/drive_volume.hpp) ------------------------ */

/** What potmap_export_drive_volume writes and how. */
typedef struct potmap_drive_volume_options {
  size_t struct_size; /**< the caller's sizeof (potmap_drive_volume_options_init sets it) */
  /** Voxel edge, metres, > 0 (default 0.4: the drive map's kernels are 1 m apart, finer voxels
   *  show the same surfaces at 8 times the work a halving). */
  double voxel;
  double band_low;          /**< the height band's bottom, metres about the path's height (-1.0) */
  double band_high;         /**< and its top, above band_low (default 0.5: a van's roof) */
  const char* octomap_path; /**< OctoMap .bt of every known voxel to write, or NULL */
  const char* cloud_path;   /**< PLY of the occupied voxels to write, or NULL */
} potmap_drive_volume_options;

/** What potmap_export_drive_volume found. */
typedef struct potmap_drive_volume_summary {
  size_t struct_size;     /**< set by the caller to sizeof(potmap_drive_volume_summary) */
  size_t blocks;          /**< blocks of 16^3 voxels evaluated (those holding kernels) */
  size_t occupied_voxels; /**< known and p > 0.5 */
  size_t free_voxels;     /**< known and p <= 0.5 */
  size_t unknown_voxels;  /**< left out of the OctoMap */
  uint64_t octomap_nodes; /**< nodes of the .bt's tree */
  uint64_t octomap_leaves;
} potmap_drive_volume_summary;

/** Fills *options with the defaults above; struct_size as for potmap_scan_init. */
POTMAP_EXPORT potmap_status potmap_drive_volume_options_init(potmap_drive_volume_options* options,
                                                             size_t struct_size);

/** Evaluates a 3D map on the context's device over the blocks of 16^3 voxels that hold its
 *  kernels and writes the files `options` names (each whole or not at all), as `potmap mapping
 *  DRIVE` writes map.bt and map_occupied.ply. `path`: `positions` sensor positions in order (x
 *  y z each, metres; at least one), whose height the band follows. Call it on
 *  potmap_drive_mapper_map's map between keyframes for the map so far. `summary` may be NULL.
 *  Errors: POTMAP_ERROR_DIMENSION_MISMATCH (a 2D map), POTMAP_ERROR_INVALID_ARGUMENT (an empty
 *  map or path, an option out of range: field and value named), POTMAP_ERROR_IO. */
POTMAP_EXPORT potmap_status potmap_export_drive_volume(potmap_context* context,
                                                       const potmap_map* map, const double* path,
                                                       size_t positions,
                                                       const potmap_drive_volume_options* options,
                                                       potmap_drive_volume_summary* summary);

/* ---- the mapping job (potmap/job/mapping_job.hpp): a recording into a folder ------------- */

/** How potmap_map_recording maps: `potmap mapping`'s options (docs/commands.md). Strings may be
 *  NULL (their default); they are read during the call only. */
typedef struct potmap_mapping_job_options {
  size_t struct_size; /**< the caller's sizeof (potmap_mapping_job_options_init sets it) */
  const char* out;    /**< the output folder, created with its parents; required */
  /** NULL or "" (default: by the recording, "repot" for a 2D log, "bhm" for a 3D drive),
   *  "repot" or "pot" for 2D logs, "bhm" or "repot" for 3D drives. */
  const char* method;
  /** A .potdict file (NULL: the built-in dictionary's cached file, which `potmap dict default`
   *  builds once; POTMAP_ERROR_INVALID_ARGUMENT when it is not built yet). */
  const char* dictionary;
  /** Returns farther than this become no-returns, metres (default -1: 20 for 2D logs, the
   *  towns' range the built-in atoms are cut at; 40 for 3D drives; 0: none). */
  double range_cut;
  size_t first;          /**< scans or keyframes skipped (default 0) */
  size_t max_scans;      /**< at most this many mapped (default 0: all) */
  uint64_t seed;         /**< labelling, hold-out and subsampling (default 0) */
  double half_life;      /**< forgetting, seconds of the scans' time (default 0: never) */
  size_t picture_pixels; /**< along the pictures' longer side (default 1200) */
  const char* preset;    /**< 2D: "default" (NULL) or "paper" (the authors' rules) */
  double band_low;       /**< 3D: the band's bottom, metres about the sensor (default -1.0) */
  double band_high;      /**< 3D: its top (default 0.5: a van's roof) */
  double voxel;          /**< 3D: the exports' voxel edge, metres (default 0.4) */
  /** 3D: a checkpoint OUT/map.ckpt after every N keyframes (default 0: not by count) and when
   *  checkpoint_seconds have passed since the last (default 30; 0: not by time). */
  size_t checkpoint_every;
  double checkpoint_seconds;
  size_t export_every; /**< 3D: keyframes between exports of the map so far (0: at the end) */
  int resume;          /**< 3D: 1 continues from OUT/map.ckpt when it is there (default 0) */
  /* ---- appended in version 2 ---- */
  /** 1 scores each keyframe's (2D: scan's, RePOT only) held-out samples on the map before it
   *  is added (`potmap mapping --lookahead`; result's lookahead fields). Default 0. */
  int lookahead;
} potmap_mapping_job_options;

/** Fills *options with the defaults above (out NULL); struct_size as for potmap_scan_init. */
POTMAP_EXPORT potmap_status potmap_mapping_job_options_init(potmap_mapping_job_options* options,
                                                            size_t struct_size);

/** Where a mapping job stands; its strings are valid during the callback only. */
typedef struct potmap_job_progress {
  const char* stage;  /**< "mapping", "outputs" or "export" */
  const char* unit;   /**< "scan", "keyframe" or "share" (thousandths of the outputs) */
  size_t done, total; /**< units done and in all */
  double elapsed_s;   /**< since the stage began */
  const char* detail; /**< the unit just done, one line ("" for shares) */
} potmap_job_progress;

/** Called after every scan or keyframe and batch of output blocks; return nonzero to stop the
 *  job there (potmap_map_recording then returns POTMAP_ERROR_CANCELLED, every file whole). */
typedef int (*potmap_job_progress_fn)(const potmap_job_progress* progress, void* user);
/** Called with each line of the job's account (what is mapped, the device, the scores). */
typedef void (*potmap_job_note_fn)(const char* line, void* user);

/** What potmap_map_recording made. */
typedef struct potmap_mapping_job_result {
  size_t struct_size;   /**< set by the caller to sizeof(potmap_mapping_job_result) */
  int drive;            /**< 1: a 3D drive; 0: a 2D log */
  size_t files;         /**< files written into the folder, OUT/scores.json the last */
  double acc, auc, nll; /**< every held-out beam (20 %, never mapped) on the final map */
  size_t samples;       /**< held-out samples scored */
  /* ---- appended in version 2 ---- */
  /** options lookahead: the held-out samples scored on the map before their keyframe (scan)
   *  was added, all of them and those beyond every earlier sample's reach (NaN without). */
  double lookahead_auc, lookahead_nll;
  size_t lookahead_samples;
  double beyond_auc, beyond_nll;
  size_t beyond_samples;
} potmap_mapping_job_result;

/** Maps the recording at `path` (a 2D log, a 3D drive folder or a ROS bag) on the context's
 *  device into options->out, as `potmap mapping PATH -o OUT` does: the same files (map.potmap,
 *  pictures, a ROS map; for a drive also map.bt, map_occupied.ply and the band's files) and the
 *  same OUT/scores.json. `note`, `progress` and `result` may be NULL; `user` is passed to the
 *  callbacks, which run on the calling thread or the job's workers, one at a time.
 *  Errors: POTMAP_ERROR_INVALID_ARGUMENT (an option out of range: field and value named),
 *  POTMAP_ERROR_INPUT (an unreadable recording: the file named), POTMAP_ERROR_IO (cannot
 *  write), POTMAP_ERROR_CANCELLED (stopped by `progress`). */
POTMAP_EXPORT potmap_status potmap_map_recording(potmap_context* context, const char* path,
                                                 const potmap_mapping_job_options* options,
                                                 potmap_job_note_fn note,
                                                 potmap_job_progress_fn progress, void* user,
                                                 potmap_mapping_job_result* result);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* POTMAP_POTMAP_H */
