#pragma once
// The device runtime: one OpenCL device, its in-order queue and a cache of built programs.
//
// Thread safety: a Context may be shared between threads: kernel(), program() and the info
// getters may be called concurrently (the program cache is locked), and objects built on it
// (MapEvaluator, ...) may run on different threads at once. Its queue is in-order and shared,
// so their device work is serialised; give each thread its own Context (or a Context on its own
// queue) for device work that overlaps. Moving or destroying a Context while another thread
// uses it, or while objects built on it still exist, is not allowed.

#include <boost/compute/command_queue.hpp>
#include <boost/compute/context.hpp>
#include <boost/compute/device.hpp>
#include <boost/compute/kernel.hpp>
#include <boost/compute/program.hpp>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/runtime/tuning.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// How to pick and set up the device.
struct ContextOptions {
  /// Case-insensitive substring of the platform's name or vendor or the device's name ("pocl",
  /// "nvidia", "cpu").
  /// Empty: the POTMAP_DEVICE environment variable if set, else the first GPU, else the first
  /// CPU device, else any device.
  std::string device;
  /// Folder for compiled program binaries, keyed by platform, device, driver version, source and
  /// options. Empty: the POTMAP_CACHE_DIR environment variable if set, else no disk cache.
  /// A folder that cannot be created or written is ignored (a warning goes to stderr once).
  std::string binary_cache_dir;
  /// false: no disk cache at all, whatever binary_cache_dir and POTMAP_CACHE_DIR say.
  bool disk_cache = true;
  /// Extra options appended to every program build (e.g. "-cl-fast-relaxed-math"). Default none.
  std::string build_options;
  /// Print each kernel's source to stderr when it is built, and the compiler's log (warnings)
  /// of each successful build from source. Also set by POTMAP_DUMP_KERNELS=1. Off by default:
  /// warnings in potmap's own kernels are for its developers, not for the user's terminal (a
  /// failed build's log is always in the BuildError).
  bool dump_kernels = false;
  /// Overrides of the device's tuning (potmap/runtime/tuning.hpp: vector widths, work-group
  /// and chunk sizes), as `routine.field=value` pairs, e.g. "sinkhorn.work_group=8". Applied
  /// after the POTMAP_TUNING environment variable, which has the same form. Default none: the
  /// device's defaults (default_tuning). A bad pair throws ArgumentError naming it.
  std::string tuning;
  /// Folder of the per-device tuning files `potmap tune` writes (potmap/runtime/tuning_file.hpp).
  /// Empty: default_tuning_dir() (POTMAP_CACHE_DIR, else $XDG_CACHE_HOME/potmap, else
  /// ~/.cache/potmap). The device's file, when present and measured on this device, driver and
  /// potmap version, replaces default_tuning(); a stale or corrupt one is ignored with a warning
  /// on stderr naming the file and what is wrong. POTMAP_TUNING and `tuning` apply after it.
  std::string tuning_dir;
  /// false: read no tuning file (the built-in defaults, then the overrides). Default true.
  bool tuning_file = true;
  /// A second host thread for host work that splits into independent items (POT's per-sector
  /// preparation and placement, host_parallel_for()). Default true: with the device idle
  /// between launches, one scan's host stages otherwise leave a core idle. Ignored on a
  /// single-core machine. The thread starts on first use and sleeps when there is no work.
  bool host_helper = true;
};

/// Names of one OpenCL device as potmap sees it.
struct DeviceInfo {
  std::string platform;  ///< platform name, e.g. "Portable Computing Language"
  std::string platform_version;
  std::string name;  ///< device name
  std::string driver_version;
  bool is_gpu = false;
  bool is_cpu = false;
  bool has_fp64 = false;
  /// 64-bit integer atomics on global memory (cl_khr_int64_base_atomics): the keyframe
  /// gathering's table (data/keyframe_samples.hpp) needs them.
  bool has_int64_atomics = false;
  std::size_t compute_units = 0;
  std::size_t max_work_group_size = 0;
  std::size_t global_mem_bytes = 0;
  std::size_t max_alloc_bytes = 0;
  /// Platform vendor, e.g. "The pocl project" or "NVIDIA Corporation": a device is picked by
  /// it too (Debian's PoCL platform is named "Portable Computing Language").
  std::string platform_vendor;
  std::string summary() const;  ///< "device name (platform, driver x)" for logs and benchmarks
};

/// Every device of every platform, in platform order.
std::vector<DeviceInfo> list_devices();

/// Asks PoCL's CPU device to keep each of its worker threads on a core of its own
/// (POCL_AFFINITY=1 in this process's environment) unless the environment already names a
/// value, which is kept (POCL_AFFINITY=0 turns it off). PoCL reads it once, when the first
/// OpenCL call of the process loads it, so call this at the start of main(), before any
/// Context, and before any other thread runs (it calls setenv). Returns true when it set it.
///
/// Why: a launch wakes PoCL's workers, and a kernel scheduler that believes an idle core is
/// busy (a virtual machine's idle vCPU is reported as preempted) wakes them on the launching
/// core, where two workers share one core until the load balancer moves one. Pinned, each runs
/// on its own core at once. A launch of milliseconds after an idle gap pays this most: one
/// POT scan at a time ranked in 2.9 instead of 3.9 ms (docs/pot-scale.md). The
/// `potmap` command and the latency benchmarks call it; an embedder decides for its process.
bool pin_pocl_workers();

/// The idle kernels of a Context (opaque; see KernelLease).
struct KernelPool;

/// A kernel lent by a Context for one launch: set every argument, enqueue, then let the lease
/// go and the kernel returns to the context's idle kernels (an enqueued launch keeps its own
/// copy of the arguments, so the next borrower may set new ones at once). Routines that launch
/// every scan borrow instead of calling Context::kernel, which makes a new cl_kernel (and looks
/// the program up by its source) each time: about 0.3 ms a launch on PoCL's CPU device.
class KernelLease {
 public:
  KernelLease(KernelLease&& other) noexcept;
  KernelLease& operator=(KernelLease&&) = delete;
  KernelLease(const KernelLease&) = delete;
  KernelLease& operator=(const KernelLease&) = delete;
  ~KernelLease();
  boost::compute::kernel& operator*() { return kernel_; }
  boost::compute::kernel* operator->() { return &kernel_; }

 private:
  friend class Context;
  KernelLease(KernelPool* pool, std::string key, boost::compute::kernel k);
  KernelPool* pool_;
  std::string key_;
  boost::compute::kernel kernel_;
};

/// Owns the device, queue and the program cache. Movable, not copyable.
class Context {
 public:
  /// Picks a device as ContextOptions says. Throws potmap::Error if none matches.
  explicit Context(const ContextOptions& options = {});
  /// Wraps a queue the host application already owns (its context and device are used). The
  /// queue is retained, not copied: work potmap enqueues is ordered with the host's own.
  Context(cl_command_queue queue, const ContextOptions& options = {});
  /// Uses a context the host application already owns, on one of its devices, with a new
  /// in-order queue of potmap's own (the context is retained). `options.device` is ignored.
  /// Throws ArgumentError if either is null or the device is not one of the context's.
  Context(cl_context context, cl_device_id device, const ContextOptions& options = {});

  Context(Context&&) noexcept;
  Context& operator=(Context&&) noexcept;
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context();

  const DeviceInfo& info() const;
  /// The launch choices the routines built on this context read (see tuning.hpp). Objects built
  /// on the context (MapEvaluator, ...) read it when they are constructed.
  const Tuning& tuning() const;
  /// Replaces the tuning (validated first: ArgumentError names a bad field); for tuners. Not
  /// to be called while another thread uses the context.
  void set_tuning(const Tuning& tuning);
  /// Where the tuning came from before the overrides: the path of the tuning file read, or
  /// "built-in defaults". For logs and benchmark records.
  const std::string& tuning_source() const;
  boost::compute::device& device();
  boost::compute::context& context();
  boost::compute::command_queue& queue();

  /// A kernel from the embedded source `file` (kernels/<file>.cl, without extension), built with
  /// `defines` (e.g. "-DDIM=3 -DTILE=64") plus the context's build options. Programs are built
  /// once per (source, options) and cached; each call returns a fresh cl_kernel, so different
  /// threads never share argument state.
  boost::compute::kernel kernel(const std::string& file, const std::string& kernel_name,
                                const std::string& defines = "");
  /// kernel(), lent from the context's idle kernels of that (file, name, defines) when one is
  /// idle (see KernelLease). Thread-safe; the Context may be moved, not destroyed, while a lease
  /// is alive.
  KernelLease lend_kernel(const std::string& file, const std::string& kernel_name,
                          const std::string& defines = "");
  /// The built program of an embedded source (see kernel()).
  boost::compute::program program(const std::string& file, const std::string& defines = "");
  /// Builds arbitrary source text (cached like embedded ones). `label` names it in errors.
  boost::compute::program program_from_source(const std::string& label, const std::string& source,
                                              const std::string& defines = "");

  /// Runs fn(i) for every i in [0, n), each once, on this thread and the context's host helper
  /// (ContextOptions::host_helper), and returns when all are done; items must be independent.
  /// The first exception an item throws is rethrown here, after the other items ran. When
  /// another thread is using the helper, this thread runs every item itself.
  void host_parallel_for(std::size_t n, const std::function<void(std::size_t)>& fn);
  /// hold true: until as many calls with false, the host helper keeps looking for the next
  /// host_parallel_for() run instead of sleeping 50 microseconds after one. For a burst of short
  /// runs with short host work between them (the joint BHM's update: some fifty runs of tens of
  /// microseconds in a few milliseconds), where waking a sleeping thread takes as long as the
  /// run. Release it when the burst ends: a looking helper keeps a core busy.
  void hold_host_helper(bool hold);

  /// Number of programs built from source (not loaded from the memory or disk cache). For tests.
  std::size_t builds_from_source() const;
  /// Number of programs loaded from the disk cache. For tests.
  std::size_t disk_cache_hits() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Names of the embedded kernel sources (kernels/*.cl without extension).
std::vector<std::string> embedded_kernel_names();
/// Source text of an embedded kernel; throws ArgumentError for an unknown name.
std::string embedded_kernel_source(const std::string& name);

}  // namespace potmap
POTMAP_CXX_API_END
