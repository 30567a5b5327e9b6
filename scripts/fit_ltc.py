#!/usr/bin/env python3
"""Fits the linearly transformed cosines (LTC) that the `ltc` strategy samples
polygon lights with, from penumbra's GGX BRDF itself, and writes them as
src/core/ltc_table.h.

An LTC (Heitz, Dupuy, Hill & Neubelt 2016) is the clamped cosine D_o(w_o) =
max(0, w_o.z) / pi seen through a 3x3 matrix M: w = M w_o / |M w_o|, with density

    D(w) = D_o(Minv w / |Minv w|) |det Minv| / |Minv w|^3.

For each view angle theta_o and GGX alpha, the fit approximates the normalised
cosine-weighted specular lobe of core/material.h (F = 1),

    p(w_i) = D(h) G2(w_o, w_i) / (4 cos_o) / rho(theta_o, alpha),

in the shading frame where w_o = (sin theta_o, 0, cos theta_o). Minv then has the
form [[a, 0, b], [0, c, 0], [d, 0, 1]] (scale does not matter: D is invariant
under Minv -> s Minv). The fit maximises the likelihood of p's samples under D,
i.e. it minimises the Kullback-Leibler divergence KL(p || D): the measure that
keeps D from being small where p is large, which is what an importance sampler
needs (Peters 2021 fits its LTCs for sampling too). The samples are GGX visible
normals (Heitz 2018) reflected about w_o, each weighted by G2 / G1(w_o), from a
fixed stratified set, so the table is the same on every run.

The table: 32 x 32 cells, rows by roughness r = sqrt(alpha) (alpha >= 1e-3, as
make_bsdf clamps it), columns by t = sqrt(1 - cos theta_o), each cell
(a, b, c, d, rho), where rho is the lobe's directional albedo with F = 1, which
the strategy uses to weigh the specular lobe against the diffuse one. Any fit
gives an unbiased estimator (the strategy's pdf is D's exactly); a better fit
only lowers the variance.

    python3 scripts/fit_ltc.py             # writes src/core/ltc_table.h
    python3 scripts/fit_ltc.py --check     # fits, and prints the fit's quality

Needs numpy and scipy (PyPI).
"""
import argparse
import math
import os
import sys

import numpy as np
from scipy.optimize import minimize

N = 32
MIN_ALPHA = 1e-3
SAMPLES = 64  # per axis: 64 x 64 stratified samples per cell


def ggx_lambda(z2, alpha):
    tan2 = np.maximum(0.0, 1.0 - z2) / np.maximum(z2, 1e-30)
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)


def lobe_samples(cos_o, alpha):
    """Directions w_i of the specular lobe and their weights (target / density), from
    visible normals (Heitz 2018, listing 1, as core/material.h samples them)."""
    sin_o = math.sqrt(max(0.0, 1.0 - cos_o * cos_o))
    wo = np.array([sin_o, 0.0, cos_o])
    k = (np.arange(SAMPLES) + 0.5) / SAMPLES
    u1, u2 = np.meshgrid(k, k, indexing="ij")
    u1, u2 = u1.ravel(), u2.ravel()
    vh = np.array([alpha * wo[0], alpha * wo[1], wo[2]])
    vh /= np.linalg.norm(vh)
    lensq = vh[0] ** 2 + vh[1] ** 2
    t1 = np.array([-vh[1], vh[0], 0.0]) / math.sqrt(lensq) if lensq > 0 else np.array([1.0, 0.0, 0.0])
    t2 = np.cross(vh, t1)
    r = np.sqrt(u1)
    phi = 2.0 * math.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + vh[2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nh = np.outer(p1, t1) + np.outer(p2, t2) + np.outer(p3, vh)
    h = np.stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(1e-6, nh[:, 2])], axis=1)
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    wi = 2.0 * (h @ wo)[:, None] * h - wo
    lam_o = ggx_lambda(cos_o * cos_o, alpha)
    lam_i = ggx_lambda(wi[:, 2] ** 2, alpha)
    w = np.where(wi[:, 2] > 0.0, (1.0 + lam_o) / (1.0 + lam_o + lam_i), 0.0)
    return wi, w


def ltc_log_density(params, wi, floor=0.0):
    """log D(w_i) for Minv = [[a, 0, b], [0, c, 0], [d, 0, 1]], params (log a, b, log c, d); None where Minv is
    not a proper transform. floor > 0: directions outside D's support get the cosine `floor` in place of
    0 (a finite, continuous penalty for the optimiser)."""
    a, b, c, d = math.exp(params[0]), params[1], math.exp(params[2]), params[3]
    det = c * (a - b * d)
    if not det > 0.0:
        return None
    v = np.stack([a * wi[:, 0] + b * wi[:, 2], c * wi[:, 1], d * wi[:, 0] + wi[:, 2]], axis=1)
    l2 = np.einsum("ij,ij->i", v, v)
    cos = v[:, 2] / np.sqrt(l2)
    with np.errstate(divide="ignore"):
        return np.log(np.maximum(cos, floor) / math.pi) + math.log(det) - 1.5 * np.log(l2)


def objective(params, wi, w, wsum, floor):
    """-E_p[log D]; with floor = 0 a direction outside D's support makes it infinite."""
    logd = ltc_log_density(params, wi, floor)
    if logd is None:
        return 1e30
    keep = w > 0.0
    value = -float(np.sum(w[keep] * logd[keep]) / wsum)
    return value if math.isfinite(value) else 1e30


def initial_guesses(wi, w, alpha):
    """Two starts: Minv = diag(1/s, 1/s, 1) R(phi)^T (the cosine turned to the lobe's mean direction
    phi, scaled to alpha), and the same with a shear in place of the turn, whose support is the upper
    hemisphere, which holds every sample."""
    avg = np.sum(wi * w[:, None], axis=0)
    avg /= np.linalg.norm(avg)
    phi = math.atan2(avg[0], avg[2])
    s = max(alpha, 1e-3)
    cp, sp = math.cos(phi), math.sin(phi)
    turned = np.array([math.log(1.0 / s), -sp / (s * cp), math.log(1.0 / (s * cp)), sp / cp])
    sheared = np.array([math.log(1.0 / s), -sp / (s * cp), math.log(1.0 / (s * cp)), 0.0])
    return [turned, sheared]


def fit_cell(cos_o, alpha, start):
    """Nelder-Mead from each start, first with a finite penalty outside D's support (so that the
    optimiser can move a start whose support misses samples), then with an infinite one from the
    best point whose support holds every sample (the sheared start always does)."""
    wi, w = lobe_samples(cos_o, alpha)
    wsum = float(np.sum(w))
    rho = wsum / len(w)
    options = {"xatol": 1e-6, "fatol": 1e-8, "maxiter": 4000, "maxfev": 8000}
    starts = ([start] if start is not None else []) + initial_guesses(wi, w, alpha)
    points = list(starts)
    for x0 in starts:
        points.append(minimize(objective, x0, args=(wi, w, wsum, 1e-9), method="Nelder-Mead", options=options).x)
    x0 = min(points, key=lambda x: objective(x, wi, w, wsum, 0.0))
    best = minimize(objective, x0, args=(wi, w, wsum, 0.0), method="Nelder-Mead", options=options)
    return best.x, rho, best.fun


def efficiency(params, cos_o, alpha):
    """Importance-sampling efficiency of D for the lobe: 1 / (1 + chi^2(p || D)), estimated from
    p's samples (E_p[p / D] = 1 + chi^2); 1 is a perfect fit."""
    wi, w = lobe_samples(cos_o, alpha)
    keep = w > 0.0
    wsum = np.sum(w)
    logd = ltc_log_density(params, wi)[keep]
    # p at the samples: weight times the sample density; the VNDF density is D(h) G1(wo) / (4 cos_o).
    sin_o = math.sqrt(max(0.0, 1.0 - cos_o * cos_o))
    wo = np.array([sin_o, 0.0, cos_o])
    h = wi[keep] + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    a2 = alpha * alpha
    dh = a2 / (math.pi * (a2 * h[:, 2] ** 2 + h[:, 0] ** 2 + h[:, 1] ** 2) ** 2)
    g1 = 1.0 / (1.0 + ggx_lambda(cos_o * cos_o, alpha))
    rho = wsum / len(w)
    p = w[keep] * dh * g1 / (4.0 * cos_o) / rho
    if not np.all(np.isfinite(logd)):
        return 0.0  # a part of the lobe outside D's support
    return 1.0 / float(np.sum(w[keep] * p / np.exp(logd)) / wsum)


def grid():
    rough = np.linspace(0.0, 1.0, N)
    alphas = np.maximum(MIN_ALPHA, rough * rough)
    ts = np.linspace(0.0, 1.0, N)
    coss = np.maximum(1e-3, 1.0 - ts * ts)
    return alphas, coss


def fit_all(progress=True):
    alphas, coss = grid()
    table = np.zeros((N, N, 5))
    quality = np.zeros((N, N))
    for j in range(N):  # view angles
        start = None
        for i in reversed(range(N)):  # from rough to smooth, each fit starting from the previous one
            x, rho, _ = fit_cell(coss[j], alphas[i], start)
            start = x
            table[i, j] = [math.exp(x[0]), x[1], math.exp(x[2]), x[3], rho]
            quality[i, j] = efficiency(x, coss[j], alphas[i])
        if progress:
            print(f"fit_ltc: view angle {j + 1}/{N} (cos {coss[j]:.3f}): efficiency "
                  f"{quality[:, j].min():.3f}-{quality[:, j].max():.3f}", file=sys.stderr)
    return table, quality


def float_literal(v):
    """v as a C++ float literal: 7 significant digits, always with a point or an exponent ("1.0f", not "1f")."""
    text = f"{v:.7g}"
    if not any(c in text for c in ".en"):
        text += ".0"
    return text + "f"


def write_header(table, path):
    lines = [
        "// Generated by scripts/fit_ltc.py: do not edit. Linearly transformed cosines fitted to",
        "// core/material.h's GGX specular lobe (F = 1) for sampling (scripts/fit_ltc.py says how).",
        f"// {N} x {N} cells: row i is roughness r = i / {N - 1} (alpha = max(r^2, {MIN_ALPHA})), column j",
        f"// is t = j / {N - 1} with cos theta_o = max(1 - t^2, 1e-3); each cell (a, b, c, d, rho):",
        "// Minv = [[a, 0, b], [0, c, 0], [d, 0, 1]] and the lobe's albedo rho.",
        "#pragma once",
        "",
        "// clang-format off",
        "#define PN_LTC_TABLE_SIZE " + str(N),
        "#define PN_LTC_TABLE_DATA \\",
    ]
    rows = []
    for i in range(N):
        for j in range(N):
            rows.append("  " + ", ".join(float_literal(v) for v in table[i, j]))
    lines.append(", \\\n".join(rows))
    lines.append("// clang-format on")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "src", "core", "ltc_table.h"))
    ap.add_argument("--check", action="store_true", help="fit and report the quality; write nothing")
    args = ap.parse_args()
    table, quality = fit_all()
    alphas, coss = grid()
    print(f"fit_ltc: importance-sampling efficiency 1/(1+chi^2) of the fits: min {quality.min():.3f}, "
          f"median {np.median(quality):.3f}; at roughness 0.1-0.5 and cos_o >= 0.3: "
          f"min {quality[(np.sqrt(alphas) >= 0.1)[:, None] & (np.sqrt(alphas) <= 0.5)[:, None] & (coss >= 0.3)[None, :]].min():.3f}")
    if not args.check:
        write_header(table, os.path.normpath(args.out))
        print(f"fit_ltc: wrote {os.path.normpath(args.out)}")


if __name__ == "__main__":
    main()
