"""The archive of ``rodsim modes`` (docs/archive.md, "Modes archives"): the run archive of
the equilibrium (``rodsim.io.run_dataset.run_dataset``) with a ``mode`` dimension.

Variables along ``mode`` (lowest frequency first): ``frequency`` [Hz], ``eigenvalue_real``
and ``eigenvalue_imag`` (ω² [rad²/s²]; netCDF has no complex numbers), ``mode_position``
(mode, node, axis) and ``mode_quaternion`` (mode, segment, component): the mode shapes laid
out as ``position`` and ``quaternion``, scaled to a modal mass of the scene's whole mass
times 1 m² (``rodsim.app.modes.Modes.shapes``), and
``rotational_share``; with the scene's damping (rodsim/core/damped_vibration.py),
``damped_frequency`` [Hz], ``damping_ratio`` and ``damped_eigenvalue_real`` and
``damped_eigenvalue_imag`` (λ [1/s]; without damping λ = iω, ζ = 0), these roots ordered
by |λ|; and matched to the undamped modes (``rodsim.app.modes.Modes.matched_eigenvalues``),
along ``mode`` in the undamped order: ``matched_eigenvalue_real`` and
``matched_eigenvalue_imag``, ``shape_mac``, and the complex damped shapes as
``damped_mode_position_real`` / ``_imag`` (mode, node, axis) and
``damped_mode_quaternion_real`` / ``_imag`` (mode, segment, component), scaled as the
undamped ones. Attributes: ``kind`` = ``modes``, ``rotary_inertia``, ``modes_message``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rodsim.io.provenance import history
from rodsim.io.run_dataset import run_dataset
from rodsim.solvers.result import Result

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["modes_dataset"]


def modes_dataset(result: Result, *, frequencies: np.ndarray, eigenvalues: np.ndarray,
                  shapes: np.ndarray, rotations: np.ndarray, rotational_share: np.ndarray,
                  rotary_inertia: bool, message: str,
                  damped_eigenvalues: np.ndarray, damped_frequencies: np.ndarray,
                  damping_ratios: np.ndarray, matched_eigenvalues: np.ndarray,
                  shape_mac: np.ndarray, damped_shapes: np.ndarray,
                  damped_rotations: np.ndarray) -> xr.Dataset:
    """The modes archive of the equilibrium ``result`` (module docstring)."""
    ds = run_dataset(result)
    count = len(frequencies)
    eigenvalues = np.asarray(eigenvalues, dtype=complex)
    ds = ds.assign_coords(mode=("mode", np.arange(count, dtype=np.int64),
                                {"units": "1", "long_name": "mode number, lowest frequency "
                                 "first"}))
    ds["frequency"] = ("mode", np.asarray(frequencies, dtype=float),
                       {"units": "Hz", "long_name": "natural frequency Re(omega)/(2 pi) "
                        "(NaN: omega^2 <= 0, no oscillation)"})
    ds["eigenvalue_real"] = ("mode", eigenvalues.real.copy(),
                             {"units": "rad2 s-2", "long_name": "real part of omega^2"})
    ds["eigenvalue_imag"] = ("mode", eigenvalues.imag.copy(),
                             {"units": "rad2 s-2", "long_name": "imaginary part of omega^2 "
                              "(nonzero only for a non-conservative coupling)"})
    ds["mode_position"] = (("mode", "node", "axis"), np.asarray(shapes, dtype=float),
                           {"units": "m", "long_name": "control point displacement of the "
                            "mode (modal mass: the whole mass times 1 m2)"})
    ds["mode_quaternion"] = (("mode", "segment", "component"),
                             np.asarray(rotations, dtype=float),
                             {"units": "1", "long_name": "quaternion change of the mode "
                              "(modal mass: the whole mass times 1 m2)"})
    ds["rotational_share"] = ("mode", np.asarray(rotational_share, dtype=float),
                              {"units": "1", "long_name": "fraction of the modal kinetic "
                               "energy in the segments' rotation"})
    roots = np.asarray(damped_eigenvalues, dtype=complex)
    ds["damped_frequency"] = ("mode", np.asarray(damped_frequencies, dtype=float),
                              {"units": "Hz", "long_name": "damped frequency Im(lambda)/(2 pi) "
                               "with the scene's damping (0: the root does not oscillate)"})
    ds["damping_ratio"] = ("mode", np.asarray(damping_ratios, dtype=float),
                           {"units": "1", "long_name": "damping ratio -Re(lambda)/|lambda| "
                            "(0 without damping)"})
    ds["damped_eigenvalue_real"] = ("mode", roots.real.copy(),
                                    {"units": "s-1", "long_name": "real part of the damped "
                                     "root lambda of (lambda^2 M + lambda D + K) phi = 0"})
    ds["damped_eigenvalue_imag"] = ("mode", roots.imag.copy(),
                                    {"units": "s-1", "long_name": "imaginary part of the "
                                     "damped root lambda"})
    matched = np.asarray(matched_eigenvalues, dtype=complex)
    ds["matched_eigenvalue_real"] = ("mode", matched.real.copy(),
                                     {"units": "s-1", "long_name": "real part of the damped "
                                      "root whose shape is this mode's (largest MAC)"})
    ds["matched_eigenvalue_imag"] = ("mode", matched.imag.copy(),
                                     {"units": "s-1", "long_name": "imaginary part of the "
                                      "damped root whose shape is this mode's"})
    ds["shape_mac"] = ("mode", np.asarray(shape_mac, dtype=float),
                       {"units": "1", "long_name": "mass-weighted MAC of the mode and its "
                        "damped shape (1: the same shape)"})
    for part in ("real", "imag"):
        ds[f"damped_mode_position_{part}"] = (
            ("mode", "node", "axis"), getattr(np.asarray(damped_shapes, dtype=complex),
                                              part).copy(),
            {"units": "m", "long_name": f"{part} part of the complex damped mode shape "
             "(motion Re(phi e^(lambda t)); modal mass: the whole mass times 1 m2)"})
        ds[f"damped_mode_quaternion_{part}"] = (
            ("mode", "segment", "component"),
            getattr(np.asarray(damped_rotations, dtype=complex), part).copy(),
            {"units": "1", "long_name": f"{part} part of the complex damped mode's "
             "quaternion change"})
    name = result.scene.name
    ds.attrs.update({
        "title": f"rodsim modes of scene {name!r} about its equilibrium",
        "kind": "modes",
        "history": history(f"rodsim.modes(scene {name!r}, count={count})",
                           ds.attrs["date_created"]),
        "rotary_inertia": int(rotary_inertia),
        "modes_message": message,
    })
    return ds
