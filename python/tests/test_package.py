"""The package around the bindings: what `import potmap` says when NumPy or the compiled module
is missing, and `python -m potmap`, which runs the potmap command as the command itself runs."""

import os
import shutil
import subprocess
import sys

import potmap


def python(code_or_args, **kw):
    args = ["-c", code_or_args] if isinstance(code_or_args, str) else code_or_args
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=300, **kw)


def test_import_without_numpy_fails_at_once_saying_how_to_install_it():
    done = python("import sys\n"
                  "sys.modules['numpy'] = None  # as if NumPy were not installed\n"
                  "try:\n"
                  "    import potmap\n"
                  "except ImportError as e:\n"
                  "    print(e)\n"
                  "    print('bindings loaded:', 'potmap._potmap' in sys.modules)\n")
    assert done.returncode == 0, done.stderr
    assert "potmap needs NumPy" in done.stdout and "pip install numpy" in done.stdout
    assert "python3-numpy" in done.stdout
    assert "bindings loaded: False" in done.stdout


def test_import_without_the_compiled_module_says_how_to_build_it(tmp_path):
    package = tmp_path / "potmap"
    package.mkdir()
    shutil.copy(os.path.join(os.path.dirname(potmap.__file__), "__init__.py"), package)
    done = python(["-c", "import potmap"], cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert done.returncode != 0
    assert "compiled module _potmap is missing from " + str(package) in done.stderr
    assert "--target potmap_python" in done.stderr and "pip install ." in done.stderr


def command(args):
    """The potmap command run as a shell runs it from PATH (argv[0] "potmap")."""
    return subprocess.run(["potmap", *args], executable=os.environ["POTMAP_CLI"],
                          capture_output=True, text=True, timeout=300)


def test_python_m_potmap_runs_the_command(tmp_path):
    via_python = python(["-m", "potmap", "--help"])
    assert via_python.returncode == 0, via_python.stderr
    assert "mapping" in via_python.stdout
    assert via_python.stdout == command(["--help"]).stdout
    # An error of the command: its message and exit status, unchanged.
    args = ["eval", "--map", str(tmp_path / "missing.potmap"), "--test", str(tmp_path / "t.csv")]
    via_python, direct = python(["-m", "potmap", *args]), command(args)
    assert direct.returncode != 0
    assert (via_python.returncode, via_python.stdout, via_python.stderr) == \
        (direct.returncode, direct.stdout, direct.stderr)
