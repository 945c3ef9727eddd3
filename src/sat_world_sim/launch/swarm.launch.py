"""Launch a sat-swarm run on a full ROS 2 Jazzy install: the same processes as the bring-up.

    ros2 launch sat_world_sim swarm.launch.py run_dir:=runs/launch seed:=1 clock:=lock_step \
        record:=true view:=file fastdds_profile:=config/fastdds.xml

The launch arguments are the bring-up's run options (``ros2 launch ... --show-args`` lists
them: scenario, params, run_dir, clock, period, agent_timeout, seed, steps, radio_loss,
radio_delay, composed, respawn, record, view, view_rate, live_params, fastdds_profile,
domain_id, key_file, run_id, no_auth), and the
processes, their arguments and their environment come from the bring-up's own
``process_list`` and ``run_env`` (sat_world_sim.bringup): one source of truth, checked by
tests/test_launch_parity.py. Every process runs with ``use_sim_time`` and the run's seed
(the scenario's unless ``seed`` is given). The launch ends, like the bring-up, once every
observer (metrics, recorder, logger) has exited; the agents exit by themselves when the world
says the run is finished.

Authentication: the launch makes no key; give one with ``key_file:=<path>`` (0600, >= 32 random
bytes), else every node runs without signatures and warns (README, "Trust model"). With a key
file every launch is a run with a new id (``run_id:=`` to choose it), as in the bring-up.

``processes(values)`` needs no launch package, so the process list can be checked (and run)
where launch is not installed.
"""

from sat_world_sim import bringup


def processes(values):
    """Return (processes, extra environment) for launch argument values (name -> string)."""
    options = bringup.options_from_launch(values)
    bringup.check_auth(options)
    return bringup.load_run(options), bringup.run_env(options.fastdds_profile, options.domain_id)


def _nodes(context):
    from launch.actions import EmitEvent, RegisterEventHandler
    from launch.event_handlers import OnProcessExit
    from launch.events import Shutdown
    from launch_ros.actions import Node

    values = dict(context.launch_configurations)
    specs, env = processes(values)
    nodes = {spec.name: Node(package=spec.package, executable=spec.executable,
                             arguments=list(spec.arguments),
                             ros_arguments=list(spec.ros_arguments), respawn=spec.respawn,
                             additional_env=env, output='screen')
             for spec in specs}
    observers = {spec.name for spec in specs if spec.observer}
    exited = set()

    def on_exit(name, event, _):
        # As the bring-up's supervise: the run is over when every observer has exited, and
        # lost when world_sim fails.
        exited.add(name)
        if observers <= exited or (name == 'world_sim' and event.returncode != 0):
            return [EmitEvent(event=Shutdown(reason=f'{name} exited: the run is over'))]
        return None

    handlers = [RegisterEventHandler(OnProcessExit(
        target_action=nodes[name],
        on_exit=lambda event, context, name=name: on_exit(name, event, context)))
        for name in sorted(observers | {'world_sim'})]
    return list(nodes.values()) + handlers


def generate_launch_description():
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, OpaqueFunction

    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=description)
          for name, default, description in bringup.launch_arguments()),
        OpaqueFunction(function=_nodes),
    ])
