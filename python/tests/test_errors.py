"""Every error path: potmap's own errors as Python exceptions carrying its message, and bad
arrays as TypeError / ValueError before they reach the library."""

import gzip

import numpy as np
import pytest

import potmap


def test_exception_classes():
    assert issubclass(potmap.Error, RuntimeError)
    assert issubclass(potmap.InputError, potmap.Error) and issubclass(potmap.InputError, ValueError)
    assert issubclass(potmap.ArgumentError, potmap.Error) and issubclass(potmap.ArgumentError, ValueError)
    assert issubclass(potmap.BuildError, potmap.OpenCLError)
    assert issubclass(potmap.OpenCLError, potmap.Error)


def test_bad_map_file_names_file_line_and_value(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("x,y,gamma,w_mean,w_var\n1,2,0.5,0.1,0.2\n3,4,abc,0.1,0.2\n")
    with pytest.raises(potmap.InputError) as e:
        potmap.read_map(str(path))
    msg = str(e.value)
    assert "bad.csv" in msg and "3" in msg and "abc" in msg


def test_corrupt_native_map_names_the_offset(scene, tmp_path):
    path = tmp_path / "m.potmap"
    potmap.write_map(scene.map, str(path))
    raw = bytearray(path.read_bytes())
    raw[60] ^= 0xFF
    path.write_bytes(bytes(raw))
    with pytest.raises(potmap.InputError, match="m.potmap"):
        potmap.read_map(str(path))


def test_missing_and_unknown_files(tmp_path):
    with pytest.raises(potmap.InputError, match="nothing.potmap"):
        potmap.read_map(str(tmp_path / "nothing.potmap"))
    with pytest.raises(potmap.InputError):
        potmap.read_map(str(tmp_path / "map.txt"))
    with pytest.raises(potmap.ArgumentError):
        potmap.write_map(potmap.KernelMap(np.zeros((1, 2)), [1.0], [0.0], [1.0]), str(tmp_path / "m.txt"))


def test_bad_carmen_line_names_file_and_line(tmp_path):
    path = tmp_path / "bad.log.gz"
    with gzip.open(path, "wt") as f:
        f.write("FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 0 host 0\n")
        f.write("FLASER 3 1.0 -2.0 3.0 0 0 0 0 0 0 0 host 0\n")
    with pytest.raises(potmap.InputError) as e:
        potmap.read_dataset(str(path))
    assert "bad.log.gz" in str(e.value) and "2" in str(e.value)


def test_invalid_kernels_raise_argument_error():
    with pytest.raises(potmap.ArgumentError, match="gamma"):
        potmap.KernelMap(np.zeros((3, 2)), [1.0, -1.0, 1.0], [0, 0, 0.0], [1, 1, 1.0])
    with pytest.raises(potmap.ArgumentError):
        potmap.KernelMap(np.zeros((2, 2)), [1.0, 1.0], [0, np.nan], [1, 1.0])


@pytest.mark.parametrize("bad, exc", [
    (np.zeros((4, 3)), ValueError),         # wrong width
    (np.zeros(8), ValueError),              # flat
    (np.zeros((2, 2, 2)), ValueError),      # 3D
    (np.zeros((4, 2), dtype=np.int64), TypeError),
    (np.array([["a", "b"]]), TypeError),
    (np.zeros((4, 2), dtype=np.complex128), TypeError),
    (None, TypeError),
    ("points", TypeError),
])
def test_bad_point_arrays(scene, ctx, bad, exc):
    ev = potmap.Evaluator(ctx, scene.map)
    with pytest.raises(exc):
        ev.evaluate(bad)
    with pytest.raises(exc):
        scene.map.evaluate_exact(bad)


def test_bad_constructor_arrays():
    with pytest.raises(ValueError, match="gamma"):
        potmap.KernelMap(np.zeros((3, 2)), [1.0, 1.0], [0, 0, 0.0], [1, 1, 1.0])
    with pytest.raises(TypeError, match="w_mean"):
        potmap.KernelMap(np.zeros((3, 2)), [1.0] * 3, np.zeros(3, dtype=np.int32), [1.0] * 3)
    with pytest.raises(ValueError, match="positions"):
        potmap.KernelMap(np.zeros((3, 4)), [1.0] * 3, [0.0] * 3, [1.0] * 3)
    with pytest.raises(ValueError, match="labels"):
        potmap.LabelledPoints(np.zeros((3, 2)), [0, 1, 2])
    with pytest.raises(ValueError):
        potmap.LabelledPoints(np.zeros((3, 2)), [0, 1])


def test_bad_scores():
    with pytest.raises(ValueError):
        potmap.score(np.array([0.5, 0.5]), np.array([1, 0, 1]))
    with pytest.raises(potmap.ArgumentError, match="1"):
        potmap.score(np.array([0.5, np.nan]), np.array([1, 0]))
    with pytest.raises(potmap.ArgumentError):
        potmap.score(np.array([0.5, 1.5]), np.array([1, 0]))
    with pytest.raises(TypeError):
        potmap.score(np.array([0.5, 0.5]), np.array(["a", "b"]))


def test_unknown_device_and_options():
    with pytest.raises(potmap.Error, match="no-such-device"):
        potmap.Context(device="no-such-device")
    with pytest.raises(TypeError, match="em_iteration"):
        potmap.BhmOptions(em_iteration=2)
    with pytest.raises(TypeError, match="refin"):
        potmap.PotOptions(refin=True)
    assert potmap.PotOptions(refine=True, wall_clearance=0.5).wall_clearance == 0.5


def test_raster_window_errors(scene, ctx):
    with pytest.raises(potmap.ArgumentError):
        scene.map.raster((0, -1, 0, 1), 0.5, ctx)
    with pytest.raises(ValueError):
        scene.map.raster((0, 1, 0), 0.5, ctx)


def test_sinkhorn_errors(ctx):
    b = potmap.SinkhornBatch()
    with pytest.raises(potmap.InputError):
        b.add(np.array([[0.0, np.nan]]), np.zeros((2, 2)))
    with pytest.raises(ValueError):
        b.add(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(potmap.ArgumentError):
        b.add(np.zeros((3, 2)), np.zeros((3, 2)), epsilon=-1.0)
    with pytest.raises(TypeError, match="epsilonn"):
        b.add(np.zeros((3, 2)), np.zeros((3, 2)), epsilonn=1.0)
    with pytest.raises(ValueError):
        potmap.sinkhorn(ctx, [np.zeros((3, 2))], [])


def test_dictionary_errors(tmp_path):
    path = tmp_path / "d.potdict"
    path.write_bytes(b"POTDIC\r\n" + bytes(100))
    with pytest.raises(potmap.InputError, match="d.potdict"):
        potmap.Dictionary.load(str(path))
    with pytest.raises(potmap.ArgumentError):
        potmap.Mapper(None, potmap.Dictionary())
