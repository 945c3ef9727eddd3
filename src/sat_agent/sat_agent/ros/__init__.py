"""The agent's ROS 2 adapters: every module of sat_agent that imports rclpy or *_msgs.

The node, its parameters, message conversion with validation, QoS, the process runner and the
radio's byte parsing. The SAT-PHD core beside this package imports no ROS
(tests/test_ros_boundary.py), so it runs in-process, in benchmarks and on other middleware.
"""
