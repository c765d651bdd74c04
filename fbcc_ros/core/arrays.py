"""The package's one array type: float64 arrays of any shape (features, responses, wrenches)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
