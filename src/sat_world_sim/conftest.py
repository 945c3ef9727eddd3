"""`colcon test` runs pytest here, in the package; the suite (test/ is tests/) runs from the root.

make test starts pytest at the repository's root, and tests and tools read paths relative to
it (e.g. evaluate's default config/paper.yaml). colcon starts pytest in src/sat_world_sim and
loads this file first, so the suite gets the same working directory either way.
"""

import os
from pathlib import Path

os.chdir(Path(__file__).resolve().parents[2])
