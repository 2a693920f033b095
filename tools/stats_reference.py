#!/usr/bin/env python3
"""Write the reference values that crates/eval-harness/tests/reference.rs checks the
statistics of `eval_harness::stats` against (the paper's Appendix B).

On the fixed inputs below it computes, with the libraries a Python evaluation would use:
  - the exact two-sided McNemar p-value as scipy.stats.binomtest(b, b + c, 0.5).pvalue, and the
    same p-value from exact rationals (Python integers): min(1, 2 * sum_{i<=min(b,c)} C(n,i) / 2^n),
    correctly rounded to a float. The script asserts that the two agree (scipy's two-sided
    p-value, "all outcomes no more likely than the observed one", equals the doubled lower tail
    at probability 1/2 by symmetry);
  - Holm's adjusted p-values, statsmodels.stats.multitest.multipletests(p, method="holm")[1];
  - numpy's mean and std(ddof=1) of per-run values;
  - numpy's default percentile (method="linear"), the convention of the bootstrap interval's
    end points, including the 2.5 and 97.5 percentiles of a 10,000-value array.

Every float is written as a string (Python's shortest round-trip repr), so that the Rust side
parses it with str::parse (correctly rounded) and not with serde_json's faster, not always
correctly rounded, float parser.

Usage (from the repository root; the venv lives outside the repository):
    python3 -m venv ~/.cache/nsea-stats-venv
    ~/.cache/nsea-stats-venv/bin/pip install scipy statsmodels numpy
    ~/.cache/nsea-stats-venv/bin/python tools/stats_reference.py
writes crates/eval-harness/tests/fixtures/stats_reference.json (with the library versions).
"""
import json
import math
import os
import platform
import sys
from fractions import Fraction

import numpy as np
import scipy
import statsmodels
from scipy.stats import binomtest
from statsmodels.stats.multitest import multipletests

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "crates", "eval-harness", "tests", "fixtures",
                   "stats_reference.json")

# (b, c): discordant counts. Edge cases (b + c = 0, b = c, one zero, b + c odd with |b - c| = 1),
# small tables like the paper's, and b + c up to 2,000 (p down to below f64's range).
MCNEMAR_CASES = [
    (0, 0), (0, 1), (1, 0), (1, 1), (0, 2), (2, 0), (0, 5), (5, 0), (3, 4), (4, 3), (5, 5), (7, 7),
    (1, 12), (12, 1), (0, 12), (2, 12), (6, 14), (10, 20), (20, 10), (9, 10), (25, 40), (40, 18),
    (0, 30), (1, 60), (100, 150), (150, 100), (120, 121), (300, 330), (500, 520), (499, 500),
    (0, 1000), (3, 1000), (900, 1100), (1100, 900), (950, 1050), (990, 1010), (999, 1001),
    (1000, 1000), (1, 1999), (0, 2000), (600, 1400), (700, 1300), (850, 1150), (1200, 800),
]

# Families of raw p-values: ties, zeros and ones, a single test, values whose Holm factor
# passes 1, a 24-test family as in Table 9 and a 4-test family as in Table 10.
HOLM_FAMILIES = [
    [0.01],
    [0.04, 0.01, 0.03, 0.02],
    [0.2, 0.2, 0.2],
    [0.0, 1.0, 0.5, 0.0],
    [0.5, 0.6, 0.01, 0.02, 0.9],
    [0.001, 0.013, 0.013, 0.04, 0.3, 0.0005],
    [1e-300, 3e-12, 0.049, 0.051, 1.0],
    [0.03, 0.025, 0.02, 0.015, 0.01, 0.005],
    [1.0, 0.9999, 1e-5, 0.25],
    [2.0 ** -40, 0.123, 0.0123, 0.5, 0.5, 0.00077],
    # m = 24, a mix of tiny and moderate values.
    [1e-40, 3e-25, 2e-9, 7e-7, 1e-6, 4e-5, 1.2e-4, 0.0009, 0.0011, 0.002, 0.0049, 0.006, 0.0123,
     0.021, 0.025, 0.033, 0.047, 0.061, 0.1, 0.123, 0.25, 0.5, 0.75, 1.0],
    # m = 4.
    [1.0, 1.0, 2.4e-9, 6.1e-5],
]

# Per-run values of one condition (success rates over seeds 0, 42, 1738; and longer lists).
RUN_SETS = [
    [0.945, 0.945, 0.945],
    [0.3, 0.3, 0.3],
    [0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1],
    [0.397, 0.365, 0.43],
    [0.31, 0.22, 0.40],
    [0.133, 0.09, 0.175],
    [0.005, 0.0, 0.01],
    [0.872, 0.864, 0.88],
    [0.0, 1.0],
    [1.0, 2.0, 3.0, 4.0],
    [1e8 + 0.1, 1e8 + 0.2, 1e8 + 0.3],
    [-3.5, 2.25, 1e-3, 7.0, 0.0, -1.0, 12.5, 3.3, 0.7],
    [57.5, 49.6, 65.4, 61.0, 53.2, 58.8, 55.1, 60.3, 57.0, 52.9, 59.4, 56.6],
]

PERCENTS = [0.0, 2.5, 5.0, 25.0, 33.3, 50.0, 66.7, 95.0, 97.5, 100.0]


def exact_mcnemar(b, c):
    n = b + c
    if n == 0:
        return 1.0
    k = min(b, c)
    tail = sum(math.comb(n, i) for i in range(k + 1))
    return float(min(Fraction(1), Fraction(2 * tail, 2 ** n)))


def s(x):
    """A float as its shortest round-trip string."""
    return repr(float(x))


def relative_error(a, b):
    if a == b:
        return 0.0
    return abs(a - b) / max(abs(a), abs(b))


def main():
    mcnemar = []
    for b, c in MCNEMAR_CASES:
        scipy_p = 1.0 if b + c == 0 else binomtest(b, b + c, 0.5, alternative="two-sided").pvalue
        exact_p = exact_mcnemar(b, c)
        # The two definitions agree (1e-9 relative, or both below f64's normal range).
        both_tiny = abs(scipy_p) < sys.float_info.min and abs(exact_p) < sys.float_info.min
        assert both_tiny or relative_error(scipy_p, exact_p) <= 1e-9, (b, c, scipy_p, exact_p)
        mcnemar.append({"b": b, "c": c, "p_scipy": s(scipy_p), "p_exact": s(exact_p)})

    holm = []
    for family in HOLM_FAMILIES:
        reject, adjusted, _, _ = multipletests(family, alpha=0.05, method="holm")
        holm.append({"p_values": [s(p) for p in family], "adjusted": [s(p) for p in adjusted]})

    runs = []
    for values in RUN_SETS:
        array = np.array(values, dtype=np.float64)
        runs.append({"values": [s(v) for v in values], "mean": s(np.mean(array)), "std_ddof1": s(np.std(array, ddof=1))})

    # A bootstrap-sized array: 10,000 success rates k/600 (200 tasks x 3 runs), from a seeded
    # generator, stored as numerators; and a short array with negative and repeated values.
    rng = np.random.default_rng(20261201)
    numerators = [int(k) for k in rng.binomial(600, 0.4, size=10_000)]
    arrays = [
        {"numerators": numerators, "denominator": 600},
        {"values": [s(v) for v in [3.0, -1.5, 2.0, 2.0, 0.25, 10.0, -7.0]]},
        {"values": [s(42.0)]},
    ]
    percentiles = []
    for entry in arrays:
        if "numerators" in entry:
            values = np.array(entry["numerators"], dtype=np.float64) / entry["denominator"]
        else:
            values = np.array([float(v) for v in entry["values"]], dtype=np.float64)
        entry["percentiles"] = [{"percent": s(q), "value": s(np.percentile(values, q))} for q in PERCENTS]
        percentiles.append(entry)

    document = {
        "generated_by": "tools/stats_reference.py",
        "versions": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "statsmodels": statsmodels.__version__,
        },
        "mcnemar": mcnemar,
        "holm": holm,
        "runs": runs,
        "percentile": percentiles,
    }
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    # Indented, except the 10,000 numerators, which go on one line.
    placeholder = "@NUMERATORS@"
    arrays[0]["numerators"] = placeholder
    text = json.dumps(document, indent=1).replace(json.dumps(placeholder), json.dumps(numerators, separators=(",", ":")))
    assert json.loads(text)["percentile"][0]["numerators"] == numerators
    with open(OUT, "w") as f:
        f.write(text + "\n")
    print(f"wrote {os.path.normpath(OUT)}: {len(mcnemar)} McNemar cases, {len(holm)} Holm families, "
          f"{len(runs)} run sets, {len(percentiles)} percentile arrays")


if __name__ == "__main__":
    main()
