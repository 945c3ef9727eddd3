"""ament_python package sat_agent: `ros2 run sat_agent agent`."""

from setuptools import find_packages, setup

PACKAGE = 'sat_agent'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
    ],
    install_requires=['setuptools'],
    # colcon test: pytest (it finds nothing here; the suite runs from sat_world_sim, whose
    # test/ is the repository's tests/) instead of the deprecated `setup.py test`.
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='sat-swarm maintainers',
    maintainer_email='maintainers@sat-swarm.org',
    description='Decentralized search-and-track agent: SAT-PHD filter, planners, rclpy node.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'agent = sat_agent.ros.agent_node:main',
            'agents_composed = sat_agent.ros.agent_node:main_composed',
        ],
    },
)
