"""One colour scale for ground truth and estimate: zero is neutral grey, force runs dark to bright.

Zero gets its own colour (not the bottom of the ramp) so that, as in the
paper's figures, the limb shape stays visible and contact stands out.
"""

from __future__ import annotations

import numpy as np

#: Anchor colours of an inferno-like ramp, from the smallest force to `vmax`.
_STOPS = np.array(
    [
        [40, 11, 84],
        [101, 21, 110],
        [159, 42, 99],
        [212, 72, 66],
        [245, 125, 21],
        [250, 193, 39],
        [252, 255, 164],
    ],
    dtype=np.float64,
)
ZERO = np.array([200, 200, 205], dtype=np.uint8)
_LUT = np.stack(
    [
        np.interp(np.linspace(0, 1, 256), np.linspace(0, 1, len(_STOPS)), _STOPS[:, c])
        for c in range(3)
    ],
    axis=1,
).astype(np.uint8)


def heat_colors(forces: np.ndarray, vmax: float) -> np.ndarray:
    """RGB (..., 3) uint8 for force magnitudes (...,); values above `vmax` saturate."""
    forces = np.asarray(forces, dtype=np.float32)
    scale = 255.0 / vmax if vmax > 0 else 0.0
    idx = np.clip(forces * scale, 0, 255).astype(np.uint8)
    out = _LUT[idx]
    out[forces <= 0] = ZERO
    return out


def color_scale(forces: np.ndarray | None, quantile: float = 0.995) -> float | None:
    """A `vmax` from the positive forces, robust to a few spikes; None if there are none."""
    positive = np.zeros(0) if forces is None else forces[forces > 0]
    if not positive.size:
        return None
    return float(max(np.quantile(positive, quantile), 1e-6))


def legend(vmax: float) -> tuple[np.ndarray, list[str]]:
    """The colour key of a map: colours and their labels, from no force to `vmax` (N).

    Grey for no force, the faintest force, then quarters of `vmax` (each the force its
    label gives, so its colour is that force's) up to `vmax`, whose colour every stronger
    force shares.
    """
    quarters = [float(f"{q * vmax:.2g}") for q in (0.25, 0.5, 0.75)]
    forces = np.array([0.0, 1e-6 * vmax, *quarters, vmax])
    labels = ["0 N", "> 0", *(f"{q:g}" for q in quarters), f"{vmax:.3g} N +"]
    return heat_colors(forces, vmax), labels
