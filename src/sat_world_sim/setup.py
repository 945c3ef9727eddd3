"""ament_python package sat_world_sim: world simulator, radio, bring-up, metrics, recording."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'sat_world_sim'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
        # The project's parameter, scenario and Fast DDS files, so an installed package finds them.
        (f'share/{PACKAGE}/config', glob('../../config/*.yaml') + ['../../config/fastdds.xml']),
        (f'share/{PACKAGE}/config/scenarios', glob('../../config/scenarios/*.yaml')),
    ],
    install_requires=['setuptools'],
    # `colcon test` runs pytest here when a package asks for it: test/ is the repository's
    # tests/ (a symlink), so colcon test and make test run one suite under one pytest.ini.
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='sat-swarm maintainers',
    maintainer_email='maintainers@sat-swarm.org',
    description='World simulator, range-gated radio, bring-up and metrics of a sat-swarm run.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'compare_runs = sat_world_sim.run_comparison:main',
            'evaluate = sat_world_sim.evaluate:main',
            'inprocess_swarm = sat_world_sim.inprocess_swarm:main',
            'logger = sat_world_sim.ros.logger_node:main',
            'metrics = sat_world_sim.ros.metrics_node:main',
            'recorder = sat_world_sim.ros.recorder_node:main',
            'replay = sat_world_sim.ros.replay:main',
            'swarm = sat_world_sim.bringup:main',
            'world_sim = sat_world_sim.ros.world_sim_node:main',
        ],
    },
)
