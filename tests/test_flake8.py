"""The code base passes flake8 with the ament rules (.flake8: ament_flake8 + ament_pep257)."""

import subprocess
import sys

from conftest import REPO_ROOT


def test_flake8_ament_rules_clean():
    targets = ['src', 'scripts', 'tests']
    result = subprocess.run([sys.executable, '-m', 'flake8', *targets], cwd=REPO_ROOT,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
