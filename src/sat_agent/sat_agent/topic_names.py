"""Topics in standard ROS types: the standard views, the robot interface and the clock.

Names (relative ones live under the agent's namespace ``/agent_<i>``) and ``pkg/msg/Name``
types, transport-free: the agent node (sat_agent.ros.agent_node), world_sim and the recorder's
list of the graph (sat_world_sim.topics) all read them here. What each one holds:
sat_agent.ros.views and sat_agent.ros.robot_input.
"""

# Standard views an agent publishes under view/<name>.
AGENT_VIEWS = {
    'search_density': 'nav_msgs/msg/OccupancyGrid',
    'estimates': 'visualization_msgs/msg/MarkerArray',
    'estimate_poses': 'geometry_msgs/msg/PoseArray',
    'plan': 'nav_msgs/msg/Path',
    'pose': 'geometry_msgs/msg/PoseStamped',
}
VIEW_PREFIX = 'view/'
# The robot interface: the goal the agent publishes, the pose and detections it takes with
# input_source:=robot.
ROBOT_GOAL = ('robot/goal', 'geometry_msgs/msg/PoseStamped')
ROBOT_POSE = ('robot/pose', 'geometry_msgs/msg/PoseStamped')
ROBOT_DETECTIONS = ('robot/detections', 'sensor_msgs/msg/PointCloud2')
# world_sim's sim time and its truth as markers.
CLOCK = ('/clock', 'rosgraph_msgs/msg/Clock')
TRUTH_MARKERS = ('/world/truth_markers', 'visualization_msgs/msg/MarkerArray')
