"""Fixed-step classical Runge-Kutta (RK4) with sub-steps, on plain Python floats."""

from __future__ import annotations


def rk4(f, t, x, h, n_sub=1, args=(), warm=None):
    """Advance ``x' = f(t, x, *args)`` from ``t`` over ``h`` [s] in ``n_sub`` RK4 sub-steps.

    ``x`` is a sequence of floats, ``f`` returns a sequence of the same length.
    Sub-step times are ``t + j h / n_sub`` (never accumulated).  Returns a tuple.

    ``warm``: None, or a one-element list passed to ``f`` after ``args``, for an iterative solve
    inside ``f`` to start from ``warm[0]`` and leave its solution there.  It is reset to 0.0 (a cold
    start) at the first stage of every sub-step, so stages 2 to 4 start from the previous stage's
    solution and the result depends on ``x`` and the inputs only (a step of n h is n steps of h).
    """
    dt = h / n_sub
    half = 0.5 * dt
    sixth = dt / 6.0
    x = tuple(x)
    if warm is not None:
        args = (*args, warm)
    for j in range(n_sub):
        tj = t + j * dt
        if warm is not None:
            warm[0] = 0.0
        k1 = f(tj, x, *args)
        k2 = f(tj + half, [xi + half * ki for xi, ki in zip(x, k1)], *args)
        k3 = f(tj + half, [xi + half * ki for xi, ki in zip(x, k2)], *args)
        k4 = f(tj + dt, [xi + dt * ki for xi, ki in zip(x, k3)], *args)
        x = tuple(
            xi + sixth * (a + 2.0 * b + 2.0 * c + d) for xi, a, b, c, d in zip(x, k1, k2, k3, k4)
        )
    return x
