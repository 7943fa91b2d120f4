/* Streaming a real LIDAR log through potmap's POT/RePOT mapper from a C program that drives its
 * own OpenCL device.
 *
 * Usage: embed_map_log LOG [OVERALL_MAP] [SOURCE_SCANS] [SCANS] [pot|repot]
 *   LOG           a dataset potmap reads (CARMEN .log/.log.gz, ...), e.g.
 *                 ../shared/data/radish/intel-corrected.log.gz
 *   OVERALL_MAP   where the overall map goes (.potmap, .csv or .npz; default
 *                 embed_overall.potmap); the dictionary is written beside it (.potdict)
 *   SOURCE_SCANS  scans the dictionary is built from (default 10: the log's first ones)
 *   SCANS         scans mapped after them (default 30)
 *   pot|repot     the method (default repot)
 *
 * What it shows: the program opens its own OpenCL context and queue and hands the queue to
 * potmap; reads the log with potmap_dataset_load; learns a BHM map of the first scans and cuts
 * them into a dictionary of atoms; creates a mapper and feeds it the next scans one at a time
 * (as a SLAM front end would), printing each scan's statistics; writes the overall map; then
 * checks it on the mapped scans themselves: the probability of occupancy at their beam end
 * points and at their beams' mid points (free space), evaluated on the device. Exit status: 0
 * when most mid points are free and most beams see a higher probability at their end point
 * than at their mid point, 1 when not, 2 on an error. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <potmap/potmap.h>

#include "embed_util.h"

int main(int argc, char** argv) {
  const char* log_path = argc > 1 ? argv[1] : NULL;
  const char* out_path = argc > 2 ? argv[2] : "embed_overall.potmap";
  size_t n_source = argc > 3 ? (size_t)strtoul(argv[3], NULL, 10) : 10;
  size_t n_map = argc > 4 ? (size_t)strtoul(argv[4], NULL, 10) : 30;
  const int refine = argc > 5 ? strcmp(argv[5], "pot") != 0 : 1;
  int status = 2, dim = 0;
  size_t n_scans = 0, i, j, atoms = 0, kernels = 0, count = 0, n_points = 0, n_hits = 0;
  size_t hit_ok = 0, free_ok = 0, ranked = 0;
  double ms = 0;
  char* dict_path = NULL;
  double* points = NULL;
  float* prob = NULL;
  potmap_scan* scans = NULL;
  const potmap_scan** source = NULL;
  cl_device_id device = NULL;
  cl_context cl_ctx = NULL;
  cl_command_queue queue = NULL;
  potmap_context* ctx = NULL;
  potmap_dataset* data = NULL;
  potmap_map* source_map = NULL;
  potmap_map* overall = NULL;
  potmap_dictionary* dict = NULL;
  potmap_mapper* mapper = NULL;
  potmap_evaluator* ev = NULL;
  potmap_mapper_options options;
  potmap_scan_stats stats;
  const potmap_device_info* info = NULL;

  if (!log_path) {
    fprintf(stderr, "usage: %s LOG [OVERALL_MAP] [SOURCE_SCANS] [SCANS] [pot|repot]\n", argv[0]);
    return 2;
  }

  /* 1. The host's own OpenCL objects, and potmap on its queue. */
  if (!open_host_queue(&device, &cl_ctx, &queue)) goto cleanup;
  POTMAP_TRY(potmap_context_create_from_queue(queue, &ctx));
  POTMAP_TRY(potmap_context_device_info(ctx, &info));
  printf("potmap %s on %s\n", potmap_version_string(), info->name);

  /* 2. The log. Scans filled by potmap_dataset_scan point into the dataset (no copy). */
  POTMAP_TRY(potmap_dataset_load(log_path, &data));
  POTMAP_TRY(potmap_dataset_size(data, &n_scans));
  if (n_source < 1 || n_source + n_map > n_scans) {
    fprintf(stderr, "%s has %zu scans: fewer than %zu + %zu\n", log_path, n_scans, n_source, n_map);
    goto cleanup;
  }
  scans = malloc((n_source + n_map) * sizeof *scans);
  source = malloc(n_source * sizeof *source);
  if (!scans || !source) goto cleanup;
  for (i = 0; i < n_source + n_map; ++i) {
    POTMAP_TRY(potmap_scan_init(&scans[i], sizeof scans[i]));
    POTMAP_TRY(potmap_dataset_scan(data, i, &scans[i]));
  }
  for (i = 0; i < n_source; ++i) source[i] = &scans[i];
  dim = scans[0].dim;
  printf("%s: %zu scans, %dD; dictionary from scans 0-%zu, mapping scans %zu-%zu\n", log_path,
         n_scans, dim, n_source - 1, n_source, n_source + n_map - 1);

  /* 3. The dictionary: a BHM map of the source scans, cut into atoms with them. */
  POTMAP_TRY(potmap_map_learn_bhm(ctx, source, n_source, 0.0, 0.0, &source_map));
  POTMAP_TRY(potmap_dictionary_build(source, n_source, source_map, NULL, &dict));
  POTMAP_TRY(potmap_dictionary_info(dict, NULL, &atoms, &kernels, NULL, NULL, NULL));
  dict_path = malloc(strlen(out_path) + sizeof ".potdict");
  if (!dict_path) goto cleanup;
  strcpy(dict_path, out_path);
  if (strrchr(dict_path, '.') && strrchr(dict_path, '.') > strrchr(dict_path, '/'))
    *strrchr(dict_path, '.') = '\0';
  strcat(dict_path, ".potdict");
  POTMAP_TRY(potmap_dictionary_save(dict, dict_path));
  printf("dictionary: %zu atoms, %zu kernels -> %s\n", atoms, kernels, dict_path);

  /* 4. The mapper, fed one scan at a time. */
  /* `potmap map`'s settings (indexed ranking, kernels on the scans' samples, averaged overall
     map); potmap_mapper_options_init gives the paper's rules instead. */
  POTMAP_TRY(potmap_mapper_options_init_map_defaults(&options, sizeof options));
  options.refine = refine;
  POTMAP_TRY(potmap_mapper_create(ctx, dict, &options, &mapper));
  stats.struct_size = sizeof stats;
  for (i = n_source; i < n_source + n_map; ++i) {
    POTMAP_TRY(potmap_mapper_add_scan(mapper, &scans[i], &stats));
    ms += stats.total_ms;
    printf(
        "scan %4zu: %zu sectors, %4zu kernels, %6.1f ms (ranking %.1f, transport %.1f); "
        "overall %zu kernels (+%zu, %zu merged)\n",
        i, stats.sectors, stats.kernels_placed, stats.total_ms, stats.ranking_ms,
        stats.transport_ms, stats.overall_kernels, stats.overall_added, stats.overall_merged);
  }

  /* 5. The overall map: written, then evaluated at the mapped scans' end points (occupied) and
   *    beam mid points (free). */
  POTMAP_TRY(potmap_mapper_overall_map(mapper, &overall));
  POTMAP_TRY(potmap_map_size(overall, &dim, &count));
  POTMAP_TRY(potmap_map_save(overall, out_path));
  printf("%s %s: %zu scans in %.1f s (%.0f ms per scan); overall map %zu kernels -> %s\n",
         refine ? "RePOT" : "POT", info->name, n_map, ms / 1000, ms / (double)n_map, count,
         out_path);
  for (i = n_source; i < n_source + n_map; ++i) n_points += 2 * scans[i].num_hits;
  points = malloc(n_points * dim * sizeof *points);
  prob = malloc(n_points * sizeof *prob);
  if (!points || !prob) goto cleanup;
  for (i = n_source; i < n_source + n_map; ++i) {
    memcpy(points + n_hits * dim, scans[i].hits, scans[i].num_hits * dim * sizeof *points);
    n_hits += scans[i].num_hits;
  }
  for (i = n_source, j = n_hits; i < n_source + n_map; ++i) {
    /* Mid point between the sensor (pose[0..1] in 2D, the translation column in 3D) and the hit. */
    size_t k;
    int d;
    for (k = 0; k < scans[i].num_hits; ++k, ++j)
      for (d = 0; d < dim; ++d) {
        const double sensor = dim == 2 ? scans[i].pose[d] : scans[i].pose[4 * d + 3];
        points[j * dim + d] = 0.5 * (sensor + scans[i].hits[k * dim + d]);
      }
  }
  POTMAP_TRY(potmap_evaluator_create(ctx, overall, 0.0, &ev));
  POTMAP_TRY(potmap_evaluate(ev, points, n_points, dim, NULL, NULL, prob, n_points));
  for (i = 0; i < n_hits; ++i) {
    hit_ok += prob[i] > 0.5f;
    free_ok += prob[n_hits + i] < 0.5f;
    ranked += prob[i] > prob[n_hits + i];
  }
  printf(
      "check on %zu beams: p > 0.5 at %.1f %% of end points, p < 0.5 at %.1f %% of mid points, "
      "p(end) > p(mid) for %.1f %%\n",
      n_hits, 100.0 * hit_ok / n_hits, 100.0 * free_ok / n_hits, 100.0 * ranked / n_hits);
  status = 2 * free_ok > n_hits && 2 * ranked > n_hits ? 0 : 1;

cleanup:
  potmap_evaluator_destroy(ev);
  potmap_mapper_destroy(mapper);
  potmap_dictionary_destroy(dict);
  potmap_map_destroy(overall);
  potmap_map_destroy(source_map);
  potmap_dataset_destroy(data);
  potmap_context_destroy(ctx);
  if (queue) clReleaseCommandQueue(queue);
  if (cl_ctx) clReleaseContext(cl_ctx);
  free(dict_path);
  free(points);
  free(prob);
  free(scans);
  free(source);
  return status;
}
