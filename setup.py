"""Builds the Python package `potmap` through CMake, for `pip install .` (pyproject.toml).

setuptools' build_ext is replaced by a CMake build: potmap is configured in setuptools' build
folder (build-pip/ at the top of the source tree) for the interpreter that runs pip, without
its tests and benchmarks; the library, the potmap command and the module are built, installed
into a staging prefix with `cmake --install`, and packed into the package's folder:

    potmap/_potmap.<abi>.so   the bindings, run path $ORIGIN/lib
    potmap/lib/               libpotmap.so.0, and libpotmap_gdal.so (libpotmap loads it from
                              its own folder for GeoTIFFs)
    potmap/bin/potmap         the command, run path $ORIGIN/../lib; `python -m potmap ARGS` and
                              the `potmap` script pip puts on PATH run it

Environment:
    POTMAP_CMAKE_BUILD_DIR      an already-built CMake build folder of potmap (configured for this
                                Python's version, `cmake --build` done): packed as it is, nothing
                                configured or compiled. The tests use it, so that CI does not build
                                potmap twice; setuptools' own files then go to its pip/ folder.
    POTMAP_CMAKE_ARGS           more configure arguments, e.g. "-DPOTMAP_WITH_ROS=OFF".
    CMAKE_BUILD_PARALLEL_LEVEL  compile jobs (default: every core).
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
EXISTING_BUILD = os.environ.get("POTMAP_CMAKE_BUILD_DIR", "")


def project_version():
    m = re.search(r"project\(potmap VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text())
    if not m:
        sys.exit("setup.py: no `project(potmap VERSION x.y.z)` in %s" % (ROOT / "CMakeLists.txt"))
    return m.group(1)


def run_cmake(*args):
    cmd = ["cmake", *map(str, args)]
    print("setup.py: " + shlex.join(cmd), flush=True)
    try:
        subprocess.run(cmd, check=True)
    except FileNotFoundError:
        sys.exit("setup.py: cmake not found: potmap builds with CMake 3.20 or newer and the "
                 "Debian packages that scripts/setup.sh installs")
    except subprocess.CalledProcessError as e:
        sys.exit("setup.py: `%s` failed (exit status %d); its output is above"
                 % (shlex.join(cmd), e.returncode))


def cache_entries(build_dir):
    """The CMakeCache.txt of build_dir as a dict of name: value."""
    cache = build_dir / "CMakeCache.txt"
    if not cache.is_file():
        sys.exit("setup.py: %s is not a CMake build folder (no CMakeCache.txt)" % build_dir)
    entries = {}
    for line in cache.read_text().splitlines():
        m = re.match(r"([A-Za-z0-9_.-]+):[A-Z_]+=(.*)$", line)
        if m:
            entries[m.group(1)] = m.group(2)
    return entries


def set_run_path(path, run_path):
    script = ROOT / "cmake" / "SetRunPath.cmake"
    run_cmake("-DFILE=%s" % path, "-DRUN_PATH=%s" % run_path, "-P", script)


def staged_module(staged_package):
    """The compiled module in the staged package, checked to be for this interpreter."""
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    found = sorted(staged_package.glob("_potmap*.so"))
    if not found:
        sys.exit("setup.py: no compiled module under %s: the CMake build has no Python package "
                 "(its configure output says why: pybind11-dev, python3-dev) or it is not built"
                 % staged_package)
    for module in found:
        if module.name == "_potmap" + suffix:
            return module
    sys.exit("setup.py: the build's module %s is not for %s, which loads _potmap%s: configure "
             "the build with -DPOTMAP_PYTHON=%s" % (found[0].name, sys.executable, suffix,
                                                    sys.executable))


def pack(build_dir, stage, module_path):
    """Copies what `cmake --install` staged into the package folder (module_path's), with run
    paths that point into the package itself."""
    cache = cache_entries(build_dir)
    package = module_path.parent
    staged_package = stage / cache["POTMAP_PYTHON_INSTALL_DIR"] / "potmap"
    lib_dir = stage / cache.get("CMAKE_INSTALL_LIBDIR", "lib")
    bin_dir = stage / cache.get("CMAKE_INSTALL_BINDIR", "bin")
    package.mkdir(parents=True, exist_ok=True)
    shutil.copy2(staged_module(staged_package), module_path)
    set_run_path(module_path, "$ORIGIN/lib")
    # libpotmap under its soname (the name the module and the command ask the loader for).
    (package / "lib").mkdir(exist_ok=True)
    soname = "libpotmap.so." + project_version().split(".")[0]
    shutil.copy2(lib_dir / soname, package / "lib" / soname)  # follows the symbolic link
    if (lib_dir / "libpotmap_gdal.so").exists():
        shutil.copy2(lib_dir / "libpotmap_gdal.so", package / "lib" / "libpotmap_gdal.so")
    command = "None"
    if (bin_dir / "potmap").exists():
        (package / "bin").mkdir(exist_ok=True)
        shutil.copy2(bin_dir / "potmap", package / "bin" / "potmap")
        set_run_path(package / "bin" / "potmap", "$ORIGIN/../lib")
        command = '"bin/potmap"'
    (package / "_command.py").write_text(
        "# Where `python -m potmap` finds the potmap command: relative to this folder.\n"
        "COMMAND = %s\n" % command)


class BuildWithCMake(build_ext):
    """build_ext that builds potmap with CMake (or takes POTMAP_CMAKE_BUILD_DIR's build)."""

    def run(self):
        if self.inplace:
            sys.exit("setup.py: editable installs are not supported; from the source tree use "
                     "the CMake build (PYTHONPATH=build/python)")
        build_dir = self.cmake_build()
        stage = Path(self.build_temp).resolve() / "stage"
        shutil.rmtree(stage, ignore_errors=True)
        run_cmake("--install", build_dir, "--prefix", stage)
        pack(build_dir, stage, Path(self.get_ext_fullpath("potmap._potmap")).resolve())

    def cmake_build(self):
        if EXISTING_BUILD:
            build_dir = Path(EXISTING_BUILD).resolve()
            print("setup.py: packing the CMake build %s (POTMAP_CMAKE_BUILD_DIR): nothing is "
                  "configured or compiled" % build_dir, flush=True)
            return build_dir
        build_dir = Path(self.build_temp).resolve() / "cmake"
        run_cmake("-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
                  "-DPOTMAP_PYTHON=%s" % sys.executable, "-DPOTMAP_PYTHON_NEEDS_NUMPY=OFF",
                  "-DPOTMAP_BUILD_TESTS=OFF", "-DPOTMAP_BUILD_CAPI_TESTS=OFF",
                  "-DPOTMAP_BUILD_BENCH=OFF", *shlex.split(os.environ.get("POTMAP_CMAKE_ARGS", "")))
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        run_cmake("--build", build_dir, "--parallel", jobs)
        return build_dir


# setuptools' own files (its build folders, the egg-info) out of the source tree's top.
BUILD_BASE = Path(EXISTING_BUILD).resolve() / "pip" if EXISTING_BUILD else ROOT / "build-pip"
BUILD_BASE.mkdir(parents=True, exist_ok=True)

setup(
    version=project_version(),
    packages=["potmap"],
    package_dir={"potmap": "python/potmap"},
    package_data={"potmap": ["__init__.pyi", "py.typed"]},
    include_package_data=False,
    ext_modules=[Extension("potmap._potmap", sources=[])],
    cmdclass={"build_ext": BuildWithCMake},
    options={"build": {"build_base": str(BUILD_BASE)}, "egg_info": {"egg_base": str(BUILD_BASE)}},
)
