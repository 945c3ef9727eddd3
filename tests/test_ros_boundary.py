"""The layout shows the ROS boundary: the core imports no ROS, the adapters live in ros/.

Every module of sat_agent and sat_world_sim outside their ``ros/`` subpackages is parsed (ast)
and must not import rclpy, a ``*_msgs`` or ``*_interfaces`` package, launch, or the ``ros/``
adapters themselves, at module level or inside a function. The executables keep their names,
each package.xml declares what its code imports, and `colcon test` runs the suite.
"""

import ast
import configparser
import re
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

from conftest import REPO_ROOT
from ros_harness import scaled

PACKAGES = (REPO_ROOT / 'src' / 'sat_agent' / 'sat_agent',
            REPO_ROOT / 'src' / 'sat_world_sim' / 'sat_world_sim')
ROS_MODULE = re.compile(r'^(rclpy|rosidl_\w+|rmw\w*|launch|launch_ros|\w+_msgs|\w+_interfaces|'
                        r'sat_agent\.ros|sat_world_sim\.ros)(\.|$)')
EXECUTABLES = {
    'sat_agent': {'agent', 'agents_composed'},
    'sat_world_sim': {'compare_runs', 'evaluate', 'inprocess_swarm', 'logger', 'metrics',
                      'recorder', 'replay', 'swarm', 'world_sim'},
}


def ros_imports(source: str):
    """Return the ROS modules a Python source imports anywhere (sorted, de-duplicated)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            # `from sat_agent import ros` names the adapter package only in its alias.
            names = [node.module] if ROS_MODULE.match(node.module) else [
                f'{node.module}.{alias.name}' for alias in node.names]
        else:
            continue
        found.update(name for name in names if ROS_MODULE.match(name))
    return sorted(found)


def core_modules():
    for package in PACKAGES:
        for path in sorted(package.rglob('*.py')):
            if 'ros' not in path.relative_to(package).parts[:-1]:
                yield path


def test_the_scanner_sees_every_form_of_ros_import():
    source = ('import numpy\nimport rclpy.node\nfrom geometry_msgs.msg import Point\n'
              'def f():\n    from sat_agent.ros import qos\n    import builtin_interfaces\n'
              'from sat_agent import ros\nfrom . import x\n')
    assert ros_imports(source) == ['builtin_interfaces', 'geometry_msgs.msg', 'rclpy.node',
                                   'sat_agent.ros']


def test_the_core_imports_no_rclpy_no_messages_and_no_ros_adapter():
    modules = list(core_modules())
    assert len(modules) > 30, 'the scan found too few modules to be the core'
    leaks = {str(path.relative_to(REPO_ROOT)): ros_imports(path.read_text(encoding='utf-8'))
             for path in modules}
    assert {path: names for path, names in leaks.items() if names} == {}


def test_importing_the_core_loads_no_ros_module():
    # The transitive check: a fresh interpreter imports every core module, then looks at
    # sys.modules (a helper that imported ROS for the core would show up here).
    names = sorted('.'.join(path.relative_to(package.parent).with_suffix('').parts)
                   for package in PACKAGES for path in core_modules()
                   if path.is_relative_to(package))
    names = [name.removesuffix('.__init__') for name in names]
    code = ('import importlib, sys\n'
            f'for name in {names!r}:\n    importlib.import_module(name)\n'
            'print(sorted({m.split(".")[0] for m in sys.modules}))\n')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            timeout=scaled(120))
    assert result.returncode == 0, result.stderr
    loaded = [name for name in eval(result.stdout) if ROS_MODULE.match(name)]
    assert loaded == []


def console_scripts(package: str) -> dict:
    """Return {executable: 'module:function'} of a package's setup.py entry points."""
    source = (REPO_ROOT / 'src' / package / 'setup.py').read_text(encoding='utf-8')
    entries = re.findall(r"'(\w+) = ([\w.]+:\w+)'", source)
    return dict(entries)


def test_executables_keep_their_names_and_resolve():
    for package, names in EXECUTABLES.items():
        scripts = console_scripts(package)
        assert set(scripts) == names, package
        for target in scripts.values():
            module, function = target.split(':')
            source = REPO_ROOT / 'src' / package / (module.replace('.', '/') + '.py')
            tree = ast.parse(source.read_text(encoding='utf-8'))
            assert function in {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}, \
                target


def test_colcon_test_runs_the_make_test_suite():
    # colcon runs pytest in each package directory whose setup.py asks for pytest; sat_world_sim
    # (built last) does, and its test/ is this suite, collected under the same pytest.ini.
    package = REPO_ROOT / 'src' / 'sat_world_sim'
    assert (package / 'test').resolve() == REPO_ROOT / 'tests'
    assert "extras_require={'test': ['pytest']}" in (package / 'setup.py').read_text()
    setup_cfg = configparser.ConfigParser()
    setup_cfg.read(package / 'setup.cfg')
    assert 'tool:pytest' not in setup_cfg, 'a [tool:pytest] here would replace pytest.ini'


# Python libraries by their rosdep keys; the pip-only ones have none and are named in a
# package.xml comment instead (requirements.txt installs them).
ROSDEP_KEYS = {'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml',
               'matplotlib': 'python3-matplotlib', 'tqdm': 'python3-tqdm',
               'pydantic': 'python3-pydantic'}
PIP_ONLY = {'rosbags', 'rerun', 'ortools', 'dask', 'distributed'}
ROS_PACKAGES = re.compile(r'^(rclpy|ament_index_python|launch|launch_ros|\w+_msgs|'
                          r'\w+_interfaces)$')


def imported_roots(package: str) -> set:
    """Top-level modules the package's code (its Python package and launch files) imports."""
    roots = set()
    base = REPO_ROOT / 'src' / package
    for path in [*(base / package).rglob('*.py'), *(base / 'launch').glob('*.py')]:
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.Import):
                roots.update(alias.name.split('.')[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                roots.add(node.module.split('.')[0])
    return roots - set(sys.stdlib_module_names) - {package}


def test_each_package_xml_declares_what_its_code_imports():
    for package in ('sat_agent', 'sat_world_sim'):
        xml_path = REPO_ROOT / 'src' / package / 'package.xml'
        root = ElementTree.parse(xml_path).getroot()
        declared = {e.text for e in root if e.tag in ('depend', 'exec_depend')}
        text = xml_path.read_text(encoding='utf-8')
        for module in sorted(imported_roots(package)):
            if module in PIP_ONLY:
                assert module in text, f'{package}: name {module} in a package.xml comment'
            elif module in ROSDEP_KEYS:
                assert ROSDEP_KEYS[module] in declared, f'{package}: {ROSDEP_KEYS[module]}'
            else:
                assert ROS_PACKAGES.match(module) or module.startswith('sat_'), \
                    f'{package} imports {module}: add it to package.xml and to this test'
                assert module in declared, f'{package}: exec_depend {module}'
