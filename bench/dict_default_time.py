#!/usr/bin/env python3
"""How long `potmap dict default` (and `--3d`) takes to build the built-in dictionary when the
user's cache lacks it: wall and CPU seconds, each dictionary built into an empty cache folder of
its own (the build uses no device), the best of --repeat.

    bench/dict_default_time.py                      # prints, writes nothing
    bench/dict_default_time.py --figures            # also into docs/figures.json, then every page

--figures puts the wall times into docs/figures.json (dict.default.build, dict.default3d.build)
with this command and the machine, and scripts/make_doc_figures.py carries them to the pages.
"""
import argparse
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "scripts"))


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def build_once(potmap, dim, kernel_cache):
    """(wall s, CPU s) of one build into an empty dictionary cache."""
    cache = tempfile.mkdtemp(prefix="dict-default-")
    env = dict(os.environ, XDG_CACHE_HOME=cache, POTMAP_CACHE_DIR=kernel_cache)
    cmd = [potmap, "dict", "default"] + (["--3d"] if dim == 3 else [])
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    shutil.rmtree(cache)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--potmap", default=os.path.join(ROOT, "build", "tools", "potmap"))
    p.add_argument("--repeat", type=int, default=1, help="timed builds of each (best kept)")
    p.add_argument("--figures", action="store_true", help="write docs/figures.json and the pages")
    a = p.parse_args()
    kernel_cache = tempfile.mkdtemp(prefix="dict-default-kernels-")
    device = subprocess.run([a.potmap, "devices"], capture_output=True, text=True).stdout.strip()
    entries = {}
    for dim, name in ((2, "dict.default.build"), (3, "dict.default3d.build")):
        runs = [build_once(a.potmap, dim, kernel_cache) for _ in range(a.repeat)]
        wall, cpu = min(runs)
        print("%dD default dictionary: %.1f s wall, %.1f s CPU (best of %d; load %.2f)" % (
            dim, wall, cpu, len(runs), os.getloadavg()[0]))
        entries[name] = {
            "text": "%.0f s" % wall if wall >= 10 else "%.1f s" % wall,
            "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
            "command": "bench/dict_default_time.py --figures",
            "machine": "%d-core %s, %s" % (os.cpu_count(), cpu_name(), device.splitlines()[-1] if device else "?"),
            "about": "`potmap dict default%s` building the %dD default dictionary into an empty cache: "
                     "wall time" % (" --3d" if dim == 3 else "", dim),
        }
    shutil.rmtree(kernel_cache)
    if a.figures:
        import make_doc_figures
        make_doc_figures.set_measured(ROOT, entries)
        return make_doc_figures.main(["--root", ROOT])
    return 0


if __name__ == "__main__":
    sys.exit(main())
