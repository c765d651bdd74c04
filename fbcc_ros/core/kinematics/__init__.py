"""The arm: robot models, inverse kinematics, the cell's feature and TCP solutions."""
