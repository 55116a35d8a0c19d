"""The force-map LSTM's forward pass in numpy (float32): inference without importing torch.

Importing torch costs about 1.5 s, so `dresslog infer` and evaluation run this instead;
it matches `dresslog.model.network.ForceMapLSTM` to 1e-5 (tests/model/test_model.py).

Public API
----------
``NumpyEstimator(weights)``
    ``weights``: the flat float32 dict of ``ForceMapLSTM.weights()`` / ``load_model``.
    Attributes ``n_points``, ``hidden``, ``layers``, ``input_dim`` (9, or 18 for a
    network that also reads phi's change per step: ``dresslog.model.inputs``; it is fed
    9-D phi either way).

    ``step(phi (9,)) -> (forces (N,), contact (N,))``
        Stateful, one measurement at a time (the paper's real-time use): forces have Eq. 2
        applied, contact is the raw contact map (> 0 means contact). Returns fresh arrays;
        the recurrent work itself allocates nothing. ``reset()`` starts a new sequence.
    ``step_raw(phi (9,)) -> (2N,)``: the same step, unprocessed output; a view of an
        internal buffer that the next step overwrites (copy it to keep it).
    ``run(phi (T, 9) or (B, T, 9)) -> (forces, contact)``
        Whole sequence(s) from a zero state, Eq. 2 applied; does not touch ``step``'s state.
    ``forward(phi) -> (T, 2N) or (B, T, 2N)``: whole sequence(s), unprocessed output.

``expected_shapes(n_points, hidden=50, layers=3, input_dim=9) -> dict[str, tuple]``
    Every weight name and its shape; ``dresslog.model.files`` checks files against it.
``infer_sizes(weights) -> (n_points, hidden, layers, input_dim)``
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from dresslog.errors import ModelError
from dresslog.model.inputs import PHI_DIM, network_inputs, reads_differences
from dresslog.model.postprocess import apply_contact, split_output

F32 = np.float32
_F32_MAX = float(np.finfo(F32).max)


def expected_shapes(
    n_points: int, hidden: int = 50, layers: int = 3, input_dim: int = 9
) -> dict[str, tuple[int, ...]]:
    """Names and shapes of every array a model with these sizes has (torch's names)."""
    shapes: dict[str, tuple[int, ...]] = {}
    for layer in range(layers):
        width = input_dim if layer == 0 else hidden
        shapes[f"lstm.weight_ih_l{layer}"] = (4 * hidden, width)
        shapes[f"lstm.weight_hh_l{layer}"] = (4 * hidden, hidden)
        shapes[f"lstm.bias_ih_l{layer}"] = (4 * hidden,)
        shapes[f"lstm.bias_hh_l{layer}"] = (4 * hidden,)
    shapes["head.weight"] = (2 * n_points, hidden)
    shapes["head.bias"] = (2 * n_points,)
    shapes["input_mean"] = (input_dim,)
    shapes["input_std"] = (input_dim,)
    return shapes


def infer_sizes(weights: Mapping[str, np.ndarray]) -> tuple[int, int, int, int]:
    """(n_points, hidden, layers, input_dim) read from the weight shapes."""
    try:
        four_h, input_dim = weights["lstm.weight_ih_l0"].shape
        n_points = weights["head.weight"].shape[0] // 2
    except (KeyError, ValueError) as err:
        raise ModelError(f"not force-map LSTM weights: {err}") from None
    layers = sum(1 for k in weights if k.startswith("lstm.weight_ih_l"))
    return n_points, four_h // 4, layers, input_dim


def _fused_gates(w: np.ndarray, b: np.ndarray, hidden: int) -> tuple[np.ndarray, np.ndarray]:
    """Reorder torch's gates (i, f, g, o) to (i, f, o, g) and halve the sigmoid rows.

    Then one tanh over all gates gives tanh(x/2) for i, f, o, and sigmoid(x) is
    0.5 * tanh(x/2) + 0.5: exact in float32 because halving is exact.
    """
    i, f, g, o = (slice(k * hidden, (k + 1) * hidden) for k in range(4))
    order = np.r_[i, f, o, g]
    w = w[order].astype(F32)
    b = b[order].astype(F32)
    w[: 3 * hidden] *= 0.5
    b[: 3 * hidden] *= 0.5
    return w, b


class NumpyEstimator:
    """Runs trained force-map LSTM weights on numpy: whole sequences or one step at a time."""

    def __init__(self, weights: Mapping[str, np.ndarray]) -> None:
        self.n_points, self.hidden, self.layers, self.input_dim = infer_sizes(weights)
        self.differences = reads_differences(self.input_dim)
        expected = expected_shapes(self.n_points, self.hidden, self.layers, self.input_dim)
        for name, shape in expected.items():
            if name not in weights or tuple(weights[name].shape) != shape:
                got = tuple(weights[name].shape) if name in weights else "missing"
                raise ModelError(f"weight {name}: expected shape {shape}, got {got}")
        h = self.hidden
        self.mean = np.asarray(weights["input_mean"], F32).copy()
        self.std = np.asarray(weights["input_std"], F32).copy()
        # Whole-sequence path: input and recurrent weights kept apart (input done as one matmul).
        self._w_ih: list[np.ndarray] = []
        self._w_hh: list[np.ndarray] = []
        self._b: list[np.ndarray] = []
        # One-step path: [W_ih | W_hh] fused, applied to a [x, h] slice of one state vector.
        self._w: list[np.ndarray] = []
        for layer in range(self.layers):
            w_ih, b = _fused_gates(
                weights[f"lstm.weight_ih_l{layer}"],
                np.asarray(weights[f"lstm.bias_ih_l{layer}"])
                + np.asarray(weights[f"lstm.bias_hh_l{layer}"]),
                h,
            )
            w_hh, _ = _fused_gates(weights[f"lstm.weight_hh_l{layer}"], np.zeros(4 * h, F32), h)
            self._w_ih.append(np.ascontiguousarray(w_ih.T))
            self._w_hh.append(np.ascontiguousarray(w_hh.T))
            self._b.append(b)
            self._w.append(np.ascontiguousarray(np.concatenate([w_ih, w_hh], axis=1)))
        self._head_w = np.ascontiguousarray(np.asarray(weights["head.weight"], F32))
        self._head_wt = np.ascontiguousarray(self._head_w.T)
        self._head_b = np.asarray(weights["head.bias"], F32).copy()
        self._alloc_step_buffers()

    # -- one step ----------------------------------------------------------------------
    def _alloc_step_buffers(self) -> None:
        h, d = self.hidden, self.input_dim
        # state = [x, h_0, h_1, ..., h_{L-1}]: layer l reads [input, own h] as one contiguous
        # slice (h_{l-1}, already updated this step, then its own previous h_l).
        self._state = np.zeros(d + self.layers * h, F32)
        self._c = [np.zeros(h, F32) for _ in range(self.layers)]
        self._gates = np.zeros(4 * h, F32)
        self._tmp = np.zeros(h, F32)
        self._out = np.zeros(2 * self.n_points, F32)
        self._mask = np.zeros(self.n_points, F32)
        self._phi = np.zeros(PHI_DIM, F32)  # the last step's phi
        self._first = True
        self._slices = []
        for layer in range(self.layers):
            start = 0 if layer == 0 else d + (layer - 1) * h
            width = d if layer == 0 else h
            z = self._state[start : start + width + h]
            self._slices.append((z, self._state[start + width : start + width + h]))

    def reset(self) -> None:
        """Zero the recurrent state: the next step starts a new sequence."""
        self._state[:] = 0.0
        for c in self._c:
            c[:] = 0.0
        self._first = True

    def step_raw(self, phi: np.ndarray) -> np.ndarray:
        """Advance one step; the unprocessed (2N,) output in a reused buffer."""
        finite = (
            np.isfinite(phi).all()  # float32 holds nothing past its range: the cheap check
            if getattr(phi, "dtype", None) == F32
            else (np.abs(phi) <= _F32_MAX).all()  # 1e39 is finite, but not as float32
        )
        if np.shape(phi) != (PHI_DIM,) or not finite:
            # checked before the state moves: one bad step must not poison the ones after
            raise ModelError(
                f"phi must be {PHI_DIM} finite float32 numbers, got {np.asarray(phi)!r}"
            )
        h, d = self.hidden, self.input_dim
        x = self._state[:d]
        if self.differences:  # [phi, its change since the last step], as network_inputs
            now, change = x[:PHI_DIM], x[PHI_DIM:]
            now[:] = phi  # float32 first, as the whole-sequence path
            if self._first:
                change[:] = 0.0
            else:
                np.subtract(now, self._phi, out=change)
            self._phi[:] = now
            self._first = False
            np.subtract(x, self.mean, out=x)
        else:
            np.subtract(phi, self.mean, out=x)
        np.divide(x, self.std, out=x)
        g, tmp = self._gates, self._tmp
        sig, i, f, o, cand = g[: 3 * h], g[:h], g[h : 2 * h], g[2 * h : 3 * h], g[3 * h :]
        for w, b, c, (z, hl) in zip(self._w, self._b, self._c, self._slices, strict=True):
            np.dot(w, z, out=g)
            np.add(g, b, out=g)
            np.tanh(g, out=g)
            np.multiply(sig, 0.5, out=sig)
            np.add(sig, 0.5, out=sig)
            np.multiply(c, f, out=c)
            np.multiply(i, cand, out=tmp)
            np.add(c, tmp, out=c)
            np.tanh(c, out=tmp)
            np.multiply(o, tmp, out=hl)
        np.dot(self._head_w, self._state[d + (self.layers - 1) * h :], out=self._out)
        np.add(self._out, self._head_b, out=self._out)
        return self._out

    def step(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Advance one step: (forces after Eq. 2, raw contact map), both new (N,) arrays."""
        out = self.step_raw(phi)
        n = self.n_points
        forces = np.maximum(out[:n], F32(0.0))
        np.greater_equal(out[n:], 0.0, out=self._mask, casting="unsafe")
        np.multiply(forces, self._mask, out=forces)
        return forces, out[n:].copy()

    # -- whole sequences -----------------------------------------------------------------
    def forward(self, phi: np.ndarray) -> np.ndarray:
        """Unprocessed output for whole sequence(s) (T, 9) or (B, T, 9), from a zero state."""
        with np.errstate(over="ignore"):  # past float32's range: inf, refused below
            phi = np.asarray(phi, F32)
        single = phi.ndim == 2
        if single:
            phi = phi[None]
        if phi.ndim != 3 or phi.shape[-1] != PHI_DIM:
            raise ModelError(f"phi must be (T, {PHI_DIM}) or (B, T, {PHI_DIM})")
        if not np.isfinite(phi).all():
            raise ModelError("phi has NaN or infinite values; the model cannot run on them")
        batch, steps, _ = phi.shape
        h = self.hidden
        seq = (network_inputs(phi, self.differences) - self.mean) / self.std
        for w_ih, w_hh, b in zip(self._w_ih, self._w_hh, self._b, strict=True):
            pre = seq @ w_ih + b  # (B, T, 4H): the input part of every step at once
            out = np.empty((batch, steps, h), F32)
            hl = np.zeros((batch, h), F32)
            c = np.zeros((batch, h), F32)
            g = np.empty((batch, 4 * h), F32)
            tmp = np.empty((batch, h), F32)
            for t in range(steps):
                np.matmul(hl, w_hh, out=g)
                np.add(g, pre[:, t], out=g)
                np.tanh(g, out=g)
                sig = g[:, : 3 * h]
                np.multiply(sig, 0.5, out=sig)
                np.add(sig, 0.5, out=sig)
                np.multiply(c, g[:, h : 2 * h], out=c)
                np.multiply(g[:, :h], g[:, 3 * h :], out=tmp)
                np.add(c, tmp, out=c)
                np.tanh(c, out=tmp)
                np.multiply(g[:, 2 * h : 3 * h], tmp, out=hl)
                out[:, t] = hl
            seq = out
        result = seq @ self._head_wt + self._head_b
        return result[0] if single else result

    def run(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whole sequence(s) from a zero state: (forces after Eq. 2, raw contact map)."""
        forces_u, contact = split_output(self.forward(phi))
        return apply_contact(forces_u, contact), np.ascontiguousarray(contact)
