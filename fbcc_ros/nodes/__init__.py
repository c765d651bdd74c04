"""ROS 2 nodes: parameters in, messages <-> numpy (:mod:`convert`), the core called, published."""
