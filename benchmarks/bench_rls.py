"""RLS update per sample: ours (the compiled recursion over a frame, as the nodes call it) against a plain
numpy textbook implementation, for the electrical (3), full (6) and ARX(4,3,1) (7) regressions, and the
identifier's electrical regression as it runs it (4 coefficients, instrumental variables)."""
import numpy as np

from benchmarks.harness import Row, best_time
from emla_identification.rls import RecursiveLeastSquares

FRAME = 100          # samples per frame at 10 kHz in the ROS graph
SAMPLES = 20_000


def textbook(Phi, Y, lam):
    """The DC-motor paper's recursion written directly in numpy, one sample at a time."""
    n = Phi.shape[1]
    theta, P = np.zeros(n), 1e6 * np.eye(n)
    for phi, y in zip(Phi, Y):
        e = y - phi @ theta
        g = P @ phi
        d = lam + phi @ g
        theta = theta + g * (e / d)
        P = (P - np.outer(g, g) / d) / lam
    return theta


def run():
    rng = np.random.default_rng(0)
    rows = []
    for label, n in [('electrical, 3 parameters', 3), ('full, 6 parameters', 6), ('ARX(4,3,1), 7 parameters', 7)]:
        Phi = rng.standard_normal((SAMPLES, n))
        Y = Phi @ rng.standard_normal(n) + 0.01 * rng.standard_normal(SAMPLES)
        rls = RecursiveLeastSquares(n, forgetting=0.9995)
        rls.update_block(Phi[:FRAME], Y[:FRAME])        # compile outside the timing

        def ours(rls=rls, Phi=Phi, Y=Y):
            for k in range(0, SAMPLES, FRAME):
                rls.update_block(Phi[k:k + FRAME], Y[k:k + FRAME])

        def per_sample_calls(rls=rls, Phi=Phi, Y=Y):
            for k in range(2000):
                rls.update(Phi[k], Y[k])

        t_ours = best_time(ours, repeats=5) / SAMPLES * 1e6
        t_call = best_time(per_sample_calls, repeats=3) / 2000 * 1e6
        t_text = best_time(lambda Phi=Phi, Y=Y: textbook(Phi[:5000], Y[:5000], 0.9995), repeats=3) / 5000 * 1e6
        target = '<= 5 us' if n == 3 else ''
        rows.append(Row(f'RLS update, {label}, frames of {FRAME}', t_ours, 'us/sample', t_text,
                        'numpy textbook', target, t_ours <= 5 if n == 3 else None))
        rows.append(Row(f'RLS update, {label}, one update() call per sample', t_call, 'us/sample', t_text,
                        'numpy textbook'))
    Phi = rng.standard_normal((SAMPLES, 4))
    Y = Phi @ rng.standard_normal(4) + 0.01 * rng.standard_normal(SAMPLES)
    Zeta = np.roll(Phi, 1, axis=0) + 0.5 * Phi
    rls = RecursiveLeastSquares(4, forgetting=0.9995)
    rls.update_block(Phi[:FRAME], Y[:FRAME], Zeta[:FRAME])  # compile outside the timing

    def instrumented():
        for k in range(0, SAMPLES, FRAME):
            rls.update_block(Phi[k:k + FRAME], Y[k:k + FRAME], Zeta[k:k + FRAME])

    t_iv = best_time(instrumented, repeats=5) / SAMPLES * 1e6
    t_text = best_time(lambda: textbook(Phi[:5000], Y[:5000], 0.9995), repeats=3) / 5000 * 1e6
    rows.append(Row(f'RLS update, the identifier\'s electrical regression (4 coefficients, instrumental variables), '
                    f'frames of {FRAME}', t_iv, 'us/sample', t_text, 'numpy textbook (least squares)', '<= 5 us',
                    t_iv <= 5))
    return rows
