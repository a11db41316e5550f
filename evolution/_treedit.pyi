"""Type stubs of the compiled tree edit distance (controller_cpp/src/treedit.cpp).

Use it through :mod:`evolution.diversity`. Trees are pre-order int32 arrays: part type id, slot
on the parent, parent index (-1 for the root).
"""

import numpy as np
import numpy.typing as npt

def distance(
    types_a: npt.NDArray[np.int32],
    slots_a: npt.NDArray[np.int32],
    parents_a: npt.NDArray[np.int32],
    types_b: npt.NDArray[np.int32],
    slots_b: npt.NDArray[np.int32],
    parents_b: npt.NDArray[np.int32],
) -> int: ...
def pairwise(
    types: npt.NDArray[np.int32],
    slots: npt.NDArray[np.int32],
    parents: npt.NDArray[np.int32],
    offsets: npt.NDArray[np.int32],
) -> npt.NDArray[np.int32]: ...
