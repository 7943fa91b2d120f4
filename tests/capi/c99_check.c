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
  return 0;
}
