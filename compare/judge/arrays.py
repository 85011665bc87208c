"""The array types the judge passes around."""

import numpy as np
from numpy.typing import NDArray

F32 = NDArray[np.float32]  # images (H, W, 3) and per-pixel maps (H, W)
