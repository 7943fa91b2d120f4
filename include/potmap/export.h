/* Symbol visibility of libpotmap (plain C; included by potmap.h and every C++ header).
 *
 * The library is compiled with -fvisibility=hidden and -fvisibility-inlines-hidden: a symbol is
 * exported from the shared library only if it is marked here. Two markings exist:
 *   POTMAP_EXPORT          on each function of the C API (potmap.h);
 *   POTMAP_CXX_API_BEGIN / POTMAP_CXX_API_END
 *                          around the potmap namespace of every public C++ header
 *                          (the .hpp files of include/potmap): everything declared there is
 * exported. Whatever host/ declares (namespaces potmap::detail, potmap::npy, potmap::npz,
 * potmap::data) stays hidden. The pragma form is used rather than a macro on each declaration so
 * that a definition in another namespace block keeps the exported visibility under clang as well.
 */
#ifndef POTMAP_EXPORT_H
#define POTMAP_EXPORT_H

#if defined(__GNUC__) || defined(__clang__)
#define POTMAP_EXPORT __attribute__((visibility("default")))
#define POTMAP_CXX_API_BEGIN _Pragma("GCC visibility push(default)")
#define POTMAP_CXX_API_END _Pragma("GCC visibility pop")
#else
#define POTMAP_EXPORT
#define POTMAP_CXX_API_BEGIN
#define POTMAP_CXX_API_END
#endif

#endif /* POTMAP_EXPORT_H */
