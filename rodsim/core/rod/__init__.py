"""One discretised Cosserat rod: geometry, quaternion algebra and state layout."""

from rodsim.core.rod.geometry import RodGeometry
from rodsim.core.rod.layout import COORDS_PER_NODE, RodLayout

__all__ = ["RodGeometry", "RodLayout", "COORDS_PER_NODE"]
