// Devices and contexts (include/potmap/runtime/context.hpp).

#include <pybind11/stl.h>

#include "bindings.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

void bind_runtime(py::module_& m) {
  py::class_<DeviceInfo>(m, "DeviceInfo", "Names and limits of one OpenCL device.")
      .def_readonly("platform", &DeviceInfo::platform, "platform name")
      .def_readonly("platform_version", &DeviceInfo::platform_version)
      .def_readonly("name", &DeviceInfo::name, "device name")
      .def_readonly("driver_version", &DeviceInfo::driver_version)
      .def_readonly("is_gpu", &DeviceInfo::is_gpu)
      .def_readonly("is_cpu", &DeviceInfo::is_cpu)
      .def_readonly("has_fp64", &DeviceInfo::has_fp64, "whether the device has cl_khr_fp64")
      .def_readonly("compute_units", &DeviceInfo::compute_units)
      .def_readonly("max_work_group_size", &DeviceInfo::max_work_group_size)
      .def_readonly("global_mem_bytes", &DeviceInfo::global_mem_bytes, "bytes")
      .def_readonly("max_alloc_bytes", &DeviceInfo::max_alloc_bytes, "bytes")
      .def("summary", &DeviceInfo::summary, "'device name (platform, driver x)'")
      .def("__repr__",
           [](const DeviceInfo& d) { return "<potmap.DeviceInfo " + d.summary() + ">"; });

  m.def("devices", &list_devices, "Every OpenCL device of every platform, in platform order.");
  m.def("pin_pocl_workers", &pin_pocl_workers,
        "Asks PoCL's CPU device to keep each worker thread on a core of its own\n"
        "(POCL_AFFINITY=1 in this process's environment, as the C library sees it) unless it\n"
        "names a value already (POCL_AFFINITY=0 turns it off). PoCL reads it once, at the first\n"
        "OpenCL call of the process: call it before the first Context. Returns True when it\n"
        "set it. One scan at a time on a virtual machine's CPU, pinned workers rank and\n"
        "transport about a quarter faster (docs/performance.md, PoCL's workers pinned).");

  py::class_<Context>(m, "Context",
                      "One OpenCL device, its in-order queue and a cache of built programs.\n\n"
                      "Every object built on a Context (Evaluator, Mapper) keeps it alive. Device\n"
                      "work releases the GIL; a Context may be shared by threads (its queue\n"
                      "serialises their device work).")
      .def(py::init([](const std::string& device, const std::string& cache_dir, bool disk_cache,
                       const std::string& build_options, bool dump_kernels, bool host_helper) {
             ContextOptions o;
             o.device = device;
             o.binary_cache_dir = cache_dir;
             o.disk_cache = disk_cache;
             o.build_options = build_options;
             o.dump_kernels = dump_kernels;
             o.host_helper = host_helper;
             py::gil_scoped_release release;
             return std::make_unique<Context>(o);
           }),
           "device"_a = "", "cache_dir"_a = "", "disk_cache"_a = true, "build_options"_a = "",
           "dump_kernels"_a = false, "host_helper"_a = true,
           "Picks a device and sets it up.\n\n"
           "device: case-insensitive substring of the platform's name or vendor or the\n"
           "    device's name ('pocl', 'nvidia', 'cpu'); default '': $POTMAP_DEVICE, else the\n"
           "    first GPU, else the first CPU, else any device. potmap.Error if none matches.\n"
           "cache_dir: folder for compiled program binaries; default '': $POTMAP_CACHE_DIR,\n"
           "    else none (an unwritable folder is ignored with one warning).\n"
           "disk_cache: False turns the binary cache off whatever cache_dir says (default True).\n"
           "build_options: appended to every kernel build, e.g. '-cl-fast-relaxed-math'.\n"
           "dump_kernels: print each kernel's source to stderr when built (default False).\n"
           "host_helper: a second host thread for a scan's per-sector host work (default True;\n"
           "    it sleeps when there is none; the maps are the same either way).")
      .def_property_readonly("device", &Context::info, "The DeviceInfo of the chosen device.")
      .def_property_readonly("builds_from_source", &Context::builds_from_source,
                             "programs compiled from source so far (not from a cache)")
      .def_property_readonly("disk_cache_hits", &Context::disk_cache_hits)
      .def("__repr__",
           [](const Context& c) { return "<potmap.Context " + c.info().summary() + ">"; });
}

}  // namespace potmap::python
