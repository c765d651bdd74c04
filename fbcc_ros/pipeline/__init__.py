"""The cell's stages without ROS: compensation, kinematics, controller, each owning its
parameter table. The nodes are thin adapters around one stage each, and the offline replay
drives the same stages; the simulator, batched over trials, runs the same law with the
supervisor's step clip (:mod:`fbcc_ros.core.sim.simulation`)."""
