"""The simulator's ROS 2 adapters: every module of sat_world_sim that imports rclpy or *_msgs.

The nodes (world_sim, metrics, recorder, logger), the observers' start-up handshake, the live
bag replay and the shared QoS/message-class look-ups. The maths they call (world_model, radio,
metrics, records, rerun_view, bag reading) imports no ROS (tests/test_ros_boundary.py).
"""
