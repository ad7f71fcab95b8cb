#!/usr/bin/env python3
"""Brute-force check of `odoerr bound` on a short drive (docs/nonsystematic.md, "How it is tested").

1. `odoerr sim` writes a short drive of the paper's experiment; every --scan-every-th scan
   is kept (so that the dense computation below stays small); `odoerr bound` runs on that
   log and dumps its linearisation at the true path (F, G, dQ/dK per cycle, the beams' H).
2. From that linearisation alone, numpy builds the joint Gaussian of ALL the measurements
   of the drive at once, z = H X + v with X the stacked states (no recursion, no filter):
       Sigma(K) = H (A P0 A^T + B Q(K) B^T) H^T + r I,   dSigma/dK_i = H B dQ_i B^T H^T,
   and the exact Fisher information of K, I_ij = 0.5 tr(Sigma^-1 dSigma_i Sigma^-1 dSigma_j),
   and the posterior covariance of the final state given all measurements; the covariance
   term alone from central differences of Sigma's Cholesky pivots (the innovation variances).
3. A Monte Carlo of the score: z drawn from N(0, Sigma), the score
   s_i = -0.5 tr(Sigma^-1 dSigma_i) + 0.5 z^T Sigma^-1 dSigma_i Sigma^-1 z, and its
   covariance over --draws draws, which must match I within its sampling error.

Tolerances: the recursion and the dense formula are the same quantity computed two ways in
double precision: 1e-6 relative (observed agreement is ~1e-10). The Monte Carlo variance of
the score over n draws has a relative standard error sqrt(2/n) (Gaussian score): 4 standard
errors are allowed. Exit 1 on any disagreement, with the numbers.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("command failed: %s\n%s%s" % (" ".join(cmd), r.stdout, r.stderr))
    return r


def joint_check(lin, b, H, r):
    """K with delta unknown: the joint information of theta = (K, delta) from the dense
    Gaussian of the pose-only model z ~ N(mu(theta), Sigma(theta)) (delta a parameter of the
    data, the filter's prior on the pose), exact formula
        J_ab = mu_a^T Sigma^-1 mu_b + 0.5 tr(Sigma^-1 Sigma_a Sigma^-1 Sigma_b) + prior on delta,
    with mu_delta = H m (m: the stacked mean path's derivative, F_pp products of d f/d delta,
    F's delta columns) and Sigma_delta by central differences of Sigma under G + e dG/d delta
    (F_pp at the true delta, as in the recursion; step 1e-5: truncation ~1e-10, rounding
    ~1e-11 relative)."""
    N, M = lin["states"], lin["nonsys"]
    cyc = lin["cycles"]
    T = len(cyc)
    L = N - 3
    k_true = np.array(lin["k_true"])
    P0 = np.array(lin["P0"])
    nw = len(cyc[0]["G"][0])
    Hp = H.reshape(H.shape[0], T, N)[:, :, :3].reshape(H.shape[0], T * 3)  # pose columns only
    Fpp = [np.array(cy["F"])[:, :3] for cy in cyc]
    Fpd = [np.array(cy["F"])[:, 3:] for cy in cyc]
    G = [np.array(cy["G"]) for cy in cyc]
    dG = [[np.array(cy["dG_ddelta"][j]) for cy in cyc] for j in range(L)]
    dq = np.array([[v for cy in cyc for v in cy["dQ"][i]] for i in range(M)])
    q = k_true @ dq

    def stacks(Fs, Gs):
        A = np.zeros((T * 3, 3))
        B = np.zeros((T * 3, T * nw))
        pa, pb = np.eye(3), np.zeros((3, T * nw))
        for c in range(T):
            pa = Fs[c] @ pa
            pb = Fs[c] @ pb
            pb[:, c * nw:(c + 1) * nw] += Gs[c]
            A[c * 3:(c + 1) * 3] = pa
            B[c * 3:(c + 1) * 3] = pb
        return Hp @ A, Hp @ B

    def sigma(Fs, Gs):
        HA, HB = stacks(Fs, Gs)
        return HA @ P0[:3, :3] @ HA.T + (HB * q) @ HB.T + r * np.eye(Hp.shape[0]), HB

    S, HB = sigma(Fpp, G)
    dS = [(HB * dq[i]) @ HB.T for i in range(M)]
    mus = [np.zeros(Hp.shape[0]) for _ in range(M)]
    eps = 1e-5
    for j in range(L):
        Sp, _ = sigma(Fpp, [G[c] + eps * dG[j][c] for c in range(T)])
        Sm, _ = sigma(Fpp, [G[c] - eps * dG[j][c] for c in range(T)])
        dS.append((Sp - Sm) / (2 * eps))
        mvec, mm = np.zeros(T * 3), np.zeros(3)
        for c in range(T):
            mm = Fpp[c] @ mm + Fpd[c][:, j]
            mvec[c * 3:(c + 1) * 3] = mm
        mus.append(Hp @ mvec)
    Sinv = np.linalg.inv(S)
    Y = [Sinv @ d for d in dS]
    nt = M + L
    J = np.array([[mus[a] @ Sinv @ mus[b] + 0.5 * np.sum(Y[a] * Y[b].T) for b in range(nt)] for a in range(nt)])
    J[M:, M:] += np.linalg.inv(P0[3:, 3:])
    J_rec = np.array(b["final"]["fisher_K_delta"])
    # relative to each entry's scale sqrt(J_aa J_bb) (the entries span 1e0..1e12)
    scale = np.sqrt(np.outer(np.diag(J), np.diag(J)))
    rel = np.max(np.abs(J_rec - J) / scale)
    print("joint information of (K, delta): recursion\n%s\ndense\n%s\nmax difference / sqrt(J_aa J_bb) %.2e "
          "(tolerance 1e-6)" % (J_rec, J, rel))
    fails = []
    if not rel < 1e-6:
        fails.append("the joint information differs from the dense one by %.2e" % rel)
    cov = np.linalg.inv(J)
    names = list(b["final"]["nonsystematic"].keys())
    for i, n in enumerate(names):
        rec = b["final"]["nonsystematic_delta_unknown"][n]["sigma"]
        d = abs(rec - np.sqrt(cov[i, i])) / np.sqrt(cov[i, i])
        print("%s with delta unknown: sigma recursion %.6g, dense %.6g (%.1e)" % (n, rec, np.sqrt(cov[i, i]), d))
        if not d < 1e-6:
            fails.append("%s's delta-unknown sigma differs from the dense one by %.2e" % (n, d))
    return fails


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("odoerr")
    ap.add_argument("out")
    ap.add_argument("--drive", default="sync")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--scan-every", type=int, default=8)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--draws", type=int, default=3000)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    full = os.path.join(a.out, "drive-%s.odolog" % a.drive)
    thin = os.path.join(a.out, "drive-%s-thin.odolog" % a.drive)
    run([a.odoerr, "sim", "--drive", a.drive, "--steps", str(a.steps), "--seed", str(a.seed), "--out", full])
    kept = 0
    with open(full) as f, open(thin, "w") as g:
        n = 0
        for line in f:
            if line.startswith("scan "):
                n += 1
                if n % a.scan_every:
                    continue
                kept += 1
            g.write(line)
    bj = os.path.join(a.out, "bound-%s.json" % a.drive)
    lj = os.path.join(a.out, "lin-%s.json" % a.drive)
    run([a.odoerr, "bound", thin, "--json", bj, "--dump-linearisation", lj])
    b = json.load(open(bj))
    lin = json.load(open(lj))

    N, M, r = lin["states"], lin["nonsys"], lin["range_variance"]
    k_true = np.array(lin["k_true"])
    P0 = np.array(lin["P0"])
    cyc = lin["cycles"]
    T = len(cyc)
    # X = [x_0 .. x_{T-1}] (state after each cycle) = A x_init + B W, W = (w_0 .. w_{T-1})
    nw = len(cyc[0]["G"][0])
    A = np.zeros((T * N, N))
    B = np.zeros((T * N, T * nw))
    prevA, prevB = np.eye(N), np.zeros((N, T * nw))
    dq = np.zeros((M, T * nw))
    for c, cy in enumerate(cyc):
        F = np.eye(N)
        F[:3, :] = np.array(cy["F"])
        G = np.zeros((N, nw))
        G[:3, :] = np.array(cy["G"])
        prevA = F @ prevA
        prevB = F @ prevB
        prevB[:, c * nw:(c + 1) * nw] += G
        A[c * N:(c + 1) * N] = prevA
        B[c * N:(c + 1) * N] = prevB
        for i in range(M):
            dq[i, c * nw:(c + 1) * nw] = cy["dQ"][i]
    rows = []
    for c, cy in enumerate(cyc):
        for h in cy["H"]:
            row = np.zeros(T * N)
            row[c * N:c * N + 3] = h
            rows.append(row)
    H = np.array(rows)
    m = H.shape[0]
    if m == 0:
        sys.exit("no beam in the linearisation: nothing to check")
    q = k_true @ dq  # Q(K) is linear in K
    HA, HB = H @ A, H @ B
    Sigma = HA @ P0 @ HA.T + (HB * q) @ HB.T + r * np.eye(m)
    dS = [(HB * dq[i]) @ HB.T for i in range(M)]
    L = np.linalg.cholesky(Sigma)  # raises if Sigma is not positive definite
    Linv = np.linalg.inv(L)
    Sinv = Linv.T @ Linv
    Y = [Sinv @ d for d in dS]
    # tr(Y_i Y_j) as an elementwise sum (no m^3 product)
    I_dense = np.array([[0.5 * np.sum(Y[i] * Y[j].T) for j in range(M)] for i in range(M)])
    I_rec = np.array(b["final"]["fisher_K"])
    I_cov = np.array(b["final"]["fisher_K_covariance_term"])
    fails = []
    rel = np.max(np.abs(I_rec - I_dense)) / np.max(np.abs(I_dense))
    print("%s: %d cycles, %d scans kept, %d beams (dense Sigma %dx%d)" % (a.drive, T, kept, m, m, m))
    print("Fisher information of K: recursion\n%s\ndense\n%s\nmax relative difference %.2e (tolerance 1e-6)"
          % (I_rec, I_dense, rel))
    if not rel < 1e-6:
        fails.append("the recursion's Fisher information differs from the dense one by %.2e" % rel)
    if not np.all(np.diag(I_cov) < np.diag(I_dense)):
        fails.append("the covariance term alone is not below the full information")
    # The covariance term alone: the innovation variances s_k of the measurements in the
    # filter's order are the pivots of Sigma's Cholesky factorisation (Sigma = L D L^T),
    # ds_k/dK_i by central differences of the factorisation at K_i (1 +- eps). Sigma is
    # linear in K but its pivots are not: the truncation error is O(eps^2) relative (1e-8
    # at eps = 1e-4) and the rounding error about 1e-16 cond(Sigma) / eps, far below the
    # 1e-5 tolerance allowed here.
    eps = 1e-4
    piv = lambda S: np.diag(np.linalg.cholesky(S)) ** 2
    s_k = piv(Sigma)
    dsk = []
    for i in range(M):
        h = eps * k_true[i]
        dsk.append((piv(Sigma + h * dS[i]) - piv(Sigma - h * dS[i])) / (2 * h))
    I_cov_fd = np.array([[0.5 * np.sum(dsk[i] * dsk[j] / s_k ** 2) for j in range(M)] for i in range(M)])
    rel_c = np.max(np.abs(I_cov - I_cov_fd)) / np.max(np.abs(I_cov_fd))
    print("covariance term alone: recursion\n%s\nfinite differences of the dense pivots\n%s\n"
          "max relative difference %.2e (tolerance 1e-5)" % (I_cov, I_cov_fd, rel_c))
    if not rel_c < 1e-5:
        fails.append("the covariance term differs from the finite differences of the pivots by %.2e" % rel_c)
    # Posterior covariance of the last state given every measurement (the PCRB of the pose
    # and systematic parameters at the end), against the recursion's sigmas.
    CX = A[-N:] @ P0 @ A.T + (B[-N:] * q) @ B.T  # Cov(x_T, X)
    Cxz = CX @ H.T
    Pxx = A[-N:] @ P0 @ A[-N:].T + (B[-N:] * q) @ B[-N:].T
    Ppost = Pxx - Cxz @ np.linalg.solve(Sigma, Cxz.T)
    f = b["final"]
    sig_rec = [f["pose"]["x_sigma_m"], f["pose"]["y_sigma_m"], f["pose"]["heading_sigma_rad"]]
    sig_rec += [v["sigma"] for v in f["systematic"].values()]
    sig_dense = np.sqrt(np.diag(Ppost))
    rel_s = np.max(np.abs(np.array(sig_rec) - sig_dense) / sig_dense)
    print("final sigmas: recursion %s\n              dense     %s\nmax relative difference %.2e (tolerance 1e-6)"
          % (np.array(sig_rec), sig_dense, rel_s))
    if not rel_s < 1e-6:
        fails.append("the recursion's final sigmas differ from the dense posterior by %.2e" % rel_s)
    fails += joint_check(lin, b, H, r)
    # Monte Carlo of the score.
    rng = np.random.default_rng(a.seed)
    # z = L e, so Sigma^-1 z = L^-T e; z^T Sigma^-1 dSigma_i Sigma^-1 z = sum_k dq_ik (HB^T Sigma^-1 z)_k^2
    tr = np.array([np.trace(y) for y in Y])
    scores = np.zeros((a.draws, M))
    batch = 1000
    for s0 in range(0, a.draws, batch):
        nb = min(batch, a.draws - s0)
        g = HB.T @ (Linv.T @ rng.standard_normal((m, nb)))
        for i in range(M):
            scores[s0:s0 + nb, i] = -0.5 * tr[i] + 0.5 * (dq[i][:, None] * g * g).sum(axis=0)
    I_mc = np.cov(scores.T).reshape(M, M)
    se = np.sqrt(2.0 / a.draws)
    for i in range(M):
        d = I_mc[i, i] / I_rec[i, i] - 1
        print("K_%d: Monte Carlo of the score %.6g vs recursion %.6g: %+.1f %% (tolerance 4 SE = %.1f %%); score mean %.3g sd"
              % (i, I_mc[i, i], I_rec[i, i], 100 * d, 400 * se, np.mean(scores[:, i]) / np.sqrt(I_mc[i, i] / a.draws)))
        if not abs(d) < 4 * se:
            fails.append("Monte Carlo Fisher information of K_%d off by %.1f %%" % (i, 100 * d))
    if fails:
        print("FAIL: " + "; ".join(fails))
        return 1
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
