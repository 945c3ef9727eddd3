#!/usr/bin/env python3
"""Point the ROS 2 wheels' exported CMake include paths at this venv's Python and numpy.

The ros-jazzy-* wheels export ``INTERFACE_INCLUDE_DIRECTORIES`` naming the build machine's
Python and numpy headers (``/opt/python/cp311-cp311/...``). CMake refuses an include directory
that does not exist, so any message package depending on std_msgs/geometry_msgs fails to
generate until they point at real directories. Rewriting is idempotent: a file already naming
this venv's directories is left untouched.
"""

import argparse
from pathlib import Path
import re
import sys
import sysconfig

import numpy

# A python include dir followed by a numpy include dir, as the wheels write them.
INCLUDE_PAIR = re.compile(
    r'INTERFACE_INCLUDE_DIRECTORIES "[^";]*/include/python3\.\d+;[^";]*/numpy/_core/include"')


def fix_file(path: Path, replacement: str) -> bool:
    """Rewrite one exported CMake file; return whether it changed."""
    text = path.read_text(encoding='utf-8')
    fixed = INCLUDE_PAIR.sub(replacement, text)
    if fixed == text:
        return False
    path.write_text(fixed, encoding='utf-8')
    return True


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('prefix', type=Path, help='the venv prefix (holds share/*/cmake)')
    args = parser.parse_args()
    python_include = sysconfig.get_paths()['include']
    numpy_include = numpy.get_include()
    for directory in (python_include, numpy_include):
        if not Path(directory).is_dir():
            print(f'error: include directory {directory} does not exist', file=sys.stderr)
            return 1
    replacement = f'INTERFACE_INCLUDE_DIRECTORIES "{python_include};{numpy_include}"'
    changed = [p for p in sorted(args.prefix.glob('share/*/cmake/*Export*.cmake'))
               if fix_file(p, replacement)]
    print(f'fix_wheel_cmake_paths: {len(changed)} exported CMake file(s) rewritten')
    return 0


if __name__ == '__main__':
    sys.exit(main())
