/* What the C examples share: error handling that prints and jumps to `cleanup`, and the host's
 * choice of OpenCL device. */
#ifndef POTMAP_EMBED_UTIL_H
#define POTMAP_EMBED_UTIL_H

#include <stdio.h>

#include <CL/cl.h>
#include <potmap/potmap.h>

/* On a potmap failure: print the status name and the full message, then go to cleanup. */
#define POTMAP_TRY(call)                                                         \
  do {                                                                           \
    potmap_status st_ = (call);                                                  \
    if (st_ != POTMAP_SUCCESS) {                                                 \
      fprintf(stderr, "%s failed: %s\n  %s\n", #call, potmap_status_string(st_), \
              potmap_last_error());                                              \
      goto cleanup;                                                              \
    }                                                                            \
  } while (0)

#define CL_TRY(call)                                                \
  do {                                                              \
    cl_int err_ = (call);                                           \
    if (err_ != CL_SUCCESS) {                                       \
      fprintf(stderr, "%s failed: OpenCL error %d\n", #call, err_); \
      goto cleanup;                                                 \
    }                                                               \
  } while (0)

/* The host's device: the first GPU, else the first device of any kind. */
static cl_device_id pick_device(void) {
  cl_platform_id platforms[16];
  cl_uint np = 0, p;
  cl_device_id dev = NULL;
  if (clGetPlatformIDs(16, platforms, &np) != CL_SUCCESS) return NULL;
  if (np > 16) np = 16;
  for (p = 0; p < np && !dev; ++p)
    if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_GPU, 1, &dev, NULL) != CL_SUCCESS) dev = NULL;
  for (p = 0; p < np && !dev; ++p)
    if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 1, &dev, NULL) != CL_SUCCESS) dev = NULL;
  return dev;
}

/* The host's own OpenCL objects: a context and a queue on pick_device()'s device. Returns 0,
 * having printed why, when there is no device or a call fails; what was made is left in
 * *cl_ctx and *queue for the caller to release. */
static int open_host_queue(cl_device_id* device, cl_context* cl_ctx, cl_command_queue* queue) {
  cl_int err = CL_SUCCESS;
  *device = pick_device();
  if (!*device) {
    fprintf(stderr, "no OpenCL device\n");
    return 0;
  }
  *cl_ctx = clCreateContext(NULL, 1, device, NULL, NULL, &err);
  if (err == CL_SUCCESS) *queue = clCreateCommandQueue(*cl_ctx, *device, 0, &err);
  if (err != CL_SUCCESS) {
    fprintf(stderr, "creating the OpenCL context and queue failed: OpenCL error %d\n", err);
    return 0;
  }
  return 1;
}

#endif /* POTMAP_EMBED_UTIL_H */
