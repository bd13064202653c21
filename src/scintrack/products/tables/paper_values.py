"""Values printed in the papers, transcribed for the paper-vs-reproduced twins.

Source: ``shared/papers/vila-valls-2018-scintillation-mitigation.txt``.
"""

# Table I: AR(q) amplitude and AR(p) phase orders per scintillation region.
VILA_VALLS_2018_TABLE_I = {
    "severe": {"s4_range": "0.6 < S4", "amplitude": 3, "phase": 1},
    "moderate": {"s4_range": "0.3 < S4 <= 0.6", "amplitude": 3, "phase": 2},
    "low": {"s4_range": "S4 <= 0.3", "amplitude": 3, "phase": 3},
}

TRACKERS_5 = ("pll", "kf", "akf", "akf_ar", "aekf_ar")

# Table III: steady-state RMSE [rad], rows (S4, tau0), columns PLL KF AKF AKF-AR AEKF-AR.
VILA_VALLS_2018_TABLE_III = {
    "s4_0.9_tau0_0.1": (1.1, 0.71, 0.61, 0.43, 0.12),
    "s4_0.8_tau0_0.2": (0.83, 0.59, 0.52, 0.42, 0.10),
    "s4_0.7_tau0_0.3": (0.63, 0.49, 0.48, 0.42, 0.10),
    "s4_0.6_tau0_0.4": (0.47, 0.40, 0.39, 0.29, 0.08),
    "s4_0.5_tau0_0.4": (0.36, 0.31, 0.30, 0.23, 0.07),
    "s4_0.4_tau0_0.8": (0.26, 0.25, 0.25, 0.20, 0.07),
}

# Table IV: AEKF-AR steady-state RMSE [rad] with AR mismatch; rows = predicted
# scintillation (the AR fit used), columns = true scintillation; None = "-".
VILA_VALLS_2018_TABLE_IV = {
    "aekf_pred_0.9": {"s4_0.8_tau0_0.2": 0.102, "s4_0.6_tau0_0.4": None},
    "aekf_pred_0.8": {"s4_0.8_tau0_0.2": 0.10, "s4_0.6_tau0_0.4": 0.0802},
    "aekf_pred_0.7": {"s4_0.8_tau0_0.2": 0.1512, "s4_0.6_tau0_0.4": 0.0832},
    "aekf_pred_0.6": {"s4_0.8_tau0_0.2": 0.21, "s4_0.6_tau0_0.4": 0.078},
    "aekf_pred_0.5": {"s4_0.8_tau0_0.2": None, "s4_0.6_tau0_0.4": 0.0828},
    "aekf_pred_0.4": {"s4_0.8_tau0_0.2": None, "s4_0.6_tau0_0.4": 0.0829},
}

# Table VII: mean number of cycle slips over 500 runs of 500 s; the extracted
# text of the table lost its row labels, the rows follow the paper's tracker
# order everywhere else (PLL, KF, AKF, AKF-AR, AEKF-AR).
VILA_VALLS_2018_TABLE_VII = {
    "pll": {"slips_case1": 0.476, "slips_case2": 22.332, "slips_case3": 407.82},
    "kf": {"slips_case1": 0.006, "slips_case2": 2.150, "slips_case3": 216.43},
    "akf": {"slips_case1": 0.0, "slips_case2": 0.532, "slips_case3": 23.86},
    "akf_ar": {"slips_case1": 0.0, "slips_case2": 0.0, "slips_case3": 0.01},
    "aekf_ar": {"slips_case1": 0.0, "slips_case2": 0.0, "slips_case3": 0.0},
}

# Sec. VI-E (JRC Hanoi traces).  Table V: AEKF-AR amplitude (E rho_s, linear)
# and phase (E theta_s, rad) RMSE over 600 s, per event and band.
VILA_VALLS_2018_TABLE_V = {
    "event1": {"L1": (0.0178, 0.0261), "L2": (0.0196, 0.0303), "L5": (0.0179, 0.0300)},
    "event2": {"L1": (0.0174, 0.0202), "L2": (0.0200, 0.0241), "L5": (0.0176, 0.0188)},
    "event3": {"L1": (0.0204, 0.0356), "L2": (0.0249, 0.0721), "L5": (0.0321, 0.1099)},
}

# Table VI: RMSE of theta_d [rad] over the processed sequence; tracker -> (L1, L2, L5).
VILA_VALLS_2018_TABLE_VI = {
    "event1": {"pll": (0.493, 0.568, 0.586), "kf": (0.588, 0.664, 0.680), "akf": (0.598, 0.685, 0.725), "akf_ar": (0.459, 0.503, 0.531), "aekf_ar": (0.162, 0.172, 0.188)},
    "event2": {"pll": (0.12, 0.16, 0.17), "kf": (0.128, 0.18, 0.19), "akf": (0.126, 0.18, 0.189), "akf_ar": (0.105, 0.135, 0.157), "aekf_ar": (0.029, 0.037, 0.054)},
    "event3": {"pll": (0.56, 0.626, 0.654), "kf": (0.666, 0.757, 0.78), "akf": (0.688, 0.771, 0.794), "akf_ar": (0.529, 0.554, 0.616), "aekf_ar": (0.195, 0.18, 0.344)},
}

# Table VIII: number of cycle slips per event and band; tracker order PLL KF AKF AKF-AR AEKF-AR.
VILA_VALLS_2018_TABLE_VIII = {
    ("event1", "L1"): (4, 0, 2, 0, 0), ("event1", "L2"): (4, 3, 3, 0, 0), ("event1", "L5"): (5, 2, 4, 0, 0),
    ("event2", "L1"): (0, 0, 0, 0, 0), ("event2", "L2"): (2, 1, 0, 0, 0), ("event2", "L5"): (2, 0, 0, 0, 0),
    ("event3", "L1"): (2, 0, 1, 0, 0), ("event3", "L2"): (3, 2, 2, 0, 0), ("event3", "L5"): (3, 3, 2, 0, 0),
}

# Zhao, Khanafseh & Pervan, Sec. IV: ENU mean error and standard deviation [m] of one 4-minute run;
# clean (PLL-aided DLL) and jammed at ~15 dB-Hz (MM-aided DLL). The paper gives magnitudes without signs.
ZHAO_ENU = {
    ("clean", "mean", "east"): 3.9, ("clean", "mean", "north"): 0.2, ("clean", "mean", "up"): 0.5,
    ("clean", "std", "east"): 13.0, ("clean", "std", "north"): 23.0, ("clean", "std", "up"): 50.0,
    ("jammed", "mean", "east"): 5.0, ("jammed", "mean", "north"): 1.8, ("jammed", "mean", "up"): 1.9,
    ("jammed", "std", "east"): 16.0, ("jammed", "std", "north"): 32.0, ("jammed", "std", "up"): 63.0,
}
