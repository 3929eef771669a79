#!/usr/bin/env python3
# SEPIA itself as the reference for vignette("real-data-gap") (issue 35,
# item 3): SEPIA's emulator (PCA + GP) and MCMC run on SEPIA's own examples,
# set up as its own scripts and notebooks set them up, the posterior draws
# of theta (native scale) saved for R to summarise. SEPIA's code is not part
# of griddy: it is imported from a copy extracted from the lanl/SEPIA
# repository (BSD-3), e.g.
#   git --git-dir=/path/to/SEPIA.git archive HEAD | tar -x -C /tmp/sepia
# (in a snapshot without every blob, `git show HEAD:<path>` file by file),
# with numpy, scipy and matplotlib (Debian: python3-numpy python3-scipy
# python3-matplotlib). Run from the package root:
#   SEPIA_SRC=/tmp/sepia /usr/bin/python3 data-raw/sepia-reference.py CASE [CASE...]
# CASE: ball_drop_1, ball_drop_1_noD, ball_drop_2, ball_drop_2_noD, al5083,
# al5083_cost (the cost of SEPIA's log likelihood, see al5083_cost()). Each writes
# inst/extdata/sepia_<CASE>.csv.gz (the kept draws: theta_native columns and
# the chain's log posterior) and appends a line to inst/extdata/sepia_runs.csv
# (the settings, the seconds the run took, the machine's load; times are on
# a shared 2-core machine). data-raw/sepia-reference.R reads them.
#
# Settings, per case (from SEPIA's files; what differs is said):
# * ball_drop_1: examples/Ball_Drop/ball_drop_1.ipynb on the data files of
#   examples/Ball_Drop/data (the files griddy reads; the notebook regenerates
#   the field data with fresh noise): x = R, theta = C, 2 principal
#   components, the discrepancy basis of 16 normal kernels (width 1.5 m) at
#   the simulator's heights; step sizes tuned (50, 20). The notebook draws
#   1,000 samples; here 6,000 (the first 1,000 dropped) so that the Monte
#   Carlo error of the bounds is small.
# * ball_drop_1_noD: the same without the discrepancy basis
#   (ball_drop_1_noD.ipynb's model).
# * ball_drop_2: ball_drop_2.ipynb: x = (R, rho_ball), theta = (C, g), 80
#   runs at 101 heights, 4 balls at 3 heights, 3 principal components, 20
#   kernels of discrepancy; 6,000 samples, the first 1,000 dropped.
# * ball_drop_2_noD: the same without the discrepancy basis.
# * al5083: examples/Al_5083/Al_5083_calibration.py: 1,000 runs of 11
#   parameters, 12 features, Sigy = diag(0.01 y_obs), 11 principal
#   components, lamWs's prior as in the script; step sizes tuned (100, 25)
#   and 10,000 samples as the script, unless AL5083_SAMPLES / AL5083_TUNE /
#   AL5083_RUNS say otherwise (the file records what was run).
import os
import sys
import time
import csv
import gzip
import subprocess

import numpy as np
from scipy.stats import norm

SRC = os.environ.get("SEPIA_SRC", "/tmp/sepia")
sys.path.insert(0, SRC)
from sepia.SepiaData import SepiaData  # noqa: E402
from sepia.SepiaModel import SepiaModel  # noqa: E402

OUT = os.environ.get("SEPIA_OUT", "inst/extdata")
BALL = os.path.join(SRC, "examples", "Ball_Drop", "data")
AL = os.path.join(SRC, "examples", "Al_5083", "data")


def load(path):
    with open(path) as f:
        return np.loadtxt(f)


def ball_drop_1(discrepancy=True):
    design = load(os.path.join(BALL, "sim.design"))
    y_sim = load(os.path.join(BALL, "sim.dat")).T  # one row per run
    h_sim = load(os.path.join(BALL, "sim.height"))
    y_obs = load(os.path.join(BALL, "field.dat"))
    h_obs = load(os.path.join(BALL, "field.height"))
    radii = load(os.path.join(BALL, "field.radii"))
    data = SepiaData(x_sim=design[:, [0]], t_sim=design[:, [1]], y_sim=y_sim,
                     y_ind_sim=h_sim, x_obs=radii.reshape(-1, 1), y_obs=y_obs,
                     y_ind_obs=h_obs)
    data.transform_xt()
    data.standardize_y()
    data.create_K_basis(2)
    if discrepancy:
        width = 1.5
        d_obs = np.column_stack([norm.pdf(h_obs, c, width) for c in h_sim])
        d_sim = np.column_stack([norm.pdf(h_sim, c, width) for c in h_sim])
        data.create_D_basis(D_obs=d_obs.T, D_sim=d_sim)
    return data, ["C"], dict(tune=(50, 20), samples=6000, burn=1000)


def ball_drop_2(discrepancy=True):
    d = os.path.join(BALL, "data_ball_drop_2")
    field = load(os.path.join(d, "fieldDat12x6gparam.txt"))
    x = load(os.path.join(d, "desNative4x2Rrho.txt"))
    y_obs = np.reshape(field[:, 4], (4, 3))
    h_obs = field[0:3, 3]
    sim = load(os.path.join(d, "desNative80x4Cg.txt"))
    h_sim = load(os.path.join(d, "simHeights101x1"))
    y_sim = load(os.path.join(d, "sims101x80Cg.txt")).T
    data = SepiaData(x_sim=sim[:, 0:2], t_sim=sim[:, 2:4], y_ind_sim=h_sim, y_sim=y_sim,
                     x_obs=x, y_obs=y_obs, y_ind_obs=h_obs)
    data.transform_xt()
    data.standardize_y()
    data.create_K_basis(3)
    if not discrepancy:
        return data, ["C", "g"], dict(tune=(50, 20), samples=6000, burn=1000)
    grid = np.linspace(min(h_sim), max(h_sim), 20, dtype=int)
    width = max(grid) / 20
    d_obs = np.column_stack([norm.pdf(h_obs, c, width) for c in grid])
    d_sim = np.column_stack([norm.pdf(h_sim, c, width) for c in grid])
    data.create_D_basis(D_obs=d_obs.T, D_sim=d_sim.T)
    return data, ["C", "g"], dict(tune=(50, 20), samples=6000, burn=1000)


def al5083():
    shots = ["104S", "105S", "106S"]
    sel = [3, 5, 7, 9]
    sim = [np.genfromtxt(os.path.join(AL, "features_cdf%s.csv" % s), delimiter=",",
                         skip_header=1) for s in shots]
    obs = [np.genfromtxt(os.path.join(AL, "features_cdf_obs%s.csv" % s), delimiter=",",
                         skip_header=1) for s in shots]
    design = np.loadtxt(os.path.join(AL, "Al.trial5.design.txt"), skiprows=1)
    with open(os.path.join(AL, "Al.trial5.design.txt")) as f:
        names = f.readline().split()
    y_sim = 10000 * np.concatenate([s[:, sel] for s in sim], axis=1)
    y_obs = np.concatenate([o[sel] for o in obs])[None, :]
    n_runs = int(os.environ.get("AL5083_RUNS", design.shape[0]))
    design, y_sim = design[:n_runs], y_sim[:n_runs]
    n_features = y_obs.shape[1]
    y_ind = np.arange(1, n_features + 1)
    sigy = np.diag(np.squeeze(0.01 * np.ones(n_features) * y_obs))
    data = SepiaData(t_sim=design, y_sim=y_sim, y_ind_sim=y_ind, y_obs=y_obs,
                     y_ind_obs=y_ind, Sigy=sigy)
    data.standardize_y()
    data.transform_xt()
    data.create_K_basis(n_features - 1)
    tune = tuple(int(v) for v in os.environ.get("AL5083_TUNE", "100,25").split(","))
    samples = int(os.environ.get("AL5083_SAMPLES", "10000"))
    return data, names, dict(tune=tune, samples=samples, burn=samples // 5,
                             runs=n_runs, prior="lamWs as Al_5083_calibration.py")


def al5083_cost():
    # SEPIA's full Al-5083 run did not fit this machine's time: what one
    # log-likelihood costs (its calibration model's joint covariance over the
    # runs' and the data's principal-component weights) on the first n runs,
    # and how many parameters one MCMC step updates (each needs one).
    path = os.path.join(OUT, "sepia_al5083_cost.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["runs", "loglik_seconds", "mcmc_parameters", "load"])
        for n in [int(v) for v in os.environ.get("AL5083_COST_RUNS", "100,200").split(",")]:
            os.environ["AL5083_RUNS"] = str(n)
            data, names, s = al5083()
            model = SepiaModel(data)
            model.logLik()
            start = time.time()
            for i in range(3):
                model.logLik()
            each = (time.time() - start) / 3
            params = sum(int(np.sum(~np.asarray(p.fixed))) for p in model.params.mcmcList)
            w.writerow([n, round(each, 4), params, round(os.getloadavg()[0], 2)])
            f.flush()
    print("al5083_cost done;", path)


def run(case):
    if case == "al5083_cost":
        return al5083_cost()
    if case == "ball_drop_1":
        data, names, s = ball_drop_1(True)
    elif case == "ball_drop_1_noD":
        data, names, s = ball_drop_1(False)
    elif case == "ball_drop_2":
        data, names, s = ball_drop_2(True)
    elif case == "ball_drop_2_noD":
        data, names, s = ball_drop_2(False)
    elif case == "al5083":
        data, names, s = al5083()
    else:
        raise SystemExit("unknown case " + case)
    np.random.seed(20261127)
    model = SepiaModel(data)
    if case == "al5083":
        # as Al_5083_calibration.py: "Modify priors to match Matlab"
        p = model.params.lamWs.prior
        p.bounds[1] = np.inf
        p.params = [np.ones((1, 11)), np.zeros((1, 11))]
    load0 = os.getloadavg()[0]
    start = time.time()
    model.tune_step_sizes(*s["tune"], prog=False, verbose=False)
    tuned = time.time() - start
    model.do_mcmc(s["samples"], prog=False)
    seconds = time.time() - start
    draws = model.get_samples(nburn=s["burn"])
    theta = draws["theta_native"]
    logpost = np.asarray(draws["logPost"]).reshape(-1)
    path = os.path.join(OUT, "sepia_%s.csv.gz" % case)
    with gzip.open(path, "wt", newline="") as f:
        w = csv.writer(f)
        w.writerow(names + ["logPost"])
        for i in range(theta.shape[0]):
            w.writerow(["%.8g" % v for v in theta[i]] + ["%.8g" % logpost[i]])
    commit = subprocess.run(["git", "--git-dir", os.environ.get(
        "SEPIA_GIT", "/work/.mirror/lanl+SEPIA/repo"), "rev-parse", "HEAD"],
        capture_output=True, text=True).stdout.strip()
    log = os.path.join(OUT, "sepia_runs.csv")
    new = not os.path.exists(log)
    with open(log, "a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(["case", "runs", "tune_burn", "tune_levels", "samples", "burn",
                        "seconds", "seconds_tuning", "load", "sepia_commit", "made"])
        w.writerow([case, data.sim_data.y.shape[0], s["tune"][0], s["tune"][1], s["samples"],
                    s["burn"], round(seconds, 1), round(tuned, 1), round(load0, 2), commit,
                    time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())])
    print(case, "done in", round(seconds, 1), "s;", path)


if __name__ == "__main__":
    for c in sys.argv[1:]:
        run(c)
