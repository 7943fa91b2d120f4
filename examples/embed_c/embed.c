/* Embedding potmap in a C program that drives its own OpenCL device.
 *
 * Usage: embed_c [MAP|-] [RESULTS.csv]
 *   MAP          a kernel map (.csv, .npz, .potmap), e.g. ../shared/data/carla/town1_abhm_map.csv;
 *                without it, or with "-", a small 2D map (a square room) is made from arrays.
 *   RESULTS.csv  where the values go (default embed_results.csv): one row per query point,
 *                x,y[,z],prob,var,prob_device.
 *
 * What it shows: the program opens its own OpenCL context and queue with plain OpenCL calls and
 * hands the queue to potmap; evaluates a grid of points over the map from host arrays, then the
 * same points from its own cl_mem buffers, waiting on the event potmap returns; checks the two
 * agree. Exit status: 0 when they agree, 1 when they do not, 2 on an error. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <potmap/potmap.h>

#include "embed_util.h"

#define SIDE 64 /* query points: a SIDE x SIDE grid over the map's bounds */

/* A 10 m square room: occupied walls (positive weights), free floor (negative weights). */
static potmap_status make_room(potmap_map** out) {
  double pos[2 * 200], gamma[200], w_mean[200], w_var[200];
  size_t n = 0;
  int i, j;
  for (i = 0; i < 40; ++i) {
    const double t = 10.0 * i / 40.0;
    const double wall[4][2] = {{t, 0.0}, {10.0, t}, {10.0 - t, 10.0}, {0.0, 10.0 - t}};
    for (j = 0; j < 4; ++j, ++n) {
      pos[2 * n] = wall[j][0];
      pos[2 * n + 1] = wall[j][1];
      gamma[n] = 4.0;
      w_mean[n] = 3.0;
      w_var[n] = 0.2;
    }
  }
  for (i = 0; i < 40; ++i, ++n) {
    pos[2 * n] = 1.5 + 7.0 * (i % 8) / 7.0;
    pos[2 * n + 1] = 1.5 + 7.0 * (i / 8) / 4.0;
    gamma[n] = 0.5;
    w_mean[n] = -1.5;
    w_var[n] = 0.5;
  }
  return potmap_map_create(2, n, pos, gamma, w_mean, w_var, out);
}

int main(int argc, char** argv) {
  const char* map_path = argc > 1 && strcmp(argv[1], "-") != 0 ? argv[1] : NULL;
  const char* out_path = argc > 2 ? argv[2] : "embed_results.csv";
  int status = 2, major = 0, minor = 0, patch = 0, dim = 0, d;
  size_t count = 0, n = (size_t)SIDE * SIDE, i, k;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, origin[3] = {0, 0, 0};
  double* positions = NULL;
  double* points = NULL;
  float *rel = NULL, *prob = NULL, *var = NULL, *prob_dev = NULL;
  float max_diff = 0.0f;
  cl_device_id device = NULL;
  cl_context cl_ctx = NULL;
  cl_command_queue queue = NULL;
  cl_mem d_points = NULL, d_prob = NULL;
  cl_event done = NULL;
  cl_int err = CL_SUCCESS;
  potmap_context* ctx = NULL;
  potmap_map* map = NULL;
  potmap_evaluator* ev = NULL;
  const potmap_device_info* info = NULL;
  FILE* out = NULL;

  /* The library must be the major version this program was compiled against. */
  POTMAP_TRY(potmap_version(&major, &minor, &patch));
  if (major != POTMAP_VERSION_MAJOR) {
    fprintf(stderr, "potmap %s found, built against %s\n", potmap_version_string(),
            POTMAP_VERSION_STRING);
    return 2;
  }

  /* 1. The host's own OpenCL objects. */
  if (!open_host_queue(&device, &cl_ctx, &queue)) goto cleanup;

  /* 2. potmap on that queue: its work is ordered with the host's. */
  POTMAP_TRY(potmap_context_create_from_queue(queue, &ctx));
  POTMAP_TRY(potmap_context_device_info(ctx, &info));
  printf("potmap %s on %s (%s)\n", potmap_version_string(), info->name, info->platform);

  /* 3. A map, and its bounds from the positions read back. */
  if (map_path)
    POTMAP_TRY(potmap_map_load(map_path, &map));
  else
    POTMAP_TRY(make_room(&map));
  POTMAP_TRY(potmap_map_size(map, &dim, &count));
  if (count == 0) {
    fprintf(stderr, "the map has no kernels\n");
    goto cleanup;
  }
  positions = malloc(count * dim * sizeof *positions);
  if (!positions) goto cleanup;
  POTMAP_TRY(potmap_map_read(map, positions, count * dim, NULL, NULL, NULL, 0));
  for (d = 0; d < dim; ++d) lo[d] = hi[d] = positions[d];
  for (k = 1; k < count; ++k)
    for (d = 0; d < dim; ++d) {
      const double v = positions[k * dim + d];
      lo[d] = v < lo[d] ? v : lo[d];
      hi[d] = v > hi[d] ? v : hi[d];
    }
  for (d = 0; d < dim; ++d) origin[d] = 0.5 * (lo[d] + hi[d]);
  printf("map: %zu kernels, %dD, x [%.1f, %.1f] y [%.1f, %.1f]\n", count, dim, lo[0], hi[0], lo[1],
         hi[1]);
  POTMAP_TRY(potmap_evaluator_create(ctx, map, 0.0, &ev));

  /* 4. Query points: a grid over x and y (z at mid-height in 3D). */
  points = malloc(n * dim * sizeof *points);
  rel = malloc(n * dim * sizeof *rel);
  prob = malloc(n * sizeof *prob);
  var = malloc(n * sizeof *var);
  prob_dev = malloc(n * sizeof *prob_dev);
  if (!points || !rel || !prob || !var || !prob_dev) goto cleanup;
  for (i = 0; i < n; ++i) {
    points[i * dim] = lo[0] + (hi[0] - lo[0]) * ((i % SIDE) + 0.5) / SIDE;
    points[i * dim + 1] = lo[1] + (hi[1] - lo[1]) * ((i / SIDE) + 0.5) / SIDE;
    if (dim == 3) points[i * dim + 2] = origin[2];
    /* Device points are floats relative to an origin near them (precision in large frames). */
    for (d = 0; d < dim; ++d) rel[i * dim + d] = (float)(points[i * dim + d] - origin[d]);
  }

  /* 5a. From host arrays: blocks until the values are there. */
  POTMAP_TRY(potmap_evaluate(ev, points, n, dim, NULL, var, prob, n));

  /* 5b. From the host's own device buffers: returns at once; wait on the event. */
  d_points = clCreateBuffer(cl_ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * dim * sizeof *rel,
                            rel, &err);
  CL_TRY(err);
  d_prob = clCreateBuffer(cl_ctx, CL_MEM_WRITE_ONLY, n * sizeof *prob_dev, NULL, &err);
  CL_TRY(err);
  POTMAP_TRY(
      potmap_evaluate_device(ev, d_points, n, dim, origin, NULL, NULL, d_prob, 0, NULL, &done));
  CL_TRY(clWaitForEvents(1, &done));
  CL_TRY(clEnqueueReadBuffer(queue, d_prob, CL_TRUE, 0, n * sizeof *prob_dev, prob_dev, 0, NULL,
                             NULL));

  /* 6. Results. */
  out = fopen(out_path, "w");
  if (!out) {
    fprintf(stderr, "cannot write %s\n", out_path);
    goto cleanup;
  }
  fprintf(out, dim == 3 ? "x,y,z,prob,var,prob_device\n" : "x,y,prob,var,prob_device\n");
  for (i = 0; i < n; ++i) {
    const float diff = (float)fabs(prob[i] - prob_dev[i]);
    max_diff = diff > max_diff ? diff : max_diff;
    for (d = 0; d < dim; ++d) fprintf(out, "%.3f,", points[i * dim + d]);
    fprintf(out, "%.7g,%.7g,%.7g\n", prob[i], var[i], prob_dev[i]);
  }
  if (fclose(out) != 0) {
    out = NULL;
    fprintf(stderr, "cannot write %s\n", out_path);
    goto cleanup;
  }
  out = NULL;
  printf("%zu points written to %s; host vs device buffers: max |dp| = %.2g\n", n, out_path,
         max_diff);
  status = max_diff < 1e-4f ? 0 : 1;

cleanup:
  if (out) fclose(out);
  if (done) clReleaseEvent(done);
  if (d_points) clReleaseMemObject(d_points);
  if (d_prob) clReleaseMemObject(d_prob);
  potmap_evaluator_destroy(ev);
  potmap_map_destroy(map);
  potmap_context_destroy(ctx);
  if (queue) clReleaseCommandQueue(queue);
  if (cl_ctx) clReleaseContext(cl_ctx);
  free(positions);
  free(points);
  free(rel);
  free(prob);
  free(var);
  free(prob_dev);
  return status;
}
