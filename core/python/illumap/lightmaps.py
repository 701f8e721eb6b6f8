"""UV-space lightmaps from the light at a mesh's corners or at points (numpy; the native
neighbour search for points): rasterized per triangle, grown across the islands' borders.
Row 0 of an image is v = 1 (images are stored top-down)."""

from __future__ import annotations

import numpy as np

__all__ = ["LIGHTMAP_MARGIN", "rasterize_corners", "dilate", "corner_lightmap",
           "surfel_lightmap"]

#: Texels a lightmap's islands are grown by (``dilate``), so that filtering and mipmaps at
#: UV seams read the island's own light, not the empty space around it (Blender's bake margin).
LIGHTMAP_MARGIN = 8


def rasterize_corners(uv: np.ndarray, triangles: np.ndarray, values: np.ndarray,
                      size: int) -> tuple[np.ndarray, np.ndarray]:
    """Rasterize per-corner values in UV space: (rgb (size, size, 3), covered (size, size)),
    row 0 at v = 1 (images are stored top-down).

    ``uv`` (L, 2) per corner, ``triangles`` (T, 3) corner indices, ``values`` (L, 3) per
    corner. A texel whose centre lies inside a triangle takes the corners' values blended by
    its barycentric coordinates there, as Blender interpolates the attribute over a face."""
    uv = np.asarray(uv, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    rgb = np.zeros((size, size, 3), dtype=np.float64)
    covered = np.zeros((size, size), dtype=bool)
    tri_uv = uv[triangles] * size - 0.5          # texel-centre coordinates
    lo = np.clip(np.floor(tri_uv.min(axis=1)).astype(np.int64), 0, size - 1)
    hi = np.clip(np.ceil(tri_uv.max(axis=1)).astype(np.int64), 0, size - 1)
    for t in range(len(triangles)):
        (x0, y0), (x1, y1) = lo[t], hi[t]
        (ax, ay), (bx, by), (cx, cy) = tri_uv[t]
        det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
        if abs(det) < 1e-18:
            continue
        xs, ys = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1))
        l0 = ((by - cy) * (xs - cx) + (cx - bx) * (ys - cy)) / det
        l1 = ((cy - ay) * (xs - cx) + (ax - cx) * (ys - cy)) / det
        l2 = 1.0 - l0 - l1
        eps = -1e-9
        inside = (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
        if not inside.any():
            continue
        c = values[triangles[t]]
        col = l0[inside, None] * c[0] + l1[inside, None] * c[1] + l2[inside, None] * c[2]
        rows = size - 1 - ys[inside]
        rgb[rows, xs[inside]] = col
        covered[rows, xs[inside]] = True
    return rgb, covered


def dilate(rgb: np.ndarray, covered: np.ndarray, margin: int = LIGHTMAP_MARGIN):
    """Grow the covered texels outwards by ``margin`` texels: each empty texel beside covered
    ones takes their mean, ring by ring. Returns (rgb, filled mask)."""
    rgb = rgb.copy()
    filled = covered.copy()
    h, w = filled.shape
    for _ in range(max(0, int(margin))):
        total = np.zeros_like(rgb)
        count = np.zeros((h, w), dtype=np.float64)
        padded = np.pad(rgb * filled[:, :, None], ((1, 1), (1, 1), (0, 0)))
        mask = np.pad(filled.astype(np.float64), 1)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dy == 0 and dx == 0:
                    continue
                total += padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
                count += mask[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        grow = (~filled) & (count > 0)
        if not grow.any():
            break
        rgb[grow] = total[grow] / count[grow][:, None]
        filled = filled | grow
    return rgb, filled


def corner_lightmap(uv, triangles, values, size: int = 256,
                    margin: int = LIGHTMAP_MARGIN) -> np.ndarray:
    """A UV-space lightmap (size, size, 4) from per-corner light: the triangles rasterized
    (``rasterize_corners``), then grown by ``margin`` texels across the islands' borders
    (``dilate``). Alpha is 1 on the islands and their margin, 0 elsewhere."""
    rgb, covered = rasterize_corners(uv, triangles, values, size)
    rgb, filled = dilate(rgb, covered, margin)
    img = np.zeros((size, size, 4), dtype=np.float32)
    img[:, :, :3] = np.where(filled[:, :, None], rgb, 0.0)
    img[:, :, 3] = filled
    return img


def surfel_lightmap(uv: np.ndarray, values: np.ndarray, size: int = 256,
                    k: int = 8) -> np.ndarray:
    """A UV-space lightmap (size, size, 4) from values at points with UV coordinates (N, 2):
    each texel centre takes the inverse-distance blend of the ``k`` points nearest in UV space.
    Texels farther than twice the typical point spacing (in UV) from any point lie outside
    the UV islands: RGB 0 and alpha 0 (alpha 1 inside). Islands that touch in UV space but not
    on the surface can blend along their borders (a known limit of UV-space interpolation)."""
    from .neighbours import knn
    uv = np.asarray(uv, dtype=np.float64)
    pts = np.column_stack([uv, np.zeros(len(uv))])
    centres = (np.arange(size) + 0.5) / size
    tu, tv = np.meshgrid(centres, centres[::-1])
    texels = np.column_stack([tu.ravel(), tv.ravel(), np.zeros(tu.size)])
    _, self_dist = knn(pts, pts, min(2, len(pts)))
    spacing = float(np.median(self_dist[:, -1])) if len(pts) > 1 else 1.0
    idx, dist = knn(pts, texels, min(k, len(pts)))
    w = 1.0 / (dist ** 2 + (0.1 * spacing) ** 2 + 1e-30)
    w /= w.sum(axis=1, keepdims=True)
    rgb = np.einsum("mk,mkc->mc", w, np.asarray(values, dtype=np.float64)[idx])
    inside = dist[:, 0] <= 2.0 * max(spacing, 0.5 / size)
    img = np.zeros((size * size, 4), dtype=np.float32)
    img[inside, :3] = rgb[inside]
    img[inside, 3] = 1.0
    img = img.reshape(size, size, 4)
    return img
