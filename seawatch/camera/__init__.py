"""Camera model: intrinsics, pose, PTZ; pixel <-> azimuth/elevation <-> sea-surface lat/lon.

See :mod:`seawatch.camera.model` for the frames and conventions.
"""

from seawatch.camera.model import (
    EARTH_RADIUS_M,
    REFRACTION_K,
    CameraFileError,
    CameraModel,
    Intrinsics,
    load_camera,
    load_fvessel_camera,
    save_camera,
)

__all__ = [
    "EARTH_RADIUS_M",
    "REFRACTION_K",
    "CameraFileError",
    "CameraModel",
    "Intrinsics",
    "load_camera",
    "load_fvessel_camera",
    "save_camera",
]
