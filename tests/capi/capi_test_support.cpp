#include "capi_test_support.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "data/sim_rng.hpp"  // header-only: the project's seeded generator

namespace fs = std::filesystem;

namespace capi_test {

potmap_context* shared_context() {
  static potmap_context* ctx = [] {
    potmap_context* c = nullptr;
    EXPECT_EQ(potmap_context_create(nullptr, &c), POTMAP_SUCCESS) << potmap_last_error();
    return c;
  }();
  return ctx;
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

std::string shared_data(const std::string& rel) {
  return (fs::path(POTMAP_SOURCE_DIR) / ".." / "shared" / "data" / rel).lexically_normal().string();
}

std::string temp_dir(const std::string& name) {
  fs::path p = fs::path(POTMAP_BINARY_DIR) / "test-tmp" /
               ("capi-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

Arrays random_map(int dim, std::size_t count, std::uint64_t seed, double extent) {
  potmap::data::SimRng rng{seed};
  Arrays a;
  a.dim = dim;
  for (std::size_t i = 0; i < count; ++i) {
    for (int d = 0; d < dim; ++d) a.position.push_back(rng.range(0, extent));
    a.gamma.push_back(rng.range(0.3, 3.0));
    a.w_mean.push_back(rng.range(-3.0, 3.0));
    a.w_var.push_back(rng.range(0.01, 2.0));
  }
  return a;
}

std::vector<double> random_points(int dim, std::size_t n, std::uint64_t seed, double extent) {
  potmap::data::SimRng rng{seed};
  std::vector<double> p(n * dim);
  for (double& v : p) v = rng.range(-2.0, extent + 2.0);
  return p;
}

Values reference(const Arrays& m, const std::vector<double>& points) {
  const std::size_t n = points.size() / m.dim;
  Values v;
  for (std::size_t i = 0; i < n; ++i) {
    double mu = m.has_bias ? m.bias_mean : 0.0, s2 = m.has_bias ? m.bias_var : 0.0;
    for (std::size_t k = 0; k < m.size(); ++k) {
      double d2 = 0;
      for (int d = 0; d < m.dim; ++d) {
        const double diff = points[i * m.dim + d] - m.position[k * m.dim + d];
        d2 += diff * diff;
      }
      const double phi = std::exp(-m.gamma[k] * d2);
      mu += m.w_mean[k] * phi;
      s2 += m.w_var[k] * phi * phi;
    }
    v.mean.push_back(mu);
    v.var.push_back(s2);
    v.prob.push_back(1.0 / (1.0 + std::exp(-mu / std::sqrt(1.0 + M_PI * s2 / 8.0))));
  }
  return v;
}

potmap_map* make_map(const Arrays& a) {
  potmap_map* map = nullptr;
  const potmap_status st = potmap_map_create(a.dim, a.size(), a.position.data(), a.gamma.data(),
                                             a.w_mean.data(), a.w_var.data(), &map);
  EXPECT_EQ(st, POTMAP_SUCCESS) << potmap_last_error();
  if (map && a.has_bias) potmap_map_set_bias(map, 1, a.bias_mean, a.bias_var);
  return map;
}

HostCl::HostCl() {
  // The device potmap would pick, found through potmap; everything else is plain OpenCL.
  potmap_context* probe = nullptr;
  if (potmap_context_create(nullptr, &probe) != POTMAP_SUCCESS) {
    ADD_FAILURE() << "no device: " << potmap_last_error();
    return;
  }
  potmap_context_cl(probe, nullptr, &device, nullptr);
  cl_int err = clGetDeviceInfo(device, CL_DEVICE_PLATFORM, sizeof platform, &platform, nullptr);
  EXPECT_EQ(err, CL_SUCCESS);
  context = clCreateContext(nullptr, 1, &device, nullptr, nullptr, &err);
  EXPECT_EQ(err, CL_SUCCESS);
  queue = clCreateCommandQueue(context, device, 0, &err);
  EXPECT_EQ(err, CL_SUCCESS);
  potmap_context_destroy(probe);  // the device id stays valid: root devices are not counted
}

HostCl::~HostCl() {
  if (queue) clReleaseCommandQueue(queue);
  if (context) clReleaseContext(context);
}

cl_mem HostCl::buffer(std::size_t bytes, const void* data) const {
  cl_int err = CL_SUCCESS;
  cl_mem m = clCreateBuffer(context, CL_MEM_READ_WRITE | (data ? CL_MEM_COPY_HOST_PTR : 0), bytes,
                            const_cast<void*>(data), &err);
  EXPECT_EQ(err, CL_SUCCESS);
  return m;
}

std::vector<float> HostCl::read(cl_mem m, std::size_t count) const {
  std::vector<float> out(count);
  EXPECT_EQ(clEnqueueReadBuffer(queue, m, CL_TRUE, 0, count * sizeof(float), out.data(), 0, nullptr,
                                nullptr),
            CL_SUCCESS);
  return out;
}

cl_uint reference_count(cl_context c) {
  cl_uint r = 0;
  clGetContextInfo(c, CL_CONTEXT_REFERENCE_COUNT, sizeof r, &r, nullptr);
  return r;
}
cl_uint reference_count(cl_command_queue q) {
  cl_uint r = 0;
  clGetCommandQueueInfo(q, CL_QUEUE_REFERENCE_COUNT, sizeof r, &r, nullptr);
  return r;
}
cl_uint reference_count(cl_mem m) {
  cl_uint r = 0;
  clGetMemObjectInfo(m, CL_MEM_REFERENCE_COUNT, sizeof r, &r, nullptr);
  return r;
}
cl_uint reference_count(cl_event e) {
  cl_uint r = 0;
  clGetEventInfo(e, CL_EVENT_REFERENCE_COUNT, sizeof r, &r, nullptr);
  return r;
}

namespace {

// Distance from (x, y) along (dx, dy) to the nearest wall or pillar face; infinity if none.
double cast(double x, double y, double dx, double dy) {
  struct Box {
    double x0, y0, x1, y1;
  };
  const Box boxes[2] = {{0, 0, 12, 9}, {7, 3, 8, 6}};
  double best = INFINITY;
  for (const Box& b : boxes) {
    const double xs[2] = {b.x0, b.x1}, ys[2] = {b.y0, b.y1};
    for (double wx : xs)
      if (dx != 0) {
        const double t = (wx - x) / dx, yy = y + t * dy;
        if (t > 1e-9 && yy >= b.y0 && yy <= b.y1) best = std::min(best, t);
      }
    for (double wy : ys)
      if (dy != 0) {
        const double t = (wy - y) / dy, xx = x + t * dx;
        if (t > 1e-9 && xx >= b.x0 && xx <= b.x1) best = std::min(best, t);
      }
  }
  return best;
}

}  // namespace

potmap_scan RoomScan::scan() const {
  potmap_scan s;
  potmap_scan_init(&s, sizeof s);
  s.dim = 2;
  s.pose[0] = x;
  s.pose[1] = y;
  s.pose[2] = yaw;
  s.max_range = max_range;
  s.timestamp = timestamp;
  s.hits = hits.data();
  s.num_hits = hits.size() / 2;
  s.no_return = no_return.data();
  s.num_no_return = no_return.size() / 2;
  return s;
}

RoomScan room_scan(double x, double y, double yaw, int beams, double max_range) {
  RoomScan r;
  r.x = x;
  r.y = y;
  r.yaw = yaw;
  r.max_range = max_range;
  for (int b = 0; b < beams; ++b) {
    const double a = yaw + 2 * 3.14159265358979323846 * b / beams, dx = std::cos(a),
                 dy = std::sin(a);
    const double t = cast(x, y, dx, dy);
    if (t < max_range) {
      r.hits.push_back(x + t * dx);
      r.hits.push_back(y + t * dy);
    } else {
      r.no_return.push_back(dx);
      r.no_return.push_back(dy);
    }
  }
  return r;
}

std::vector<RoomScan> room_path(std::size_t n) {
  std::vector<RoomScan> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = n > 1 ? double(i) / double(n - 1) : 0.0;
    const bool lower = i % 2 == 0;
    out.push_back(room_scan(2 + 8 * t, lower ? 2 + 0.3 * t : 7 - 0.4 * t, 0.4 * double(i)));
  }
  return out;
}

ScanList::ScanList(const std::vector<RoomScan>& room) {
  for (const RoomScan& r : room) scans.push_back(r.scan());
  for (const potmap_scan& s : scans) ptrs.push_back(&s);
}

}  // namespace capi_test
