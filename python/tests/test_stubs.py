"""The type stubs follow the bindings, and help() shows parameters with units and defaults."""

import os
import pydoc
import subprocess
import sys

import potmap

HERE = os.path.dirname(__file__)


def test_stubs_are_up_to_date():
    script = os.path.join(HERE, "..", "tools", "make_stubs.py")
    stub = os.path.join(HERE, "..", "potmap", "__init__.pyi")
    done = subprocess.run([sys.executable, script, "--check", stub], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_every_public_name_is_in_the_stubs():
    with open(os.path.join(HERE, "..", "potmap", "__init__.pyi")) as f:
        stub = f.read()
    names = [n for n in dir(potmap._potmap) if not n.startswith("_")]
    assert len(names) > 60
    for n in names:
        assert f"class {n}" in stub or f"def {n}(" in stub, n


def test_help_shows_units_and_defaults():
    text = pydoc.render_doc(potmap.Mapper, renderer=pydoc.plaintext)
    assert "add_scan" in text and "refine: bool = False" in text
    text = pydoc.render_doc(potmap.KernelMap, renderer=pydoc.plaintext)
    assert "metres" in text and "1/m^2" in text
    text = pydoc.render_doc(potmap.Context, renderer=pydoc.plaintext)
    assert "device: str = ''" in text
    assert "default 0.5" in potmap.JointBhmOptions.spacing.__doc__
    assert "metres" in repr(potmap.JointBhmOptions.spacing.__doc__)
    assert repr(potmap.PotOptions(wall_clearance=0.5)).startswith("PotOptions(")
    # Every field with its value (the class's __dict__ is a mappingproxy, once read as empty).
    assert "wall_clearance=0.5" in repr(potmap.PotOptions(wall_clearance=0.5))
    assert "async_merge=True" in repr(potmap.MapperOptions(async_merge=True))
    assert "seeds_yield_fully=True" in repr(potmap.JointBhmOptions(seeds_yield_fully=True))
