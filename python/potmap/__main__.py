"""`python -m potmap ARGS` runs the potmap command with ARGS, as `potmap ARGS` does.

The command is the C++ program built with the package (`potmap mapping LOG -o out`,
`potmap --help`); the process becomes that program (exec), so its output, exit status and
signals (Ctrl-C) are the command's own. Where it lies is written into `_command.py` when the
package is built: beside the package (`pip install .`), the prefix's bin/ (`cmake --install`)
or the build tree.
"""

import os
import sys


def command_path():
    """The potmap command of this package, as an absolute path; SystemExit if there is none."""
    from . import _command

    if _command.COMMAND is None:
        raise SystemExit("potmap: this package was built without the potmap command "
                         "(POTMAP_BUILD_TOOLS=OFF): `python -m potmap` has nothing to run")
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), _command.COMMAND)
    path = os.path.normpath(path)
    if not os.access(path, os.X_OK):
        raise SystemExit("potmap: the potmap command %s is missing: build it (`cmake --build "
                         "build --target potmap_cli`) or reinstall the package" % path)
    return path


def main(argv=None):
    """Runs the command with argv (default: sys.argv[1:]); does not return."""
    args = sys.argv[1:] if argv is None else list(argv)
    path = command_path()
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(path, ["potmap", *args])


if __name__ == "__main__":
    main()
