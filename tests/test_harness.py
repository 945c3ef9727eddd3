"""The harness: SAT_TEST_TIMEOUT_SCALE scales pytest-timeout's limits; no test is ever rerun."""

import os
import subprocess
import sys

from conftest import TESTS_DIR
import pytest
from ros_harness import scaled

INNER = '''
import pytest


@pytest.mark.timeout(7)
def test_marked(request):
    print('limit', request.node.get_closest_marker('timeout').args[0])


def test_unmarked(request):
    print('limit', request.node.get_closest_marker('timeout').args[0])
'''


def inner_pytest(tmp_path, scale):
    """Run INNER with this suite's conftest, pytest.ini's limit 5 s and the given scale."""
    (tmp_path / 'test_inner.py').write_text(INNER)
    env = dict(os.environ, SAT_TEST_TIMEOUT_SCALE=scale,
               PYTHONPATH=os.pathsep.join([str(TESTS_DIR), os.environ.get('PYTHONPATH', '')]))
    return subprocess.run([sys.executable, '-m', 'pytest', '-p', 'conftest', '-p',
                           'no:cacheprovider', '-o', 'timeout=5', '-s', '-q', 'test_inner.py'],
                          cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=scaled(120))


def test_the_scale_multiplies_marked_and_default_limits(tmp_path):
    result = inner_pytest(tmp_path, '3')
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'limit 21.0' in result.stdout and 'limit 15.0' in result.stdout, result.stdout


def test_a_scale_that_is_not_a_positive_number_is_refused_by_name(tmp_path):
    result = inner_pytest(tmp_path, 'fast')
    assert result.returncode != 0
    assert "SAT_TEST_TIMEOUT_SCALE = 'fast': must be a number > 0" in \
        result.stdout + result.stderr


def test_failed_tests_are_never_rerun(pytestconfig):
    # pytest-rerunfailures comes with colcon-core; pytest.ini keeps it out of this suite.
    assert not pytestconfig.pluginmanager.has_plugin('rerunfailures')


def test_hypothesis_draws_the_same_examples_every_run_without_deadlines(pytestconfig):
    from hypothesis import settings
    if pytestconfig.getoption('hypothesis_profile', None) not in (None, 'suite'):
        pytest.skip('another Hypothesis profile was chosen for this session')
    assert settings.default.derandomize and settings.default.deadline is None


def test_every_property_test_of_the_session_follows_the_chosen_profile(request):
    """A test's own @settings must not pin the draw, or --hypothesis-profile=explore skips it.

    Settings are bound when a test is decorated, so this reads each collected test's own.
    """
    from hypothesis import is_hypothesis_test, settings
    tests = {item.nodeid: item.function for item in request.session.items
             if is_hypothesis_test(getattr(item, 'function', None))}
    pinned = {nodeid for nodeid, test in tests.items()
              if test._hypothesis_internal_use_settings.derandomize
              != settings.default.derandomize}
    assert pinned == set()
