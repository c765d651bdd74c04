"""From a raw force/torque reading to the wrench the peg exerts on the hole."""
