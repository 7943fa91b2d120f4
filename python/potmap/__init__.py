"""potmap: continuous occupancy maps on OpenCL devices, with NumPy arrays in and out.

Kernel maps (evaluate, raster, files), LIDAR datasets and labelling, the BHM and ABHM
learners, batched Sinkhorn, POT and RePOT (dictionaries of atoms, Mapper), metrics and the
paper's experiment methods. Units are metres and radians throughout. Device work releases
the GIL. Errors are potmap.Error subclasses carrying the library's message (file, line or
offset and value); ArgumentError and InputError are ValueErrors too.

    import potmap
    ctx = potmap.Context(device="pocl")
    m = potmap.read_map("town1.npz")
    prob, mean, var = m.evaluate(points, ctx)
"""

try:  # NumPy first: the bindings take and return its arrays, and would only fail at a first call.
    import numpy as _numpy  # noqa: F401
except ImportError as _e:
    import sys as _sys

    raise ImportError(
        "potmap needs NumPy, which this Python (%s) cannot import (%s): install it with "
        "`pip install numpy` (Debian: `apt install python3-numpy`)" % (_sys.executable, _e)) from _e

try:
    from ._potmap import __version__  # noqa: F401
except ModuleNotFoundError as _e:
    if _e.name != __name__ + "._potmap":
        raise
    import os as _os

    _here = _os.path.dirname(__file__)
    raise ImportError(
        "potmap: the compiled module _potmap is missing from %s: build it (`cmake --build build "
        "--target potmap_python`, then PYTHONPATH=build/python) or install the package "
        "(`pip install .` in potmap's source folder)" % _here) from None

from ._potmap import *  # noqa: F401,F403  (the compiled bindings)
from ._potmap import __doc__ as _bindings_doc  # noqa: F401
from . import _potmap

try:
    experiment = _potmap.experiment
except AttributeError:  # built without the experiments library (POTMAP_BUILD_EXPERIMENTS=OFF)
    pass

# Files by the map itself: m = KernelMap.load(path); m.save(path).
KernelMap.load = staticmethod(read_map)  # noqa: F405


def _save(self, path):
    write_map(self, path)  # noqa: F405


_save.__doc__ = write_map.__doc__  # noqa: F405
KernelMap.save = _save  # noqa: F405


if hasattr(_potmap, "_map_recording"):  # built with the experiments library

    def map_recording(path, out_dir=None, ctx=None, method="repot", options=None,
                      range_cut=20.0, first=0, max_scans=0, dictionary=None):
        """Maps a 2D recording (any log potmap reads) in one call, as `potmap mapping LOG`.

        path: the log. out_dir: when given, the folder (created) that receives map.potmap
        (the overall map) and scores.json (the held-out scores and timings). ctx: a Context
        (default: Context(), the default device). method: 'repot' (default: POT's transport
        refined by a persistent joint BHM) or 'pot'. options: MapperOptions (default: the
        library's, which map real logs best; MapperOptions.paper() for the authors' rules);
        method sets options.pot.refine. range_cut: returns farther than this become
        no-returns, metres (default 20, the towns' range the default dictionary's atoms are
        cut at; 0: none). first, max_scans: skip this many scans, map at most this many (0:
        all). dictionary: a .potdict path (default: default_dictionary(), built once and
        cached). A 3D drive folder raises ArgumentError: map it with map_drive() or
        DriveMapper. Returns a RecordingMap: map, overall and instantaneous Scores (every
        scan's held-out beams, 20 % by default, never used for transport), timings.
        """
        if method not in ("repot", "pot"):
            raise ArgumentError("map_recording: method must be 'repot' or 'pot', not %r"  # noqa: F405
                                % (method,))
        if ctx is None:
            ctx = Context()  # noqa: F405
        r = _potmap._map_recording(str(path), ctx, options, method == "repot", float(range_cut),
                                   int(first), int(max_scans),
                                   "" if dictionary is None else str(dictionary))
        if out_dir is not None:
            import json
            import os

            os.makedirs(out_dir, exist_ok=True)
            write_map(r.map, os.path.join(out_dir, "map.potmap"))  # noqa: F405

            def scores(s):
                return {"acc": s.acc, "auc": s.auc, "nll": s.nll, "points": s.n}

            record = {"log": str(path), "method": "RePOT" if method == "repot" else "POT",
                      "scans": r.scans, "overall_kernels": r.overall_kernels,
                      "instantaneous": scores(r.instantaneous), "overall": scores(r.overall),
                      "ms_per_scan": r.ms_per_scan, "dictionary": r.dictionary,
                      "range_cut": range_cut, "device": ctx.device.summary()}
            with open(os.path.join(out_dir, "scores.json"), "w") as f:
                json.dump(record, f, indent=1)
        return r
