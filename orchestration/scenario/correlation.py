"""Correlated draws of a Monte Carlo sweep's normal parameters (:mod:`orchestration.scenario.sweep`).

Two sources, combined into one covariance matrix over the sweep's normal parameters (the diagonal
their variances): a prior file's covariance between parameters taken ``from:`` it
(:mod:`orchestration.scenario.priors`), and ``sweep.correlation`` (ones on the diagonal, entries in
[-1, 1], times the two standard deviations) or ``sweep.covariance`` (its diagonal the variances)::

    sweep:
      samples: 100
      seed: 7
      parameters:
        plant.R_s: {normal: [1.405, 0.02]}
        plant.R_r: {normal: [1.395, 0.04]}
      correlation:                      # the two resistances warm up together
        parameters: [plant.R_s, plant.R_r]
        matrix: [[1.0, 0.8], [0.8, 1.0]]

A pair given by both is refused, so is a joint matrix that is not positive semi-definite, and
correlation with a sensitivity analysis (its indices assume independent parameters).  Without any
correlation a sweep draws as before, bit for bit.  Pure: numbers in, rows out.
"""

from __future__ import annotations

__all__ = ["JOINT", "joint_normal", "draws"]

JOINT = ("correlation", "covariance")  # the sweep's keys of correlated draws


def joint_normal(chk, raw, paths, specs, sources, analysis):
    """``(normal paths, means, covariance rows)`` of a Monte Carlo sweep's normal parameters when any two
    are correlated (by a prior file's covariance or by ``sweep.correlation`` / ``sweep.covariance``),
    else None; problems recorded (a correlated parameter that is not normal, a pair given twice, a
    joint matrix that is not positive semi-definite, correlation with a sensitivity analysis)."""
    import numpy as np

    from orchestration.scenario import priors

    normal = [p for p in paths if specs.get(p) and specs[p][0] == "normal"]
    idx = {p: k for k, p in enumerate(normal)}
    std = [specs[p][2] for p in normal]
    C = np.diag(np.square(std)).tolist()
    given = {}  # (a, b) -> where the pair's covariance comes from
    for a, pa in enumerate(normal):
        for b in range(a):
            sa, sb = sources.get(pa), sources.get(normal[b])
            if sa is None or sb is None or sa[0] != sb[0] or sa[1] == sb[1]:
                continue
            prior = sa[2]
            if sa[1] in prior.names and sb[1] in prior.names:
                c = prior.cov[prior.names.index(sa[1])][prior.names.index(sb[1])]
                if c != 0.0:
                    C[a][b] = C[b][a] = c
                    given[a, b] = f"{sa[0]}'s covariance"
    if all(k in raw for k in JOINT):
        chk.add("sweep.covariance", raw["covariance"], "give sweep.correlation or sweep.covariance, not both")
        return None
    for key in JOINT:
        if key not in raw:
            continue
        field, spec = f"sweep.{key}", raw[key]
        if not chk.mapping(spec, field, ("parameters", "matrix")) or "parameters" not in spec:
            return None
        listed = spec["parameters"]
        if not (isinstance(listed, list) and len(listed) >= 2 and len(set(map(str, listed))) == len(listed)):
            chk.add(f"{field}.parameters", listed, "must list two or more of sweep.parameters, each once")
            return None
        for q in listed:
            if q not in idx:
                kind = specs[q][0] if specs.get(q) else None
                chk.add(f"{field}.parameters", listed, f"{q!r} " + (
                    f"has a {kind} distribution: a correlated parameter is normal ({{normal: [mean, std]}} "
                    "or {from: FILE})" if kind else "is not a parameter of sweep.parameters"))
                return None
        if "matrix" not in spec:
            return None
        diag = [std[idx[q]] ** 2 for q in listed]
        rows = priors.check_matrix(chk, spec["matrix"], f"{field}.matrix", len(listed), diag, key)
        if rows is None:
            return None
        for a, qa in enumerate(listed):
            for b in range(a):
                ia, ib = sorted((idx[qa], idx[listed[b]]), reverse=True)
                c = rows[a][b] if key == "covariance" else rows[a][b] * std[ia] * std[ib]
                if (ia, ib) in given:
                    chk.add(f"{field}.matrix[{a}][{b}]", spec["matrix"][a][b], f"{qa} and {listed[b]} are "
                            f"correlated by {given[ia, ib]} already")
                    return None
                given[ia, ib] = field
                C[ia][ib] = C[ib][ia] = c
    if not any(C[a][b] != 0.0 for a in range(len(normal)) for b in range(a)):
        return None
    if analysis is not None:
        chk.add("sweep.analysis", analysis, f"{analysis} indices assume independent parameters, and these "
                f"are correlated ({', '.join(sorted(set(given.values())))}): use a Monte Carlo sweep (no "
                "analysis)")
        return None
    d = np.sqrt(np.maximum(np.diag(C), 0.0))
    scale = np.where(d > 0, d, 1.0)
    low = float(np.linalg.eigvalsh(np.array(C) / np.outer(scale, scale)).min())
    if low < -1e-9:
        chk.add("sweep.parameters", {p: specs[p] for p in normal}, "the joint covariance of the normal "
                f"parameters is not positive semi-definite (smallest eigenvalue, scaled to correlations, "
                f"{low:.3g}): the correlations given contradict each other")
        return None
    return normal, [specs[p][1] for p in normal], C


def draws(paths, specs, joint, samples, seed):
    """The rows of a Monte Carlo sweep whose normal parameters are correlated: one
    ``numpy.random.default_rng(seed)``; in the order the file lists the parameters, a uniform one's
    ``samples`` draws, and at the first normal one all of them at once: ``mean + z L^T`` for standard
    normal ``z`` (``samples`` x their number) and ``L`` the covariance's Cholesky factor (an eigenvector
    factor for a singular one)."""
    import numpy as np

    normal, means, C = joint
    C = np.array(C)
    try:
        L = np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(C)
        L = V * np.sqrt(np.maximum(w, 0.0))
    rng = np.random.default_rng(seed)
    draws = {}
    for p in paths:
        kind, a, b = specs[p]
        if p in draws:
            continue
        if kind == "normal":
            X = np.asarray(means) + rng.standard_normal((samples, len(normal))) @ L.T
            draws.update({q: X[:, k].tolist() for k, q in enumerate(normal)})
        else:
            draws[p] = rng.uniform(a, b, samples).tolist()
    return [tuple(draws[p][i] for p in paths) for i in range(samples)]
