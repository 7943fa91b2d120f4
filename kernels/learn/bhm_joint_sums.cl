// A scan's features and sums for the joint BHM's update (host/learn/bhm_joint_device.cpp runs
// them; JointBhm::update's host loops are the reference). The host makes the tiles a scan
// reaches and gives each sample its span of cells and tile ids; here each sample lists its
// features (kernels within the cut-off, in raster order), and the sums are gathered per row of
// the solve (a kernel the scan reaches) over that row's features in the order of the samples,
// so every sum comes out the same whatever order the work-items run in.
// Doubles throughout, contraction off: the cut-off test decides as the host's does.

#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

// The model's grid, as JointBhm holds it.
typedef struct {
  double lo[3];     // first kernel's position, metres
  double h;         // spacing, metres
  double gamma;     // 1/m^2
  double tau;       // cut-off: gamma d^2 <= tau
  int dim;          // 2 or 3
  int tile;         // cells a tile's edge
  int tile_cells;   // tile^dim
  int box;          // stencil's edge (2 pad + 1)
} JointGrid;

inline long floor_div_l(long a, long b) {
  const long q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

inline double cell_d2(const JointGrid g, const double x[3], int i, int j, int k) {
  const int c[3] = {i, j, k};
  double d2 = 0;
  for (int d = 0; d < g.dim; ++d) {
    const double s = x[d] - (g.lo[d] + (double)c[d] * g.h);
    d2 += s * s;
  }
  return d2;
}

// Runs BODY for each of sample s's features in raster order (z, y, x), with kid its kernel's
// storage index, cell its stencil-linear place in the span's box and d2 its squared distance.
#define FOR_EACH_FEATURE(BODY)                                                              \
  {                                                                                         \
    double x[3] = {0, 0, 0};                                                                \
    for (int d = 0; d < g.dim; ++d) x[d] = pos[(size_t)s * g.dim + d];                      \
    const int a0 = span[6 * s], a1 = span[6 * s + 1], a2 = span[6 * s + 2];                 \
    const int b0 = span[6 * s + 3], b1 = span[6 * s + 4], b2 = span[6 * s + 5];             \
    const long ta0 = floor_div_l(a0, g.tile), ta1 = floor_div_l(a1, g.tile);                \
    const long ta2 = g.dim == 3 ? floor_div_l(a2, g.tile) : 0;                              \
    for (int k = a2; k <= b2; ++k) {                                                        \
      const long tz = g.dim == 3 ? floor_div_l(k, g.tile) : 0;                              \
      for (int j = a1; j <= b1; ++j) {                                                      \
        const long ty = floor_div_l(j, g.tile);                                             \
        for (int i = a0; i <= b0; ++i) {                                                    \
          const double d2 = cell_d2(g, x, i, j, k);                                         \
          if (g.gamma * d2 > g.tau) continue;                                               \
          const long tx = floor_div_l(i, g.tile);                                           \
          const int id = tiles[8 * s + ((tz - ta2) * 2 + (ty - ta1)) * 2 + (tx - ta0)];     \
          const long row = ((k - tz * g.tile) * g.tile + (j - ty * g.tile)) * g.tile;       \
          const uint kid = (uint)((long)id * g.tile_cells + row + (i - tx * g.tile));    \
          const int cell = ((k - a2) * g.box + (j - a1)) * g.box + (i - a0);               \
          BODY                                                                              \
        }                                                                                   \
      }                                                                                     \
    }                                                                                       \
  }

// Features a sample has (span: a then b, 3 ints each; tiles: 8 per sample, span_tiles()).
__kernel void joint_count(const JointGrid g, __global const double* pos,
                          __global const int* span, __global const int* tiles, uint n,
                          __global uint* count) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  uint c = 0;
  FOR_EACH_FEATURE(++c; (void)kid; (void)cell;)
  count[s] = c;
}

// Sample s's features from start[s]: kernel, phi, local cell (its stencil-linear place in the
// span's box: differences of two are the stencil offset between them) and s.
__kernel void joint_features(const JointGrid g, __global const double* pos,
                             __global const int* span, __global const int* tiles, uint n,
                             __global const uint* start, __global uint* fkernel,
                             __global double* fphi, __global int* flocal,
                             __global uint* fsample) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  uint u = start[s];
  FOR_EACH_FEATURE(fkernel[u] = kid; fphi[u] = exp(-g.gamma * d2); flocal[u] = cell;
                   fsample[u] = s; ++u;)
}

// Each feature's place in its row's list: counted, placed (in any order) ...
__kernel void joint_row_count(__global const uint* frow, uint nf, __global uint* rcount) {
  const uint u = get_global_id(0);
  if (u >= nf) return;
  atomic_inc(&rcount[frow[u]]);
}

__kernel void joint_row_place(__global const uint* frow, uint nf, __global const uint* rstart,
                              __global uint* rfill, __global uint* rlist) {
  const uint u = get_global_id(0);
  if (u >= nf) return;
  const uint r = frow[u];
  rlist[rstart[r] + atomic_inc(&rfill[r])] = u;
}

// ... then sorted: a row's features in the order of the samples (few a row: insertion sort).
__kernel void joint_row_sort(__global const uint* rstart, uint nrows, __global uint* rlist) {
  const uint r = get_global_id(0);
  if (r >= nrows) return;
  const uint a = rstart[r], b = rstart[r + 1];
  for (uint p = a + 1; p < b; ++p) {
    const uint v = rlist[p];
    uint q = p;
    while (q > a && rlist[q - 1] > v) {
      rlist[q] = rlist[q - 1];
      --q;
    }
    rlist[q] = v;
  }
}

inline double jj_lambda(double xi) {
  xi = fabs(xi);
  if (xi < 1e-4) return 0.125 - xi * xi / 96.0;
  return (1.0 / (1.0 + exp(-xi)) - 0.5) / (2.0 * xi);
}

// One EM iteration's bound: each sample's xi from the posterior (the rows' means and
// precision diagonals, the bias's mean and variance), its new lambda, and c = 2 w (lambda' -
// lambda), the change of its curvature in the precision; mu = phi . mean for the carried
// residual.
__kernel void joint_bound(__global const uint* start, __global const uint* frow,
                          __global const double* fphi, __global const double* w, uint n,
                          __global const double* row_mean, __global const double* row_diag,
                          const double mean_b, const double var_b, __global double* lambda,
                          __global double* c, __global double* mu) {
  const uint s = get_global_id(0);
  if (s >= n) return;
  double m = mean_b, s2 = var_b;
  for (uint u = start[s]; u < start[s + 1]; ++u) {
    const double phi = fphi[u];
    const uint r = frow[u];
    m += row_mean[r] * phi;
    s2 += phi * phi / row_diag[r];
  }
  const double next = jj_lambda(sqrt(m * m + s2));
  c[s] = 2.0 * w[s] * (next - lambda[s]);
  lambda[s] = next;
  mu[s] = m;
}

// Row r's sums over its features u (sample s): the precision's half stencil gains
// c_s phi_u phi_v for u and every feature v after u in s's list (half_at: the stencil slot's
// place in the half, -1 where none), the bias coupling c_s phi_u, the carried residual
// c_s mu_s phi_u and, with `with_eta`, eta's y_s phi_u.
__kernel void joint_rows(__global const uint* rstart, __global const uint* rlist, uint nrows,
                         __global const uint* start, __global const uint* fsample,
                         __global const double* fphi, __global const int* flocal,
                         __global const int* half_at, const int centre, const int half_slots,
                         __global const double* c, __global const double* mu,
                         __global const double* yc, const int with_eta, __global double* dprec,
                         __global double* drow) {
  const uint r = get_global_id(0);
  if (r >= nrows) return;
  __global double* row = dprec + (size_t)r * half_slots;
  for (int t = 0; t < half_slots; ++t) row[t] = 0;
  double bc = 0, res = 0, eta = 0;
  for (uint p = rstart[r]; p < rstart[r + 1]; ++p) {
    const uint u = rlist[p];
    const uint s = fsample[u];
    const double pu = fphi[u], ca = c[s] * pu;
    row[0] += ca * pu;
    const int base = centre - flocal[u];
    for (uint v = u + 1; v < start[s + 1]; ++v) row[half_at[base + flocal[v]]] += ca * fphi[v];
    bc += ca;
    res += c[s] * mu[s] * pu;
    if (with_eta) eta += yc[s] * pu;
  }
  drow[3 * r] = bc;
  drow[3 * r + 1] = res;
  drow[3 * r + 2] = eta;
}
