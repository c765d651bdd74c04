"""fbcc_ros: Feature-Based Compliance Control for peg-in-hole assembly on ROS 2."""

__version__ = "0.1.0"
