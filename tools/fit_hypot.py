# Remez (minimax, relative error) fit of g(u) = sqrt((1 + u)/2) on u in [0, 1], the factor of the
# decoder's modulation without a square root: with p = (|S| - |C|)/(|S| + |C|),
#   sqrt(S^2 + C^2) = (|S| + |C|) * g(p^2)      (S^2 + C^2 = (|S| + |C|)^2 (1 + p^2)/2).
# Prints the coefficients (lowest first; math::HYPOT_COEFFS in fringe3d-core), the polynomial's own
# relative error, and the relative error of its f32 evaluation by Estrin's scheme as the core does it.
# Usage: pip install numpy && python3 tools/fit_hypot.py
import numpy as np

g = lambda u: np.sqrt((1.0 + u) / 2.0)
DEG = 7


def fit(deg):
    m = deg + 2
    u = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, m))
    xs = np.linspace(0.0, 1.0, 400001)
    for _ in range(50):
        # P(u_i) - g(u_i) = (-1)^i E g(u_i)
        a = np.zeros((m, m))
        for j in range(deg + 1):
            a[:, j] = u ** j
        a[:, deg + 1] = -((-1.0) ** np.arange(m)) * g(u)
        sol = np.linalg.solve(a, g(u))
        c = sol[: deg + 1]
        err = np.polyval(c[::-1], xs) / g(xs) - 1.0
        d = np.diff(err)
        ext = np.where(np.sign(d[1:]) != np.sign(d[:-1]))[0] + 1
        cand = np.concatenate(([0], ext, [len(xs) - 1]))
        pts = []
        for k in cand:
            if pts and np.sign(err[k]) == np.sign(err[pts[-1]]):
                if abs(err[k]) > abs(err[pts[-1]]):
                    pts[-1] = k
            else:
                pts.append(k)
        while len(pts) > m:
            if abs(err[pts[0]]) < abs(err[pts[-1]]):
                pts.pop(0)
            else:
                pts.pop()
        if len(pts) < m:
            break
        u = xs[pts]
    return c, np.max(np.abs(err))


def estrin_f32(c, u):
    f = np.float32
    c = [f(v) for v in c]
    u = u.astype(f)
    u2 = u * u
    u4 = u2 * u2
    p01 = c[1] * u + c[0]
    p23 = c[3] * u + c[2]
    p45 = c[5] * u + c[4]
    p67 = c[7] * u + c[6]
    return (p23 * u2 + p01) + (p67 * u2 + p45) * u4


c, e = fit(DEG)
p = np.linspace(-1.0, 1.0, 2000001).astype(np.float32)
u = p * p
e32 = np.max(np.abs(estrin_f32(c, u).astype(np.float64) / g(u.astype(np.float64)) - 1.0))
print('degree', DEG, 'minimax relative error', e, 'f32 Estrin relative error', e32)
print('  ' + ', '.join('%.9e' % v for v in c))
