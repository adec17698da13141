"""Joint excitations, evaluated exactly (closed form) at any array of instants.

Each excitation is a callable `motion(t) -> (q, dq, ddq)` with arrays of shape
(len(t), n_joints). Closed form matters twice: the torque channel of a `delay` case is the
truth evaluated at `t - d` (no interpolation), and jittered sample instants are evaluated
where they really fall.

* `stepped`: every joint on its own schedule (not synchronised with the others) of
  constant-speed plateaus at log-spaced speeds, each out and back, with rests; speed
  changes follow a quintic smoothstep (acceleration continuous).
* `multisine`: a band-limited Fourier series per joint (Swevers et al. 1997 style:
  harmonics of a base frequency, random coefficients), scaled to a peak speed.
* `ptp`: synchronised point-to-point moves between random postures, minimum-jerk profiles
  (Flash & Hogan 1985), dwelling at each target.
"""
import numpy as np


def _smoothstep(x):
    """Quintic smoothstep s(x), its derivative and second derivative, and its integral from 0."""
    x = np.clip(x, 0.0, 1.0)
    s = x**3 * (10.0 - 15.0 * x + 6.0 * x**2)
    ds = 30.0 * x**2 * (1.0 - x) ** 2
    dds = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x)
    ints = x**4 * (2.5 - 3.0 * x + x**2)
    return s, ds, dds, ints


class VelocitySchedule:
    """One joint's velocity as a list of smooth transitions (t0, ramp, v_from, v_to),
    constant between them; position is its exact integral from `q0`."""

    def __init__(self, q0, transitions):
        self.q0 = q0
        tr = sorted(transitions)
        self.t0 = np.array([x[0] for x in tr])
        self.r = np.array([x[1] for x in tr])
        self.v0 = np.array([x[2] for x in tr])
        self.v1 = np.array([x[3] for x in tr])
        # position at the start of each transition
        qs = [q0]
        for k in range(1, len(tr)):
            end = self.t0[k - 1] + self.r[k - 1]
            disp = self.v0[k - 1] * self.r[k - 1] + (self.v1[k - 1] - self.v0[k - 1]) * self.r[k - 1] * 0.5
            qs.append(qs[-1] + disp + self.v1[k - 1] * (self.t0[k] - end))
        self.qs = np.array(qs)

    def __call__(self, t):
        k = np.searchsorted(self.t0, t, side="right") - 1
        before = k < 0
        k = np.clip(k, 0, len(self.t0) - 1)
        tau = t - self.t0[k]
        r = self.r[k]
        x = tau / r
        s, ds, dds, ints = _smoothstep(x)
        dv = self.v1[k] - self.v0[k]
        inside = x < 1.0
        v = np.where(inside, self.v0[k] + dv * s, self.v1[k])
        a = np.where(inside, dv * ds / r, 0.0)
        q_in = self.qs[k] + self.v0[k] * tau + dv * r * ints
        q_out = self.qs[k] + self.v0[k] * r + dv * r * 0.5 + self.v1[k] * (tau - r)
        q = np.where(inside, q_in, q_out)
        q = np.where(before, self.q0, q)
        v = np.where(before, 0.0, v)
        a = np.where(before, 0.0, a)
        return q, v, a


def stepped(rng, home, duration, speeds=(0.002, 0.005, 0.012, 0.03, 0.08, 0.2, 0.5), travel=0.6, ramp=(0.12, 0.3)):
    """Per joint: plateaus at each speed (random order, random first direction), out and
    back (so the joint returns to `home`), at most `travel` rad out, rests of 0.2–0.7 s."""
    scheds = []
    for q0 in home:
        t = rng.uniform(0.0, 1.0)  # joints start at different times
        tr = []
        while t < duration + 1.0:
            for v in rng.permutation(speeds):
                sgn = rng.choice([-1.0, 1.0])
                r = rng.uniform(*ramp)
                cruise = min(rng.uniform(1.2, 2.5), travel / v)
                for d in (sgn, -sgn):
                    tr.append((t, r, 0.0, d * v))
                    t += r + cruise
                    tr.append((t, r, d * v, 0.0))
                    t += r + rng.uniform(0.2, 0.7)
        scheds.append(VelocitySchedule(q0, tr))

    def motion(t):
        out = [s(t) for s in scheds]
        return tuple(np.stack([o[i] for o in out], axis=1) for i in range(3))

    return motion


def multisine(rng, home, period=10.0, harmonics=5, peak_speed=(0.35, 0.8), max_travel=0.7):
    """Per joint q = home + Σ_k a_k sin(k ω t) + b_k cos(k ω t) − its value at t = 0,
    ω = 2π/period, coefficients ∝ 1/k, scaled to a drawn peak speed, capped in travel."""
    n = len(home)
    w = 2.0 * np.pi / period
    k = np.arange(1, harmonics + 1)
    a = rng.normal(size=(n, harmonics)) / k
    b = rng.normal(size=(n, harmonics)) / k
    tt = np.linspace(0.0, period, 4001)
    for j in range(n):
        arg = np.outer(tt, k * w)
        v = (np.cos(arg) * a[j] * k * w - np.sin(arg) * b[j] * k * w).sum(axis=1)
        x = (np.sin(arg) * a[j] + np.cos(arg) * b[j]).sum(axis=1)
        scale = rng.uniform(*peak_speed) / np.abs(v).max()
        scale = min(scale, max_travel / np.abs(x - x[0]).max())
        a[j] *= scale
        b[j] *= scale
    home = np.asarray(home, float)

    def motion(t):
        arg = np.multiply.outer(t, k * w)  # (N, H)
        s, c = np.sin(arg), np.cos(arg)
        q = home + s @ a.T + c @ b.T - b.sum(axis=1)
        dq = (c * (k * w)) @ a.T - (s * (k * w)) @ b.T
        ddq = -(s * (k * w) ** 2) @ a.T - (c * (k * w) ** 2) @ b.T
        return q, dq, ddq

    return motion


def ptp(rng, home, duration, reach=0.6, move_s=(1.0, 3.5), dwell_s=(0.3, 1.2), lower=None, upper=None):
    """Synchronised minimum-jerk moves between random postures within `reach` of `home`
    (and inside the joint limits), dwelling at each."""
    home = np.asarray(home, float)
    lo = home - reach if lower is None else np.maximum(home - reach, np.asarray(lower) + 0.05)
    hi = home + reach if upper is None else np.minimum(home + reach, np.asarray(upper) - 0.05)
    starts, durs, qa, qb = [], [], [], []
    t, q = 0.0, home.copy()
    while t < duration + 1.0:
        target = rng.uniform(lo, hi)
        T = rng.uniform(*move_s)
        starts.append(t)
        durs.append(T)
        qa.append(q)
        qb.append(target)
        q = target
        t += T + rng.uniform(*dwell_s)
    starts, durs, qa, qb = map(np.array, (starts, durs, qa, qb))

    def motion(t):
        k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        T = durs[k][:, None]
        x = ((t - starts[k])[:, None]) / T
        s, ds, dds, _ = _smoothstep(x)
        d = qb[k] - qa[k]
        return qa[k] + d * s, d * ds / T, d * dds / T**2

    return motion


EXCITATIONS = ("stepped", "multisine", "ptp")


def make(kind, rng, home, duration, lower=None, upper=None):
    if kind == "stepped":
        return stepped(rng, home, duration)
    if kind == "multisine":
        return multisine(rng, home)
    if kind == "ptp":
        return ptp(rng, home, duration, lower=lower, upper=upper)
    raise ValueError(f"unknown excitation `{kind}`; use one of {EXCITATIONS}")
