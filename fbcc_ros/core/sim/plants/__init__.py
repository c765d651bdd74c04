"""The plants the simulator drives (:mod:`.plant`): the model of eq. 5-13 and MuJoCo."""
