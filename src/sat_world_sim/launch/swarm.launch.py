"""Launch a sat-swarm run on a full ROS 2 Jazzy install (launch/launch_ros are not on PyPI).

    ros2 launch sat_world_sim swarm.launch.py agents:=2 run_dir:=/tmp/run \
        scenario:=<share>/config/scenarios/paper.yaml

Starts world_sim, metrics and one agent node per id in 1..agents, each in its own process with
the same parameter file, exactly as the Python bring-up (`ros2 run sat_world_sim swarm`) does.
The agent ids must match the scenario's.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def _nodes(context):
    share = get_package_share_directory('sat_world_sim')
    params = LaunchConfiguration('params').perform(context) or os.path.join(
        share, 'config', 'paper.yaml')
    scenario = LaunchConfiguration('scenario').perform(context) or os.path.join(
        share, 'config', 'scenarios', 'paper.yaml')
    count = int(LaunchConfiguration('agents').perform(context))
    ids = list(range(1, count + 1))
    # Fast repair of lost samples (config/fastdds.xml), unless the user names a profile file.
    env = {'FASTRTPS_DEFAULT_PROFILES_FILE': os.environ.get(
        'FASTRTPS_DEFAULT_PROFILES_FILE', os.path.join(share, 'config', 'fastdds.xml'))}
    nodes = [
        Node(package='sat_world_sim', executable='world_sim', name='world_sim',
             parameters=[params, {'scenario': scenario, 'observers': 1}], output='screen',
             additional_env=env),
        Node(package='sat_world_sim', executable='metrics', name='metrics',
             parameters=[params, {'run_dir': LaunchConfiguration('run_dir').perform(context),
                                  'agent_ids': ids}], output='screen', additional_env=env),
    ]
    nodes += [Node(package='sat_agent', executable='agent', name='agent',
                   namespace=f'agent_{i}', parameters=[params, {'agent_id': i}],
                   output='screen', additional_env=env)
              for i in ids]
    return nodes


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument('agents', default_value='2', description='number of agents'),
        DeclareLaunchArgument('params', default_value='', description='parameter file'),
        DeclareLaunchArgument('scenario', default_value='', description='scenario file'),
        DeclareLaunchArgument('run_dir', default_value='runs/launch',
                              description='where metrics.json and plots go'),
        OpaqueFunction(function=_nodes),
    ])
