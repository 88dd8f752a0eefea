# Remez (minimax) fit of atan(t) = t*P(t^2) on [0, 1]; prints coefficients and the error of
# their f32 Horner evaluation. The 7-term result is math::ATAN_COEFFS in fringe3d-core.
# Usage: pip install numpy && python3 tools/fit_atan.py
import numpy as np
# minimax fit of atan(t) = t*P(t^2), t in [0,1], by Remez on the error function (absolute error)
def fit(nterms):
    # initial: chebyshev-like nodes
    m = nterms + 1
    t = np.cos(np.linspace(np.pi, 0, m))*0.5+0.5
    t = np.clip(t, 1e-6, 1.0)
    for it in range(60):
        # solve t*P(t^2) + (-1)^i E = atan(t)
        A = np.zeros((m, m)); b = np.arctan(t)
        for j in range(nterms):
            A[:, j] = t**(2*j+1)
        A[:, nterms] = (-1.0)**np.arange(m)
        sol = np.linalg.solve(A, b)
        c = sol[:nterms]
        xs = np.linspace(0, 1, 200001)
        err = xs*np.polyval(c[::-1], xs*xs) - np.arctan(xs)
        # find extrema: sign alternating segments
        idx = [0]
        # local extrema of err
        d = np.diff(err)
        ext = np.where(np.sign(d[1:]) != np.sign(d[:-1]))[0] + 1
        cand = np.concatenate(([0], ext, [len(xs)-1]))
        # choose m alternating points with largest |err|
        pts = []
        for k in cand:
            if pts and np.sign(err[k]) == np.sign(err[pts[-1]]):
                if abs(err[k]) > abs(err[pts[-1]]): pts[-1] = k
            else:
                pts.append(k)
        while len(pts) > m:
            # drop smaller end
            if abs(err[pts[0]]) < abs(err[pts[-1]]): pts.pop(0)
            else: pts.pop()
        if len(pts) < m: break
        t = xs[pts]
    return c, np.max(np.abs(err))
for n in (6,7,8):
    c, e = fit(n)
    # f32 horner evaluation error
    xs = np.linspace(0,1,1000001).astype(np.float32)
    c32 = c.astype(np.float32)
    s = xs*xs
    p = np.float32(c32[-1])*np.ones_like(xs)
    for k in c32[-2::-1]:
        p = (p*s + k).astype(np.float32)
    r = (p*xs).astype(np.float32)
    e32 = np.max(np.abs(r.astype(np.float64) - np.arctan(xs.astype(np.float64))))
    print(n, 'terms deg', 2*n-1, 'minimax err', e, 'f32 err', e32)
    print('  ', ', '.join('%.9e' % v for v in c))
