"""The plants a law runs against (DESIGN §7): the model of eq. 5-13 and MuJoCo."""
