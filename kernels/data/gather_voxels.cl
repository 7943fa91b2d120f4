// A keyframe's training samples drawn and gathered per voxel (host/data/keyframe_samples.cpp is
// the reference, keyframe_plan.hpp the layout): one work-item per training beam draws the
// beam's samples as label_scan() does (SplitMix64 from the beam's own state, the sample at a
// uniform distance along the beam) and adds each to its voxel in an open-addressing table:
// the key claimed by compare-and-swap, the count and the sample's fixed-point place in the
// voxel added by integer atomics, so the sums are the same whatever order the work-items run.
// Doubles throughout, contraction off: every sample lands in the voxel the host puts it in.

#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#pragma OPENCL FP_CONTRACT OFF

#define EMPTY_KEY 0xffffffffffffffffUL
#define GOLDEN 0x9e3779b97f4a7c15UL
#define AXIS_BITS 21
#define AXIS_HALF 1048576L
#define AXIS_LIMIT 524288.0
#define FRAC_ONE 1048576.0

inline ulong mix64(ulong z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9UL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebUL;
  return z ^ (z >> 31);
}

// Adds the sample at q (label 0 or 1) to the table; bit 0 of *flags: a sample outside the keys'
// reach, bit 1: the table was full (the host then gathers the keyframe itself).
inline void add_sample(const double q0, const double q1, const double q2, const ulong label,
                       const double inv, __global ulong* keys, __global uint* counts,
                       __global ulong* sums, const ulong mask, __global uint* flags) {
  const double q[3] = {q0, q1, q2};
  ulong key = 0, frac[3];
  for (int d = 2; d >= 0; --d) {
    const double s = q[d] * inv;
    const double c = floor(s);
    if (!(c >= -AXIS_LIMIT && c < AXIS_LIMIT)) {
      atomic_or(flags, 1u);
      return;
    }
    const double f = (s - c) * FRAC_ONE;
    frac[d] = f < FRAC_ONE ? (ulong)f : (ulong)(FRAC_ONE - 1.0);
    key = (key << AXIS_BITS) | (ulong)((long)c + AXIS_HALF);
  }
  key = (key << 1) | label;
  ulong h = mix64(key) & mask;
  for (ulong probe = 0; probe <= mask; ++probe) {
    const ulong prev = atom_cmpxchg(&keys[h], EMPTY_KEY, key);
    if (prev == EMPTY_KEY || prev == key) {
      atomic_inc(&counts[h]);
      atom_add(&sums[3 * h + 0], frac[0]);
      atom_add(&sums[3 * h + 1], frac[1]);
      atom_add(&sums[3 * h + 2], frac[2]);
      return;
    }
    h = (h + 1) & mask;
  }
  atomic_or(flags, 2u);
}

__kernel void gather_clear(__global ulong* keys, __global uint* counts, __global ulong* sums,
                           const ulong slots) {
  const ulong h = get_global_id(0);
  if (h >= slots) return;
  keys[h] = EMPTY_KEY;
  counts[h] = 0;
  sums[3 * h + 0] = 0;
  sums[3 * h + 1] = 0;
  sums[3 * h + 2] = 0;
}

// One work-item per training beam: dir and end 3 doubles each, draws_hit = draws | hit << 31.
__kernel void gather_beams(const double o0, const double o1, const double o2, const double inv,
                           __global const double* dir, __global const double* len,
                           __global const double* end, __global const ulong* state,
                           __global const uint* draws_hit, const uint beams,
                           __global ulong* keys, __global uint* counts, __global ulong* sums,
                           const ulong mask, __global uint* flags) {
  const uint b = get_global_id(0);
  if (b >= beams) return;
  const uint dh = draws_hit[b];
  if (dh >> 31)
    add_sample(end[3 * b], end[3 * b + 1], end[3 * b + 2], 1UL, inv, keys, counts, sums, mask,
               flags);
  const uint draws = dh & 0x7fffffffu;
  const double l = len[b];
  const double d0 = dir[3 * b], d1 = dir[3 * b + 1], d2 = dir[3 * b + 2];
  ulong s = state[b];
  for (uint j = 0; j < draws; ++j) {
    s += GOLDEN;
    const double u = (double)(mix64(s) >> 11) * 0x1.0p-53;
    const double t = u * l;
    add_sample(o0 + t * d0, o1 + t * d1, o2 + t * d2, 0UL, inv, keys, counts, sums, mask, flags);
  }
}

// The table's used slots, packed (in no particular order: the host sorts them by key).
__kernel void gather_compact(__global const ulong* keys, __global const uint* counts,
                             __global const ulong* sums, const ulong slots,
                             __global ulong* out_keys, __global uint* out_counts,
                             __global ulong* out_sums, __global uint* used) {
  const ulong h = get_global_id(0);
  if (h >= slots || keys[h] == EMPTY_KEY) return;
  const uint i = atomic_inc(used);
  out_keys[i] = keys[h];
  out_counts[i] = counts[h];
  out_sums[3 * i + 0] = sums[3 * h + 0];
  out_sums[3 * i + 1] = sums[3 * h + 1];
  out_sums[3 * i + 2] = sums[3 * h + 2];
}
