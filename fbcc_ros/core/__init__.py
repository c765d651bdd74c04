"""ROS-free core of fbcc_ros: numpy (and later pinocchio) only, never rclpy or message packages."""
