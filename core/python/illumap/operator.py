"""The transport operator y = F·V·x, wrapping the native ``illumap._core.Operator``.

For receiver i and source j (docs/architecture.md, "The kernel, exactly")::

    P_ij = A_j · max(0, cos_i) · max(0, cos_j) / (π r²)        (the bare point kernel)

With ``near_field="disc"`` (default), close pairs (π r² ≤ 2·16·(A_i + A_j)/2) use the exact
form factor to a regular octagon of the surfel's area instead, symmetrized and blended into P;
``near_field="point"`` keeps the bare kernel everywhere, to show where it fails. ``apply(x)`` returns the gathered ``Σ_j F_ij V_ij x_j`` per colour channel, before
albedo. V is the visibility: ``"none"`` (V = 1), ``"exact"`` (rays against the surfels as
oriented discs, Embree 3) or ``"seed"`` (the talk's point-based visibility); see
:class:`TransportOperator` and core/src/visibility/visibility.hpp.

The default expansion parameters live here, in one place: :data:`DEFAULT_ORDER`,
:data:`DEFAULT_THETA`, :data:`DEFAULT_LEAF_SIZE`.
"""

from __future__ import annotations

import time

import numpy as np

from . import conservation, limits
from .array_checks import check_values, first_nonfinite_row
from .surfels import InputError, Surfels
from ._progress import ProgressGuard

try:  # the native module is built separately (core/src); keep the package importable without it
    from . import _core
except ImportError as _exc:  # pragma: no cover - depends on the build
    _core = None
    _CORE_IMPORT_ERROR = _exc
else:
    _CORE_IMPORT_ERROR = None
    # The native checks and the table are one: a module built with other limits is refused.
    limits.check_native(_core.LIMITS)

__all__ = [
    "TransportOperator", "DEFAULT_METHOD", "DEFAULT_ORDER", "DEFAULT_THETA",
    "DEFAULT_LEAF_SIZE", "DEFAULT_NEAR_FIELD", "DEFAULT_VISIBILITY", "METHODS",
    "NEAR_FIELDS", "VISIBILITIES", "MAX_ORDER",
]

# --- defaults: the one place to change them -------------------------------------------------
DEFAULT_METHOD = "fmm"
DEFAULT_ORDER = 3  # p = 3, θ = 0.5: 5e-4 relative error, 2.9 s per apply at 1M surfels (bench_fmm)
DEFAULT_THETA = 0.5
DEFAULT_LEAF_SIZE = 32
DEFAULT_NEAR_FIELD = "disc"
DEFAULT_VISIBILITY = "none"

METHODS = ("fmm", "direct")
NEAR_FIELDS = ("disc", "point")
#: The highest FMM expansion order (``illumap.limits``, the native core's kMaxOrder).
MAX_ORDER = limits.limit("order").high

#: Visibility modes: name -> (implemented, reciprocal). A reciprocal mode has V_ij = V_ji, which
#: keeps diag(A)·F·V symmetric so that CG applies. Both native methods evaluate V(i, j) in the
#: canonical order (min(i,j), max(i,j)) and classify node pairs symmetrically, and the traversal
#: mirrors the lists of (t, s) and (s, t), so both are reciprocal.
VISIBILITIES = {
    "none": (True, True),
    "seed": (True, True),
    "exact": (True, True),
}
#: How ``hemisphere_hits`` bounds the rows: "rows" scales each receiver's row on its own
#: (one application, exact; the operator is no longer reciprocal, so GMRES solves it);
#: "symmetric" scales rows and columns alike, diag(d) K diag(d) (Sinkhorn: tens of
#: applications; reciprocal, so CG solves it).
HEMISPHERE_BALANCES = ("rows", "symmetric")
VISIBILITY_LEAF_MODES = ("per_pair", "per_pair_all", "fractional", "binary")
#: Shapes a surfel occludes with (``visibility_shape``, ``Occluders(shape=)``), each of its
#: disc's area.
OCCLUDER_SHAPES = ("disc", "quad", "octagon")

#: Visibility keywords and their defaults (see TransportOperator for their meaning and units).
VISIBILITY_DEFAULTS = {
    "visibility_leaf_mode": "per_pair",
    "visibility_samples": 8,
    "coverage": 1.3,
    "visibility_shape": "disc",
    "endpoint_offset": 0.05,
    "seed_delta": 2.0,
    "seed_k": 8,
    "seed_t1": 0.5,
    "seed_t2": 0.5,
    "seed_t3": 0.5,
    "seed_leaf_points": 8,
    "seed_binary_pairs": True,
}

#: The keywords ``solve`` forwards to TransportOperator.
OPERATOR_KEYWORDS = ("method", "order", "theta", "leaf_size", "near_field", "visibility",
                     "threads", "occluder_triangles", "hemisphere_hits",
                     "hemisphere_bound", "hemisphere_balance", "hemisphere_fill",
                     "hemisphere_enclosed", "hemisphere_links", "occluders", "scan_surfels") \
    + tuple(VISIBILITY_DEFAULTS)


def _require_core():
    if _core is None:
        raise ImportError(
            "illumap._core, the native module, is not available "
            f"({_CORE_IMPORT_ERROR}); build it with `pip install --no-build-isolation ./core`"
        )
    return _core


def _check_choice(name, value, choices):
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{name}: expected one of {list(choices)}, got {value!r}")
    return value


def _check(name, value):
    """``value`` inside its limit (``illumap.limits``) as int or float, or an InputError
    naming it; never the native module's raw type error."""
    return limits.limit(name).check(value, InputError)


def validate_keywords(*, method=DEFAULT_METHOD, order=DEFAULT_ORDER, theta=DEFAULT_THETA,
                      leaf_size=DEFAULT_LEAF_SIZE, near_field=DEFAULT_NEAR_FIELD,
                      visibility=DEFAULT_VISIBILITY, threads=0, occluder_triangles=None,
                      hemisphere_hits=None, hemisphere_bound=None, hemisphere_balance="rows",
                      hemisphere_fill=True, hemisphere_enclosed=None, hemisphere_links=None,
                      occluders=None, scan_surfels=None, **visibility_keywords) -> dict:
    """Check the operator keywords (raises InputError) and return them normalized."""
    out = {}
    _check_triangles(occluder_triangles)
    out["method"] = _check_choice("method", method, METHODS)
    out["order"] = _check("order", order)
    out["theta"] = _check("theta", theta)
    out["leaf_size"] = _check("leaf_size", leaf_size)
    out["near_field"] = _check_choice("near_field", near_field, NEAR_FIELDS)
    out["visibility"] = _check_choice("visibility", visibility, tuple(VISIBILITIES))
    if not VISIBILITIES[out["visibility"]][0]:
        raise InputError(f"visibility={out['visibility']!r} is not implemented")
    out["threads"] = _check("threads", threads)
    _check_choice("hemisphere_balance", hemisphere_balance, HEMISPHERE_BALANCES)
    if not isinstance(hemisphere_fill, (bool, np.bool_)):
        raise InputError(f"hemisphere_fill: expected a bool, got {hemisphere_fill!r}")
    unknown = set(visibility_keywords) - set(VISIBILITY_DEFAULTS)
    if unknown:
        raise TypeError(f"unexpected keyword(s) {sorted(unknown)}")
    v = dict(VISIBILITY_DEFAULTS)
    v.update(visibility_keywords)
    out["visibility_leaf_mode"] = _check_choice("visibility_leaf_mode",
                                                v["visibility_leaf_mode"], VISIBILITY_LEAF_MODES)
    out["visibility_shape"] = _check_choice("visibility_shape", v["visibility_shape"],
                                            OCCLUDER_SHAPES)
    for name in ("visibility_samples", "seed_k", "seed_leaf_points", "coverage",
                 "endpoint_offset", "seed_delta", "seed_t1", "seed_t2", "seed_t3"):
        out[name] = _check(name, v[name])
    if not isinstance(v["seed_binary_pairs"], (bool, np.bool_)):
        raise InputError(f"seed_binary_pairs: expected a bool, got {v['seed_binary_pairs']!r}")
    out["seed_binary_pairs"] = bool(v["seed_binary_pairs"])
    return out


def core_origin(positions: np.ndarray) -> np.ndarray:
    """The point the native core measures positions from: their median, snapped to a grid of
    a power of two at least their interquartile spread (the bulk's size). A few surfels more
    or less (an object far away) then leave it where it is, and with it, to the bit, every
    coordinate the core sees of the others (subtracting a multiple of a power of two at least
    the coordinates' own rounding step is exact): their tree, lists and light are as without
    them. (0, 0, 0) for no surfels; the median itself where the bulk has no spread."""
    if len(positions) == 0:
        return np.zeros(3)
    median = np.median(positions, axis=0)
    lo, hi = np.percentile(positions, [25.0, 75.0], axis=0)
    spread = float(np.max(hi - lo))
    if not spread > 0.0:
        return median
    step = 2.0 ** np.ceil(np.log2(spread))
    snapped = np.round(median / step) * step
    return snapped if np.all(np.isfinite(snapped)) else median


def _check_scan_surfels(scan, n: int) -> np.ndarray | None:
    """``scan_surfels`` as the native operator takes it ((N,) float64 cloud numbers), or
    None."""
    if scan is None:
        return None
    ids = np.asarray(scan)
    if ids.shape != (n,):
        raise InputError(f"scan_surfels: expected shape ({n},), got {ids.shape}")
    if ids.dtype == bool:
        ids = ids.astype(np.int64)
    if not np.issubdtype(ids.dtype, np.integer) or (ids < 0).any() or (ids >= 2 ** 32).any():
        raise InputError("scan_surfels: expected integers in [0, 2^32) (0: not a scan)")
    return np.ascontiguousarray(ids, dtype=np.float64)


def _check_enclosed(enclosed, links, n: int) -> np.ndarray | None:
    """``hemisphere_enclosed`` as a (N,) bool array, or None; an InputError if it is not one
    or ``links`` (``sealing.Links``) do not fit it."""
    if enclosed is None:
        return None
    array = np.asarray(enclosed)
    if array.dtype != np.bool_ or array.shape != (n,):
        raise InputError(f"hemisphere_enclosed: expected a bool array of shape ({n},), "
                         f"got {array.dtype} {array.shape}")
    if links is not None:
        known = getattr(links, "known", None)
        if known is None or len(known) != n:
            raise InputError(f"hemisphere_links: expected illumap.sealing.Links for {n} surfels")
    return array.copy()


def _check_triangles(triangles) -> np.ndarray | None:
    """``occluder_triangles`` as C-contiguous float64 (T, 3, 3), finite, or None."""
    if triangles is None:
        return None
    t = np.ascontiguousarray(triangles, dtype=np.float64)
    if t.ndim != 3 or t.shape[1:] != (3, 3) or len(t) == 0:
        raise InputError(f"occluder_triangles: expected shape (T, 3, 3) with T >= 1, got {t.shape}")
    bad = first_nonfinite_row(t)
    if bad >= 0:
        raise InputError(f"occluder_triangles[{bad}] is not finite")
    return t


class TransportOperator:
    """The gathered transport ``y_i = Σ_j F_ij V_ij x_j`` over validated surfels.

    Parameters
    ----------
    surfels : Surfels
    method : "fmm" | "direct"
        "direct" is the exact O(N²) reference; "fmm" reproduces it up to expansion error.
    order : int
        Expansion order p of the FMM (0 … MAX_ORDER); ignored by "direct".
    theta : float
        Opening criterion of the dual-tree traversal, in (0, 1).
    leaf_size : int
        Maximum surfels per octree leaf.
    near_field : "disc" | "point"
        Bounded point-to-disc rule (default) or the bare point kernel.
    visibility : "none" | "exact" | "seed"
        Occlusion V_ij. "none": V = 1. "exact": one ray per surfel pair against every surfel
        as an oriented disc (Embree 3). "seed": the talk's point-based visibility (occluders
        near the segment attenuate it). Computed once here and reused by every apply. In the
        FMM, node pairs are classified valid / invalid / partial from sampled rays (invalid:
        dropped; partial: pushed down to the children; a partial leaf pair gets a sampled
        fraction in M2L, or per-pair V in the near field); this rests on samples and can
        misclassify pairs with a small blocked part. "direct" applies V per pair (O(N²) rays
        once, small N only); ``apply_rows`` always applies V per pair.
    visibility_leaf_mode : "per_pair" | "per_pair_all" | "fractional" | "binary"
        What a partial leaf pair gets: per-pair V in the near field and the sampled fraction
        far away (default; a far pair with a point of a scan, ``scan_surfels``, takes a
        sampled fraction per point of its wider leaf instead, so that one point's view
        through a hole is not lent to the whole leaf); per-pair V everywhere ("per_pair_all": far partial leaf pairs move
        from M2L to the near field, so shadow edges inside a leaf are kept, at the cost of
        |t|·|s| rays and 1 byte each per such pair); the fraction everywhere; or all-or-nothing
        (the talk).
    visibility_samples : int
        Facing point pairs sampled per node pair to classify it (default 8).
    coverage : float
        "exact": disc radius = coverage·sqrt(A/π), in units of the surfel's own spacing.
        1 leaves gaps between discs (light leaks through walls); larger closes them but discs
        overhang edges (over-occlusion). Default 1.3 (a square grid is covered from 1.2533).
    occluder_triangles : (T, 3, 3) array or None
        "exact": the scene's own triangles (world corners, metres) as the occluders instead
        of shapes made from the surfels (``coverage`` and ``visibility_shape`` then only size
        nothing; the surfels' own radii trim the pair rays' ends).
    visibility_shape : "disc" | "quad" | "octagon"
        "exact": occluders as oriented discs, or squares or regular octagons of equal area
        (faster rays; the octagon is within 0.974-1.054 × the disc's radius).
    endpoint_offset : float
        "exact": occluders crossing the segment within endpoint_offset × r of an endpoint's
        tangent plane are ignored (r: the endpoint's disc radius; along the segment that is
        endpoint_offset × r / cos, at most 2 r): own disc, coincident duplicates, neighbours'
        discs on curved surfaces. Default 0.05.
    seed_delta : float
        "seed": an occluder k attenuates a segment within Δ_k = seed_delta·sqrt(A_k/π) of it
        (units of the occluder's own spacing, so scale-free). Default 2.0.
    seed_k : int
        "seed": at most k closest occluders multiply their transmissions. Default 8.
    seed_t1, seed_t2, seed_t3 : float in [0, 1]
        "seed" thresholds: point–point (product of transmissions > t1), point–leaf (share of
        the leaf's points visible > t2), leaf–leaf (share > t3). Default 0.5 each.
    seed_leaf_points : int
        "seed": points sampled per leaf in the leaf–leaf test. Default 8.
    seed_binary_pairs : bool
        "seed": per-pair V is 0/1 after t1 (default) or the attenuation product.
    hemisphere_hits : (N,) array in [0, 1] or None
        Each surfel's measured share of its hemisphere whose first hit is a surface that
        sends light (``illumap.conservation.hemisphere_hits``). Given, every row of the
        operator is scaled to sum to that share and never more (``hemisphere_balance``;
        ``stats`` reports it): light is conserved on overlapping, coincident and buried
        surfels, and the solve cannot create light. None: the kernel's own rows.
    hemisphere_bound : (N,) array in [0, 1] or None
        With ``hemisphere_hits``: rows may lie anywhere in [hits, bound] (default: bound =
        hits, rows equal to their share).
    hemisphere_balance : "rows" | "symmetric"
        With ``hemisphere_hits``: scale each row on its own (default; one application, and
        GMRES solves) or rows and columns alike (Sinkhorn; reciprocal, CG solves).
    hemisphere_enclosed : (N,) bool array or None
        Surfels that the light of the sky and the lamps reaches along first hits only through
        a slit, or not at all (``conservation.Hemisphere.enclosed``). With
        ``hemisphere_hits``, ``hemisphere_links`` and ``hemisphere_balance="rows"`` their
        rows are the first-hit transport's (``sealing.Links``), which leaks only where their
        rays do, in place of the kernel's, whose 1% leaks across intersection lines light a
        pocket that should stay dark. Without links (or with the symmetric balance) their
        rows and columns of every part of the operator are 0: sealed, their light is 0.
    hemisphere_links : sealing.Links or None
        The first-hit transport of the hemisphere rays (``Hemisphere.links``).
    hemisphere_fill : bool
        With ``hemisphere_hits``, ``hemisphere_balance="rows"`` and ``occluder_triangles``
        (default True): a row that stays short of its share even scaled by
        ``conservation.MAX_SCALE`` gets the rest from the first hits of its own rays
        (``conservation.first_hit_fill``), so that every row sums to its share exactly.
    occluders : receivers.MeshOccluders or None
        The caller's ray scene of ``occluder_triangles`` (the gather's; built on the same
        array, else not taken), which exact visibility and the fill cast against instead of
        building their own (a scan's splats: ~1 GB and seconds per 1M points each).
    scan_surfels : (N,) int array or None
        The point cloud (scan) each surfel stands for a point of, 1, 2, …, or 0 (a mesh's
        surfel). A close pair of facing surfels (normals opposed, each centre within half
        the other's radius of its plane) of a scan and another object takes its near-field
        form factors averaged over the receiver's disc, and no visibility test between the two
        centres, which in a gap under a scan meets the scan's own bumpy splats
        (``core/src/transport/near_field.hpp``). None: no scan.
    threads : int
        Worker threads, 0 = all hardware threads.
    progress : callable(fraction, phase) -> bool | None, optional
        Called while the tree and lists are built; returning False or raising cancels
        with :class:`illumap.Cancelled`.
    """

    def __init__(self, surfels: Surfels, method: str = DEFAULT_METHOD, *,
                 order: int = DEFAULT_ORDER, theta: float = DEFAULT_THETA,
                 leaf_size: int = DEFAULT_LEAF_SIZE, near_field: str = DEFAULT_NEAR_FIELD,
                 visibility: str = DEFAULT_VISIBILITY, threads: int = 0, progress=None,
                 occluder_triangles=None, hemisphere_hits=None, hemisphere_bound=None,
                 hemisphere_balance: str = "rows", hemisphere_fill: bool = True,
                 hemisphere_enclosed=None, hemisphere_links=None, occluders=None,
                 scan_surfels=None, **visibility_keywords):
        if not isinstance(surfels, Surfels):
            raise InputError(
                f"surfels: expected an illumap.Surfels, got {type(surfels).__name__} "
                "(build one with illumap.Surfels(positions, normals, areas, albedo, emission))"
            )
        checked = validate_keywords(method=method, order=order, theta=theta,
                                    leaf_size=leaf_size, near_field=near_field,
                                    visibility=visibility, threads=threads,
                                    **visibility_keywords)
        self.method = checked["method"]
        self.order = checked["order"]
        self.theta = checked["theta"]
        self.leaf_size = checked["leaf_size"]
        self.near_field = checked["near_field"]
        self.visibility = checked["visibility"]
        self.threads = checked["threads"]
        self._reciprocal_visibility = VISIBILITIES[self.visibility][1]
        self.visibility_options = {k: checked[k] for k in VISIBILITY_DEFAULTS}
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r}")
        self.surfels = surfels
        self.occluder_triangles = _check_triangles(occluder_triangles)
        # The caller's ray scene of these very triangles (the same array), or none.
        t = self.occluder_triangles
        self._fill_occluders = occluders if (
            occluders is not None and t is not None and occluders.corners.shape == t.shape
            and occluders.corners.ctypes.data == t.ctypes.data) else None
        # The kernel sees only differences of positions: the native core gets them relative to
        # their median (snapped: ``core_origin``), so tree bounds, facing tests and rays keep
        # their precision wherever the scene sits.
        self.origin = core_origin(surfels.positions)
        core = _require_core()
        guard = ProgressGuard(progress)
        with guard:
            self._op = core.Operator(
                np.ascontiguousarray(surfels.positions - self.origin), surfels.normals, surfels.areas,
                method=self.method, order=self.order, theta=self.theta,
                leaf_size=self.leaf_size, near_field=self.near_field, threads=self.threads,
                progress=guard.native_callback(), visibility=self.visibility,
                # The core takes the origin off each corner itself (the same doubles): no
                # shifted copy of a scan's splat triangles (0.86 GB at 1M points).
                occluder_triangles=(None if self.occluder_triangles is None
                                    else self.occluder_triangles.reshape(-1, 9)),
                occluder_shift=np.ascontiguousarray(self.origin, dtype=np.float64).reshape(3),
                occluder_scene=(None if self._fill_occluders is None
                                else self._fill_occluders._scene),   # one BVH per run
                scan_surfels=_check_scan_surfels(scan_surfels, surfels.n),
                **self.visibility_options,
            )
        self.balance = None
        self.fill = None          # conservation.Fill: the share scaled rows cannot reach
        self._fill_seconds = 0.0
        self._scale = None        # left scale (N, 1): rows
        self._right = None        # right scale (N, 1): columns ("symmetric" only)
        self._coupled = None      # (N, 1) 1.0 / 0.0: surfels not sealed (enclosed, no links)
        self.enclosed = _check_enclosed(hemisphere_enclosed, hemisphere_links, surfels.n)
        self.links = hemisphere_links if self.enclosed is not None else None
        raw_apply = self._op.apply
        # The kernel couples no enclosed surfel, as a receiver or as a source: with links
        # their rows are their first hits' (the fill, which sees every surfel), and an open
        # surfel whose rays reach them would reach them through the slit only. The kernel
        # itself also couples across the surface a surfel stands on (a face beside an
        # eyeball to the eyeball's sealed back): Suzanne's face surfels beside the eyes sent
        # 40% of their scaled rows there and read 0.55 where their first hits give 0.95.
        if self.enclosed is not None and self.enclosed.any():
            self._coupled = (~self.enclosed).astype(np.float64)[:, None]
            raw_apply = self._coupled_apply
        self.hemisphere_balance = _check_choice("hemisphere_balance", hemisphere_balance,
                                                HEMISPHERE_BALANCES)
        if hemisphere_hits is not None:
            hits = conservation.check_hits(hemisphere_hits, surfels.n)
            bound = (None if hemisphere_bound is None
                     else conservation.check_hits(hemisphere_bound, surfels.n, "hemisphere_bound"))
            if self.links is not None:
                hits = hits * ~self.enclosed      # their rows: the first hits'
                # An open surfel's rays that meet enclosed surfels take them from its first
                # hits too (its links; a surfel with a sky share of its own casts none, and
                # light reaches nothing it sees first well enough to leave it enclosed):
                # its kernel row carries the rest of its share.
                hits = np.maximum(hits - self._to_enclosed(), 0.0)
            if self._coupled is not None:
                # A sealed surfel's row is 0, and an open one's share is carried by open ones.
                hits = hits * self._coupled[:, 0]
                bound = None if bound is None else bound * self._coupled[:, 0]
            if self.hemisphere_balance == "rows":
                self.balance = conservation.scale_rows(raw_apply, hits, bound=bound)
                self._scale = self.balance.scale[:, None]
                if hemisphere_fill and self.occluder_triangles is not None:
                    start = time.perf_counter()
                    self.fill = self._first_hit_fill(hits)
                    self._fill_seconds = time.perf_counter() - start
                if self.links is not None:
                    self._first_hit_rows()
            else:
                # Surfels that reflect nothing keep their scale (conservation.balance).
                self.balance = conservation.balance(raw_apply, hits, bound=bound,
                                                    frozen=~(surfels.albedo.max(axis=1) > 0.0))
                self._scale = self._right = self.balance.scale[:, None]

    def _first_hit_rows(self) -> None:
        """The enclosed surfels' rows from the first-hit transport ``self.links``, added to
        the fill."""
        w = self.links
        take = self.enclosed[w.rows] | self.enclosed[w.cols]
        rows, cols, weights = w.rows[take], w.cols[take], w.weights[take]
        if self.fill is not None:
            rows = np.r_[self.fill.rows, rows]
            cols = np.r_[self.fill.cols, cols]
            weights = np.r_[self.fill.weights, weights]
        filled = 0 if self.fill is None else self.fill.filled
        missing = 0.0 if self.fill is None else self.fill.missing
        self.fill = conservation.Fill(rows, cols, weights, filled, missing)
        self.balance.rows_after = self.balance.rows_after + np.bincount(
            w.rows[take], w.weights[take], minlength=self.n)

    def _to_enclosed(self) -> np.ndarray:
        """(N,) the share of each open surfel's first hits (its row of ``self.links``) that
        meets enclosed surfels; 0 for the enclosed."""
        w = self.links
        take = self.enclosed[w.cols] & ~self.enclosed[w.rows]
        return np.bincount(w.rows[take], w.weights[take], minlength=self.n)

    def _coupled_apply(self, x: np.ndarray, progress=None) -> np.ndarray:
        """The native application with sealed rows and columns 0."""
        return self._op.apply(np.ascontiguousarray(x * self._coupled),
                              progress=progress) * self._coupled

    def _first_hit_fill(self, hits: np.ndarray):
        """``conservation.first_hit_fill`` for the rows short of their share, or None."""
        missing = hits - self.balance.rows_after
        rows = np.flatnonzero((missing > conservation.FILL_MIN_MISSING) & (hits > 0.0))
        if len(rows) == 0:
            return None
        from .receivers import MeshOccluders
        occluders = self._fill_occluders
        if occluders is None:
            occluders = MeshOccluders(self.occluder_triangles, threads=self.threads)
        self._fill_occluders = None   # the caller's to keep or let go
        fill = conservation.first_hit_fill(occluders, self.surfels.positions,
                                           self.surfels.normals, rows, missing[rows])
        self.balance.rows_after = self.balance.rows_after + np.bincount(
            fill.rows, fill.weights, minlength=self.n)
        return fill if len(fill.rows) else None

    @property
    def n(self) -> int:
        return self.surfels.n

    @property
    def shape(self):
        return (self.n, self.n)

    def apply(self, values, progress=None) -> np.ndarray:
        """Return ``Σ_j F_ij V_ij values_j`` (N×3) for finite N×3 ``values``."""
        values = check_values(values, self.n)
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r}")
        guard = ProgressGuard(progress)
        with guard:
            return self.apply_native(values, guard.native_callback())

    __call__ = apply

    def apply_native(self, values: np.ndarray, progress=None) -> np.ndarray:
        """``apply`` without its checks, for callers that checked ``values`` (N×3 float64
        C-contiguous, finite) themselves: the native application with the hemisphere's
        scales. ``progress``: a native callback."""
        given = values                 # the first hits (the fill) see every surfel
        if self._coupled is not None:
            values = np.ascontiguousarray(values * self._coupled)
            if self.links is None:
                given = values
        if self._scale is None:
            y = self._op.apply(values, progress=progress)
            return y if self._coupled is None else y * self._coupled
        x = values if self._right is None else np.ascontiguousarray(values * self._right)
        y = self._op.apply(x, progress=progress) * self._scale
        return y if self.fill is None else y + self.fill.apply(given)

    def apply_rows(self, values, rows) -> np.ndarray:
        """Exact direct sums for the selected receivers ``rows`` (int array): len(rows)×3."""
        values = check_values(values, self.n)
        rows = np.ascontiguousarray(rows, dtype=np.int64).ravel()
        if rows.size and (rows.min() < 0 or rows.max() >= self.n):
            k = int(np.flatnonzero((rows < 0) | (rows >= self.n))[0])
            raise InputError(f"rows[{k}] = {rows[k]} is out of range [0, {self.n})")
        given = values
        if self._coupled is not None:
            values = np.ascontiguousarray(values * self._coupled)
            if self.links is None:
                given = values
        if self._scale is None:
            y = self._op.apply_rows(values, rows)
            return y if self._coupled is None else y * self._coupled[rows]
        x = values if self._right is None else np.ascontiguousarray(values * self._right)
        y = self._op.apply_rows(x, rows) * self._scale[rows]
        return y if self.fill is None else y + self.fill.apply_rows(given, rows)

    @property
    def symmetric(self) -> bool:
        """True when diag(A)·F·V is symmetric (reciprocal kernel and visibility): CG applies."""
        one_sided = self._scale is not None and self._right is None
        return bool(self._op.symmetric) and self._reciprocal_visibility and not one_sided

    @property
    def stats(self) -> dict:
        """Build statistics. With visibility: ``visibility_{valid,invalid,partial}_per_level``
        (the model's classify() calls per level max(level(a), level(b)); the FMM classifies
        each unordered node pair once),
        ``lists_{valid,invalid,partial}_per_level`` (ordered pairs the traversal queried),
        ``visibility_queries`` (rays or point_visible calls), ``visibility_no_facing``,
        ``visibility_blocks`` / ``visibility_block_pairs`` (per-pair blocks computed),
        ``visibility_m2l_weighted`` (partial far leaf pairs kept in M2L with their sampled
        fraction), ``visibility_p2p_blocks`` / ``visibility_block_bytes`` (near pairs with
        per-pair V, 8 bits per pair), ``visibility_blocked_pairs`` (direct method),
        ``visibility_bytes``, ``time_build_visibility``, and the visibility keywords
        (``visibility_leaf_mode``, ``visibility_samples``, ``coverage``, …)."""
        stats = dict(self._op.stats)
        stats.update(method=self.method, order=self.order, theta=self.theta,
                     leaf_size=self.leaf_size, near_field=self.near_field,
                     visibility=self.visibility, n=self.n)
        if self.visibility != "none":
            stats.update(self.visibility_options)
        if self.balance is not None:
            stats.update(self.balance.stats(), hemisphere_balance=self.hemisphere_balance)
            if self.enclosed is not None:
                stats.update(hemisphere_enclosed=int(self.enclosed.sum()))
            if self.links is not None:
                stats.update(time_hemisphere_links=float(self.links.seconds))
            if self.fill is not None:
                stats.update(hemisphere_fill_rows=self.fill.filled,
                             hemisphere_fill_entries=int(len(self.fill.rows)),
                             hemisphere_fill_share=self.fill.missing,
                             time_hemisphere_fill=self._fill_seconds)
        return stats

    def keywords(self) -> dict:
        """The keywords this operator was built with."""
        out = dict(method=self.method, order=self.order, theta=self.theta,
                   leaf_size=self.leaf_size, near_field=self.near_field,
                   visibility=self.visibility, threads=self.threads)
        if self.visibility != "none":
            out.update(self.visibility_options)
        return out

    def __repr__(self) -> str:
        return (f"TransportOperator(N={self.n}, method={self.method!r}, order={self.order}, "
                f"theta={self.theta}, leaf_size={self.leaf_size}, "
                f"near_field={self.near_field!r}, visibility={self.visibility!r})")
