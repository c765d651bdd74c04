"""ROS message wire format without rclpy: the CDR codec and the conversions to the core types."""
