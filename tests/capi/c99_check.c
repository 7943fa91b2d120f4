/* Compiled as strict C99 (-pedantic-errors -Werror): potmap.h must be plain C. Called from
 * capi_test.cpp; returns 0, or the line of the first check that failed. */
#include <string.h>

#include "potmap/potmap.h"

int potmap_c99_check(void);

#define CHECK(cond)               \
  do {                            \
    if (!(cond)) return __LINE__; \
  } while (0)

int potmap_c99_check(void) {
  int major = -1, minor = -1, patch = -1;
  const double position[4] = {0.0, 0.0, 1.0, 2.0};
  const double gamma[2] = {1.0, 0.5}, w_mean[2] = {2.0, -1.0}, w_var[2] = {0.1, 0.2};
  double back[4] = {0, 0, 0, 0};
  potmap_map* map = NULL;
  int dim = 0;
  size_t count = 0;
  potmap_scan scan;
  potmap_mapper_options mapper_options;
  potmap_dictionary_options dictionary_options;
  potmap_scan_stats stats;

  CHECK(potmap_version(&major, &minor, &patch) == POTMAP_SUCCESS);
  CHECK(major == POTMAP_VERSION_MAJOR && minor == POTMAP_VERSION_MINOR &&
        patch == POTMAP_VERSION_PATCH);
  CHECK(strcmp(potmap_version_string(), POTMAP_VERSION_STRING) == 0);
  CHECK(strcmp(potmap_status_string(POTMAP_ERROR_BUFFER_TOO_SMALL),
               "POTMAP_ERROR_BUFFER_TOO_SMALL") == 0);

  CHECK(potmap_map_create(2, 2, position, gamma, w_mean, w_var, &map) == POTMAP_SUCCESS);
  CHECK(potmap_map_size(map, &dim, &count) == POTMAP_SUCCESS && dim == 2 && count == 2);
  CHECK(potmap_map_read(map, back, 3, NULL, NULL, NULL, 0) == POTMAP_ERROR_BUFFER_TOO_SMALL);
  CHECK(potmap_last_error()[0] != '\0');
  CHECK(potmap_map_read(map, back, 4, NULL, NULL, NULL, 0) == POTMAP_SUCCESS);
  CHECK(potmap_last_error()[0] == '\0');
  CHECK(memcmp(back, position, sizeof back) == 0);
  CHECK(potmap_map_destroy(map) == POTMAP_SUCCESS);
  CHECK(potmap_map_destroy(NULL) == POTMAP_SUCCESS);

  /* The versioned structs, initialised with the caller's sizeof. */
  CHECK(potmap_scan_init(&scan, sizeof scan) == POTMAP_SUCCESS);
  CHECK(scan.struct_size == sizeof scan && scan.dim == 2 && scan.hits == NULL);
  CHECK(potmap_mapper_options_init(&mapper_options, sizeof mapper_options) == POTMAP_SUCCESS);
  CHECK(mapper_options.rotations == 8 && mapper_options.refine == 0 && mapper_options.seed == 0);
  CHECK(potmap_dictionary_options_init(&dictionary_options, sizeof dictionary_options) ==
        POTMAP_SUCCESS);
  CHECK(dictionary_options.sectors == 5);
  stats.struct_size = sizeof stats;
  CHECK(potmap_mapper_add_scan(NULL, &scan, &stats) == POTMAP_ERROR_NULL_ARGUMENT);
  CHECK(potmap_mapper_save_state(NULL, "x.state") == POTMAP_ERROR_NULL_ARGUMENT);
  CHECK(potmap_mapper_load_state(NULL, "x.state") == POTMAP_ERROR_NULL_ARGUMENT);
  CHECK(potmap_mapper_destroy(NULL) == POTMAP_SUCCESS);
  CHECK(potmap_dictionary_destroy(NULL) == POTMAP_SUCCESS);
  CHECK(potmap_dataset_destroy(NULL) == POTMAP_SUCCESS);
  return 0;
}
