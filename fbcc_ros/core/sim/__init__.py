"""The hardware-free plant and studies: scenarios, the closed-loop simulator, the holder, the mock
cell, Monte Carlo."""
