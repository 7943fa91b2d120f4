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


if hasattr(_potmap, "_run_mapping_job"):  # built with the experiments library

    class MappedRecording:
        """What map_recording() wrote: `potmap mapping`'s files and scores.

        out_dir: the folder. files: every file written, scores.json last. scores: Scores of
        every scan's or keyframe's held-out beams (20 %, never mapped) on the final map (also
        `overall`). summary: scores.json as a dict (timings, kernels, memory, the run's
        options). drive: a 3D drive (else a 2D log). map: the map, read from map.potmap.
        """

        def __init__(self, result, out_dir):
            import json

            self.out_dir = str(out_dir)
            self.files = list(result.files)
            self.scores = result.scores
            self.drive = result.drive
            self.summary = json.loads(result.scores_json)

        @property
        def overall(self):
            return self.scores

        @property
        def map(self):
            import os

            return read_map(os.path.join(self.out_dir, "map.potmap"))  # noqa: F405

        def __repr__(self):
            return "<potmap.MappedRecording %s: AUC %.4f, NLL %.4f, %d files>" % (
                self.out_dir, self.scores.auc, self.scores.nll, len(self.files))

    def map_recording(path, out_dir=None, ctx=None, progress=None, quiet=True, **options):
        """Maps a recording of any kind into a folder, as `potmap mapping PATH -o OUT_DIR`.

        The library's mapping job (include/potmap/job/mapping_job.hpp), the one the command
        runs: a 2D log gives OUT_DIR/map.potmap, map_{prob,var,kernels}.png, map.yaml + .pgm
        and scores.json; a 3D drive folder map.potmap, map.bt (OctoMap), map_occupied.ply,
        map_band_{prob,var}.png, map_band.yaml + .pgm and scores.json, with checkpoints
        (resume=True continues a killed run). The same options give the same files and scores
        as the command.

        path: any recording potmap reads. out_dir: the folder, created (default
        default_mapping_folder(path), as the command's). ctx: a Context (default: Context()).
        progress: called with a JobProgress after every scan or keyframe and batch of output
        blocks (an exception raised there stops the job, every file whole). quiet: when False,
        the job's account (what is mapped, the device, the scores) is printed. options: fields
        of MappingJobOptions (method, dictionary, range_cut, first, max_scans, seed, preset,
        half_life, voxel, band_low, ...), as the command's options of the same names. Ctrl-C
        stops the job at the next scan or keyframe. Returns a MappedRecording.
        """
        if ctx is None:
            ctx = Context()  # noqa: F405
        o = MappingJobOptions(**options)  # noqa: F405
        o.out = str(out_dir) if out_dir is not None else default_mapping_folder(str(path))  # noqa: F405
        note = None if quiet else print
        r = _potmap._run_mapping_job(str(path), ctx, o, note, progress)
        return MappedRecording(r, o.out)
