#include "potmap/runtime/context.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <thread>

#include "potmap/runtime/tuning_file.hpp"
#include "runtime/binary_cache.hpp"
#include "runtime/cl_check.hpp"
#include "runtime/hash.hpp"
#include "runtime/host_team.hpp"
#include "runtime/quiet_stderr.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace detail {
const std::map<std::string, std::string_view>& embedded_kernels();
}

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return (v && *v) ? std::string(v) : fallback;
}

DeviceInfo describe(const bc::device& d) {
  DeviceInfo info;
  bc::platform p = d.platform();
  info.platform = p.name();
  info.platform_version = p.version();
  info.name = d.name();
  info.driver_version = d.driver_version();
  info.is_gpu = (d.type() & CL_DEVICE_TYPE_GPU) != 0;
  info.is_cpu = (d.type() & CL_DEVICE_TYPE_CPU) != 0;
  info.has_fp64 = d.supports_extension("cl_khr_fp64");
  info.has_int64_atomics = d.supports_extension("cl_khr_int64_base_atomics");
  info.compute_units = d.compute_units();
  info.max_work_group_size = d.max_work_group_size();
  info.global_mem_bytes = d.global_memory_size();
  info.max_alloc_bytes = d.get_info<cl_ulong>(CL_DEVICE_MAX_MEM_ALLOC_SIZE);
  info.platform_vendor = p.vendor();
  return info;
}

std::vector<bc::device> all_devices() {
  std::vector<bc::device> out;
  cl_uint n = 0;
  cl_int status = clGetPlatformIDs(0, nullptr, &n);
  if (status == -1001 /* CL_PLATFORM_NOT_FOUND_KHR */ || n == 0) return out;
  detail::cl_check(status, "clGetPlatformIDs");
  std::vector<cl_platform_id> ids(n);
  detail::cl_check(clGetPlatformIDs(n, ids.data(), nullptr), "clGetPlatformIDs");
  for (cl_platform_id id : ids) {
    bc::platform p(id);
    for (const bc::device& d : detail::cl_call("clGetDeviceIDs", [&] { return p.devices(); }))
      out.push_back(d);
  }
  return out;
}

bc::device pick_device(const std::string& wanted) {
  const std::vector<bc::device> devices = all_devices();
  if (devices.empty())
    throw Error(
        "no OpenCL device found: install an OpenCL driver (on Debian: pocl-opencl-icd for the "
        "CPU) and check that /etc/OpenCL/vendors lists it");
  if (!wanted.empty()) {
    const std::string w = lower(wanted);
    for (const bc::device& d : devices) {
      const std::string hay =
          lower(d.platform().name() + " " + d.platform().vendor() + " " + d.name());
      if (hay.find(w) != std::string::npos) return d;
    }
    std::ostringstream msg;
    msg << "no OpenCL device matches '" << wanted << "' (POTMAP_DEVICE or --device); devices:";
    for (const bc::device& d : devices) msg << "\n  " << describe(d).summary();
    throw Error(msg.str());
  }
  for (const bc::device& d : devices)
    if (d.type() & CL_DEVICE_TYPE_GPU) return d;
  for (const bc::device& d : devices)
    if (d.type() & CL_DEVICE_TYPE_CPU) return d;
  return devices.front();
}

// The device's tuning file (if present and measured here) over the built-in defaults, then
// POTMAP_TUNING, then the option: the closer to the call, the later it applies.
Tuning initial_tuning(const DeviceInfo& info, const ContextOptions& o, std::string& source) {
  Tuning base = default_tuning(info);
  source = "built-in defaults";
  if (o.tuning_file) {
    const std::string dir = o.tuning_dir.empty() ? default_tuning_dir() : o.tuning_dir;
    if (!dir.empty()) {
      const std::string path = tuning_file_path(dir, info);
      TuningFileRead file = read_tuning_file(path, info, base);
      if (!file.problem.empty())
        std::cerr << "potmap: warning: tuning file '" << path << "' ignored: " << file.problem
                  << "\n";
      if (file.tuning) {
        base = *file.tuning;
        source = path;
      }
    }
  }
  return parse_tuning(o.tuning, parse_tuning(env_or("POTMAP_TUNING", ""), base));
}

}  // namespace

std::string DeviceInfo::summary() const {
  return name + " (" + platform + ", driver " + driver_version + ")";
}

bool pin_pocl_workers() {
  const char* v = std::getenv("POCL_AFFINITY");
  if (v && *v) return false;
  // Overwrites only an empty value (the check above keeps any other).
  return setenv("POCL_AFFINITY", "1", 1) == 0;
}

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  for (const bc::device& d : all_devices()) out.push_back(describe(d));
  return out;
}

std::vector<std::string> embedded_kernel_names() {
  std::vector<std::string> names;
  for (const auto& [name, src] : detail::embedded_kernels()) names.push_back(name);
  return names;
}

std::string embedded_kernel_source(const std::string& name) {
  const auto& table = detail::embedded_kernels();
  auto it = table.find(name);
  if (it == table.end()) throw ArgumentError("no embedded kernel source named '" + name + "'");
  return std::string(it->second);
}

// Kernels lent and given back (KernelLease), by file + '\0' + name + '\0' + defines. Its own
// lock: a lease given back never waits for a program build.
struct KernelPool {
  std::mutex mutex;
  std::map<std::string, std::vector<bc::kernel>> idle;
};

struct Context::Impl {
  bc::device device;
  bc::context context;
  bc::command_queue queue;
  DeviceInfo info;
  std::string tuning_source;
  Tuning tuning;
  std::string build_options;
  bool dump = false;
  detail::BinaryCache disk;
  std::mutex mutex;
  std::map<std::string, bc::program> programs;  // key: options + '\0' + source hash
  KernelPool kernels;
  std::size_t source_builds = 0;
  std::size_t disk_hits = 0;
  bool host_helper = true;
  std::once_flag team_once;
  std::unique_ptr<detail::HostTeam> team;  // made on first use

  Impl(bc::device d, bc::context c, bc::command_queue q, const ContextOptions& o)
      : device(std::move(d)),
        context(std::move(c)),
        queue(std::move(q)),
        info(describe(device)),
        tuning(initial_tuning(info, o, tuning_source)),
        build_options(o.build_options),
        dump(o.dump_kernels || env_or("POTMAP_DUMP_KERNELS", "0") == "1"),
        disk(!o.disk_cache                ? std::string()
             : o.binary_cache_dir.empty() ? env_or("POTMAP_CACHE_DIR", "")
                                          : o.binary_cache_dir),
        host_helper(o.host_helper) {}

  bc::program build(const std::string& label, const std::string& source,
                    const std::string& defines) {
    const std::string options = defines + (build_options.empty() ? "" : " " + build_options);
    const std::string mem_key =
        options + '\0' + std::to_string(detail::fnv1a64(source)) + '\0' + label;
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = programs.find(mem_key); it != programs.end()) return it->second;

    // Dumped whether the binary then comes from the disk cache or the compiler: what matters
    // to the reader is the source the device runs.
    if (dump)
      std::cerr << "---- potmap: building kernel '" << label << "' with '" << options << "' ----\n"
                << source << "\n---- end of '" << label << "' ----\n";
    // The disk key names everything that can change the binary: a driver update must miss.
    const std::string disk_key = info.platform + '\n' + info.platform_version + '\n' + info.name +
                                 '\n' + info.driver_version + '\n' + options + '\n' + source;
    if (auto bin = disk.load(disk_key)) {
      try {
        bc::program p = bc::program::create_with_binary(*bin, context);
        p.build(options);
        ++disk_hits;
        programs.emplace(mem_key, p);
        return p;
      } catch (const bc::opencl_error& e) {
        // A binary the driver no longer takes (or one damaged in a way the checksum cannot
        // see): warn, drop it and build from source below, which stores a fresh one.
        disk.reject(disk_key, opencl_error_name(e.error_code()));
      }
    }
    bc::program p = detail::cl_call("clCreateProgramWithSource", [&] {
      return bc::program::create_with_source(source, context);
    });
    try {
      if (dump) {
        p.build(options);
      } else {
        detail::QuietStderr quiet;
        try {
          p.build(options);
        } catch (...) {
          std::string log;
          try {
            log = p.build_log();
          } catch (...) {
          }
          std::cerr << detail::not_from_compiler(quiet.release(), log);
          throw;
        }
        std::string log;
        try {
          log = p.build_log();
        } catch (const bc::opencl_error&) {
        }
        std::cerr << detail::not_from_compiler(quiet.release(), log);
      }
    } catch (const bc::opencl_error& e) {
      std::string log;
      try {
        log = p.build_log();
      } catch (...) {
        log = "(build log unavailable)";
      }
      throw BuildError(e.error_code(), label, options, log);
    }
    ++source_builds;
    if (dump) {
      std::string log;
      try {
        log = p.build_log();
      } catch (const bc::opencl_error&) {
      }
      if (log.find_first_not_of(" \t\r\n") != std::string::npos)
        std::cerr << "---- potmap: build log of '" << label << "' ----\n"
                  << log << "\n---- end of the build log of '" << label << "' ----\n";
    }
    if (disk.enabled()) {
      try {
        disk.store(disk_key, p.binary());
      } catch (const bc::opencl_error&) {
        // A device that cannot return binaries simply gets no disk cache.
      }
    }
    programs.emplace(mem_key, p);
    return p;
  }
};

Context::Context(const ContextOptions& options) {
  bc::device d = pick_device(options.device.empty() ? env_or("POTMAP_DEVICE", "") : options.device);
  bc::context c = detail::cl_call("clCreateContext", [&] { return bc::context(d); });
  bc::command_queue q =
      detail::cl_call("clCreateCommandQueue", [&] { return bc::command_queue(c, d); });
  impl_ = std::make_unique<Impl>(d, c, q, options);
}

Context::Context(cl_command_queue queue, const ContextOptions& options) {
  if (!queue) throw ArgumentError("Context: the host's cl_command_queue is null");
  bc::command_queue q(queue, /*retain=*/true);
  bc::device d = detail::cl_call("clGetCommandQueueInfo", [&] { return q.get_device(); });
  bc::context c = detail::cl_call("clGetCommandQueueInfo", [&] { return q.get_context(); });
  impl_ = std::make_unique<Impl>(d, c, q, options);
}

Context::Context(cl_context context, cl_device_id device, const ContextOptions& options) {
  if (!context) throw ArgumentError("Context: the host's cl_context is null");
  if (!device) throw ArgumentError("Context: the host's cl_device_id is null");
  bc::context c(context, /*retain=*/true);
  const std::vector<bc::device> members =
      detail::cl_call("clGetContextInfo", [&] { return c.get_devices(); });
  auto it = std::find_if(members.begin(), members.end(),
                         [&](const bc::device& m) { return m.get() == device; });
  if (it == members.end())
    throw ArgumentError("Context: the cl_device_id is not a device of the cl_context");
  const bc::device& d = *it;
  bc::command_queue q =
      detail::cl_call("clCreateCommandQueue", [&] { return bc::command_queue(c, d); });
  impl_ = std::make_unique<Impl>(d, c, q, options);
}

Context::Context(Context&&) noexcept = default;
Context& Context::operator=(Context&&) noexcept = default;
Context::~Context() = default;

const DeviceInfo& Context::info() const {
  return impl_->info;
}
const Tuning& Context::tuning() const {
  return impl_->tuning;
}
void Context::set_tuning(const Tuning& tuning) {
  validate_tuning(tuning);
  impl_->tuning = tuning;
}
const std::string& Context::tuning_source() const {
  return impl_->tuning_source;
}
bc::device& Context::device() {
  return impl_->device;
}
bc::context& Context::context() {
  return impl_->context;
}
bc::command_queue& Context::queue() {
  return impl_->queue;
}

bc::program Context::program_from_source(const std::string& label, const std::string& source,
                                         const std::string& defines) {
  return impl_->build(label, source, defines);
}

bc::program Context::program(const std::string& file, const std::string& defines) {
  const auto& table = detail::embedded_kernels();
  auto it = table.find(file);
  if (it == table.end()) throw ArgumentError("no embedded kernel source named '" + file + "'");
  return impl_->build(file, std::string(it->second), defines);
}

bc::kernel Context::kernel(const std::string& file, const std::string& kernel_name,
                           const std::string& defines) {
  bc::program p = program(file, defines);
  return detail::cl_call(("clCreateKernel(" + kernel_name + ")").c_str(),
                         [&] { return bc::kernel(p, kernel_name); });
}

KernelLease Context::lend_kernel(const std::string& file, const std::string& kernel_name,
                                 const std::string& defines) {
  std::string key = file + '\0' + kernel_name + '\0' + defines;
  KernelPool& pool = impl_->kernels;
  {
    std::lock_guard<std::mutex> lock(pool.mutex);
    auto it = pool.idle.find(key);
    if (it != pool.idle.end() && !it->second.empty()) {
      bc::kernel k = std::move(it->second.back());
      it->second.pop_back();
      return KernelLease(&pool, std::move(key), std::move(k));
    }
  }
  bc::kernel k = kernel(file, kernel_name, defines);
  return KernelLease(&pool, std::move(key), std::move(k));
}

KernelLease::KernelLease(KernelPool* pool, std::string key, bc::kernel k)
    : pool_(pool), key_(std::move(key)), kernel_(std::move(k)) {}

KernelLease::KernelLease(KernelLease&& other) noexcept
    : pool_(other.pool_), key_(std::move(other.key_)), kernel_(std::move(other.kernel_)) {
  other.pool_ = nullptr;
}

KernelLease::~KernelLease() {
  if (!pool_) return;
  try {
    std::lock_guard<std::mutex> lock(pool_->mutex);
    pool_->idle[std::move(key_)].push_back(std::move(kernel_));
  } catch (...) {
    // Out of memory while keeping it: the kernel is released instead, nothing is lost.
  }
}

namespace {

// The context's host team, made on first use.
detail::HostTeam& host_team(std::once_flag& once, std::unique_ptr<detail::HostTeam>& team,
                            bool helper) {
  std::call_once(once, [&] {
    team = std::make_unique<detail::HostTeam>(helper && std::thread::hardware_concurrency() > 1);
  });
  return *team;
}

}  // namespace

void Context::host_parallel_for(std::size_t n, const std::function<void(std::size_t)>& fn) {
  host_team(impl_->team_once, impl_->team, impl_->host_helper).run(n, fn);
}

void Context::hold_host_helper(bool hold) {
  host_team(impl_->team_once, impl_->team, impl_->host_helper).hold(hold);
}

std::size_t Context::builds_from_source() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->source_builds;
}
std::size_t Context::disk_cache_hits() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->disk_hits;
}

}  // namespace potmap
