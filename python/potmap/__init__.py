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

from ._potmap import *  # noqa: F401,F403  (the compiled bindings)
from ._potmap import __doc__ as _bindings_doc, __version__  # noqa: F401
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
