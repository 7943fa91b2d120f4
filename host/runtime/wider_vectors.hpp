#pragma once
// POTMAP_WIDER_VECTORS before a function definition compiles it twice, for AVX2 and for the
// x86-64 baseline (SSE2) the library is otherwise built for, and the loader picks the clone the
// CPU runs (GCC's and Clang's target_clones, an ifunc): its loops vectorise four doubles or
// eight floats wide where the CPU has AVX2, and the library still runs on any x86-64.
//
// The AVX2 clone is built without FMA, so the compiler cannot fuse a * b + c into one rounding:
// both clones round every operation alike and give the same results bit for bit, and a map is
// the same on every x86-64 machine. Only for loops whose sums keep their order when vectorised
// (element-wise updates, independent lanes), never for a reduction the vectoriser would reorder
// (it does not reorder floating-point sums without -ffast-math).
//
// Elsewhere (other architectures, compilers without target_clones, sanitizer builds, whose
// runtimes are set up after ifunc resolvers run) it expands to nothing.

#if defined(__x86_64__) && defined(__ELF__) && defined(__has_attribute)
#if __has_attribute(target_clones) && !defined(__SANITIZE_ADDRESS__) && \
    !defined(__SANITIZE_THREAD__)
#define POTMAP_WIDER_VECTORS __attribute__((target_clones("avx2", "default")))
#endif
#endif
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#undef POTMAP_WIDER_VECTORS
#endif
#endif
#ifndef POTMAP_WIDER_VECTORS
#define POTMAP_WIDER_VECTORS
#endif
