"""The iterations that settle ``B = E + ρ∘K(B)`` for :func:`illumap.solver.solve`: Jacobi,
conjugate gradients on the symmetrized system and restarted GMRES, with the monitor that follows
their residuals, error estimate, divergence and progress (the module docstring of
``illumap.solver`` gives the maths and the stopping rules)."""

from __future__ import annotations

import math

import numpy as np

#: Jacobi is declared divergent when its residual rose this many iterations in a row and is above
#: its initial value, or grew by DIVERGENCE_FACTOR over the best seen.
DIVERGENCE_PATIENCE = 30


DIVERGENCE_FACTOR = 1e3


#: CG recomputes the true residual from one more application only when its recurrence's
#: relative residual is below this at the stop: rounding makes the two drift apart by about
#: machine epsilon × iterations × cond(I − M) (≤ 1/(1 − ρ_max)), around 1e-12 here; above
#: it the recurrence's residual is the true one and the application would be wasted.
CONFIRM_BELOW = 1e-8


def _norms(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("ij,ij->j", x, x))


class _Monitor:
    """Relative residual bookkeeping, progress and cancellation for one solve."""

    def __init__(self, e_norm, tol, max_iterations, guard, start_fraction, *,
                 error_tol=None, non_emitting=None, amplification=1.0, emission=None):
        self.e_norm = e_norm
        self.row_sum_cause = ""   # why rows may sum above 1, for warnings (row_sum_cause)
        self.active = e_norm > 0
        self.safe_norm = np.where(self.active, e_norm, 1.0)
        self.tol = tol
        self.error_tol = error_tol
        self.non_emitting = non_emitting
        self.amplification = amplification
        self.emission = emission
        self.first_bounce = 0.0    # RMS of ρ∘K(E) over the non-emitting surfels, once known
        self.first_bounce_values = None   # ρ∘K(E) itself, (N, 3)
        self.max_iterations = max_iterations
        self.guard = guard
        self.start = start_fraction
        self.history = []
        self.iterations = 0
        self.first = None
        self.fraction = start_fraction
        self.applications = 0

    def relative(self, residual_norms):
        return np.where(self.active, residual_norms / self.safe_norm, 0.0)

    def record(self, rel):
        value = float(np.max(rel))
        self.history.append(value)
        if self.first is None:
            self.first = value
        self.update_progress(value)
        return value

    def update_progress(self, value):
        f = self.iterations / max(self.max_iterations, 1)
        if self.first is not None and self.first > self.tol and value > 0 and math.isfinite(value):
            f = max(f, math.log(self.first / value) / math.log(self.first / self.tol))
        f = min(max(f, 0.0), 1.0)
        self.fraction = max(self.fraction, self.start + (1.0 - self.start) * f * 0.999)
        self.guard.check(self.fraction, "solve")

    def _rms(self, x) -> float:
        m = self.non_emitting
        return math.sqrt(float(np.mean(np.square(x[m])))) if m.any() else 0.0

    def set_first_bounce(self, rho_KE) -> None:
        """Record ρ∘K(E), the first bounce, which CG and GMRES compute first."""
        self.first_bounce = self._rms(rho_KE)
        self.first_bounce_values = rho_KE

    def error_bound(self, B, r) -> float:
        """The solver's error bound relative to the radiosity for the iterate B with residual
        r: 1/(1 − ρ_max) · RMS(r) / RMS(B), over the non-emitting surfels (inf for B = 0
        there)."""
        b = self._rms(B)
        if not b > 0:
            return math.inf
        return self.amplification * self._rms(r) / b

    def bounce_gain(self, B) -> float:
        """How much the bounces amplify what the first one carries, as the iterate's own light
        does: RMS(B − E) / RMS(ρ∘K(E)), within [1, 1/(1 − ρ_max)] (the bound without a first
        bounce)."""
        if self.emission is None or not self.first_bounce:
            return self.amplification
        gain = self._rms(B - self.emission) / self.first_bounce
        return min(max(gain, 1.0), self.amplification)

    def error_estimate(self, B, r) -> float:
        """The solver's error estimate relative to the radiosity for the iterate B with
        residual r: the bound with the bounce gain in place of 1/(1 − ρ_max), where a first
        bounce was recorded (CG, GMRES; Jacobi's is the bound). See the module docstring."""
        b = self._rms(B)
        if not b > 0:
            return math.inf
        return self.bounce_gain(B) * self._rms(r) / b

    def done(self, value, B=None, r=None):
        """Converged: the relative residual ``value`` is within tol, or (with ``error_tol``
        and the iterate ``B`` with its residual ``r``) the error estimate is within
        error_tol."""
        if value <= self.tol:
            return True
        return (self.error_tol is not None and B is not None
                and self.error_estimate(B, r) <= self.error_tol)

    def out_of_iterations(self):
        return self.iterations >= self.max_iterations


def _jacobi(K, E, rho, mon: _Monitor):
    B = E.copy()
    best = np.inf
    rising = 0
    previous = np.inf
    warning = None
    while True:
        KB = K(B)
        r = E + rho * KB - B              # true residual of B; also the next Jacobi step
        if mon.first_bounce_values is None:
            mon.first_bounce_values = r   # B = E: ρ∘K(E) (its RMS stays unused: the bound)
        rel = mon.relative(_norms(r))
        value = mon.record(rel)
        if mon.done(value, B, r):
            break
        if not np.isfinite(value):
            warning = (f"jacobi diverged: residual became non-finite after {mon.iterations} "
                       "iterations (spectral radius of ρ·K ≥ 1?)")
            break
        best = min(best, value)
        rising = rising + 1 if value > previous else 0
        previous = value
        if value > DIVERGENCE_FACTOR * best or (
                rising >= DIVERGENCE_PATIENCE and value > mon.history[0]):
            warning = (f"jacobi diverged: relative residual grew to {value:.3g} after "
                       f"{mon.iterations} iterations (best {best:.3g}); the spectral radius of "
                       f"ρ·K is ≥ 1 (row sums of K above 1{mon.row_sum_cause})")
            break
        if mon.out_of_iterations():
            break
        B = B + r
        mon.iterations += 1
    return B, r, warning


def _cg(K, E, rho, areas, mon: _Monitor):
    s = np.sqrt(rho)                      # D^{1/2}
    w = np.sqrt(areas)[:, None]           # W^{1/2}
    inv_w = 1.0 / w
    active_rows = s > 0

    def M(z):                             # (I − M) z
        return z - w * s * K(s * inv_w * z)

    KE = K(E)
    mon.set_first_bounce(rho * KE)
    r = w * s * KE                        # b − (I−M)·0
    z = np.zeros_like(E)
    warning = None
    refreshes = 0
    while True:
        if refreshes:
            mon.history.pop()  # replace the recurrence value by the true residual's
        def converged(value):   # the iterate is formed only where error_tol needs it
            if mon.error_tol is None:
                return mon.done(value)
            return mon.done(value, E + s * inv_w * z, s * inv_w * r)

        p = r.copy()
        rr = np.einsum("ij,ij->j", r, r)
        value = mon.record(mon.relative(_norms(s * inv_w * r)))
        while not converged(value) and not mon.out_of_iterations():
            Ap = M(p)
            pAp = np.einsum("ij,ij->j", p, Ap)
            live = rr > 0
            if np.any(live & ~(pAp > 0)):
                c = int(np.flatnonzero(live & ~(pAp > 0))[0])
                warning = (f"cg stopped: the symmetrized system is not positive definite "
                           f"(pᵀAp = {pAp[c]:.3g} in channel {c}); the operator's row sums "
                           f"exceed 1/ρ{mon.row_sum_cause}")
                break
            alpha = np.where(live, rr / np.where(live, pAp, 1.0), 0.0)
            z += alpha * p
            r -= alpha * Ap
            rr_new = np.einsum("ij,ij->j", r, r)
            beta = np.where(live, rr_new / np.where(live, rr, 1.0), 0.0)
            p = r + beta * p
            rr = rr_new
            mon.iterations += 1
            value = mon.record(mon.relative(_norms(s * inv_w * r)))
            if not math.isfinite(value):
                warning = "cg stopped: the residual became non-finite"
                break
        B = E + s * inv_w * z
        if not warning and math.isfinite(value) and value > CONFIRM_BELOW:
            # r = b − (I − M) z holds for any linear operator up to rounding, which stays
            # orders below this: the recurrence's residual is the true one, no apply needed
            return B, s * inv_w * r, warning
        r_true = E + rho * K(B) - B
        true_value = float(np.max(mon.relative(_norms(r_true))))
        if (warning or mon.done(true_value, B, r_true) or mon.out_of_iterations()
                or refreshes >= 5 or not np.isfinite(true_value)):
            return B, r_true, warning
        # recurrence and true residual drifted apart: restart from the true residual
        refreshes += 1
        r = np.where(active_rows, w * r_true / np.where(active_rows, s, 1.0), 0.0)


def _back_substitute(H, g, k):
    """Solve the k×k upper-triangular H y = g per channel (zero pivots give y = 0)."""
    channels = g.shape[1]
    y = np.zeros((k, channels))
    for c in range(channels):
        for i in range(k - 1, -1, -1):
            d = H[i, i, c]
            acc = g[i, c] - H[i, i + 1:k, c] @ y[i + 1:k, c]
            y[i, c] = acc / d if d != 0 else 0.0
    return y


def _gmres_error_met(mon: _Monitor, x, V, H, g, k: int) -> bool:
    """Whether the iterate after k inner steps already meets ``error_tol``, judged with a
    bound on its residual: |g[k]| per channel is the residual's whole norm, and its RMS over
    the non-emitting surfels is at most that over their count. Never true where the true
    residual would not meet it, so the restart that follows confirms it (without this, GMRES
    tested error_tol only at its restarts and ran twice CG's iterations at a target)."""
    if mon.error_tol is None or k == 0:
        return False
    count = int(np.count_nonzero(mon.non_emitting))
    if count == 0:
        return False
    y = _back_substitute(H, g, k)
    xk = x.copy()
    for i in range(k):
        xk += y[i] * V[i]
    b = mon._rms(xk)
    if not b > 0:
        return False
    r_rms = math.sqrt(float(np.sum(np.square(g[k]))) / (count * g.shape[1]))
    return mon.bounce_gain(xk) * r_rms / b <= mon.error_tol


def _gmres(K, E, rho, mon: _Monitor, restart: int):
    def A(x):
        return x - rho * K(x)

    channels = E.shape[1]
    x = E.copy()
    r = E - A(x)
    mon.set_first_bounce(r)               # x = E: r = ρ∘K(E)
    warning = None
    while True:
        beta = _norms(r)
        value = mon.record(mon.relative(beta))
        if mon.done(value, x, r) or mon.out_of_iterations() or not np.isfinite(value):
            if not np.isfinite(value):
                warning = "gmres stopped: the residual became non-finite"
            return x, r, warning
        safe = np.where(beta > 0, beta, 1.0)
        V = [np.where(beta > 0, r / safe, 0.0)]
        H = np.zeros((restart + 1, restart, channels))
        cs = np.zeros((restart, channels))
        sn = np.zeros((restart, channels))
        g = np.zeros((restart + 1, channels))
        g[0] = beta
        k = 0
        for j in range(restart):
            v = A(V[j])
            for i in range(j + 1):
                h = np.einsum("ij,ij->j", V[i], v)
                H[i, j] = h
                v -= h * V[i]
            hn = _norms(v)
            H[j + 1, j] = hn
            V.append(np.where(hn > 0, v / np.where(hn > 0, hn, 1.0), 0.0))
            for i in range(j):
                t = cs[i] * H[i, j] + sn[i] * H[i + 1, j]
                H[i + 1, j] = -sn[i] * H[i, j] + cs[i] * H[i + 1, j]
                H[i, j] = t
            denom = np.hypot(H[j, j], H[j + 1, j])
            ok = denom > 0
            cs[j] = np.where(ok, H[j, j] / np.where(ok, denom, 1.0), 1.0)
            sn[j] = np.where(ok, H[j + 1, j] / np.where(ok, denom, 1.0), 0.0)
            H[j, j] = denom
            H[j + 1, j] = 0.0
            g[j + 1] = -sn[j] * g[j]
            g[j] = cs[j] * g[j]
            k = j + 1
            mon.iterations += 1
            value = mon.record(mon.relative(np.abs(g[j + 1])))
            if mon.done(value) or mon.out_of_iterations() or _gmres_error_met(mon, x, V, H, g, k):
                break
        if mon.history:
            mon.history.pop()  # the restart records the true residual in place of the estimate
        y = _back_substitute(H, g, k)
        for i in range(k):
            x += y[i] * V[i]
        r = E - A(x)
