"""Scores of per-vertex results against the Cycles reference (numpy only)."""

from __future__ import annotations

import numpy as np


def relative_rms(values: np.ndarray, reference: np.ndarray) -> float:
    """sqrt(Σ|x − r|²) / sqrt(Σ|r|²) over all vertices and channels (dimensionless).
    ``values`` and ``reference`` are (V, 3) outgoing radiance, or anything of equal shape."""
    x = np.asarray(values, dtype=np.float64)
    r = np.asarray(reference, dtype=np.float64)
    if x.shape != r.shape:
        raise ValueError(f"shapes differ: {x.shape} against {r.shape}")
    return float(np.sqrt(np.sum((x - r) ** 2) / np.sum(r ** 2)))


def per_object(values: dict[str, np.ndarray], reference: dict[str, np.ndarray],
               positions: dict[str, np.ndarray] | None = None) -> dict[str, dict]:
    """Diagnostics per object name: its relative RMS, mean value and mean reference (RGB mean,
    W/(m² sr)), their ratio, and the worst vertex: largest |x − r| (Euclidean over RGB) and
    where it is (m) when ``positions`` are given."""
    out = {}
    for name, ref in reference.items():
        got = np.asarray(values[name], dtype=np.float64)
        err = np.linalg.norm(got - ref, axis=1)
        worst = int(np.argmax(err))
        mean_got, mean_ref = float(got.mean()), float(ref.mean())
        row = dict(relative_rms=relative_rms(got, ref), mean=mean_got, mean_reference=mean_ref,
                   mean_ratio=mean_got / mean_ref if mean_ref > 0 else float("nan"),
                   max_error=float(err[worst]), vertices=len(ref))
        if positions is not None:
            row["max_error_at"] = [round(float(c), 4) for c in positions[name][worst]]
        out[name] = row
    return out


def stacked(per_name: dict[str, np.ndarray], names: list[str]) -> np.ndarray:
    """The (ΣV, 3) rows of ``per_name`` in the order of ``names``."""
    return np.concatenate([np.asarray(per_name[n], dtype=np.float64) for n in names])
