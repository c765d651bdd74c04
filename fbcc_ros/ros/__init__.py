"""ROS plumbing shared by the nodes: the CDR codec and the conversions to the core types (no
rclpy: the bag reader uses them too), the topic names and QoS, the parameter declaration, the
diagnostics."""
