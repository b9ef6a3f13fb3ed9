"""Named tolerances and the significance level of the statistical tests, in one place."""

SIGNIFICANCE = 1e-3
"""Family-wise false-alarm probability of each statistical test (Bonferroni within a test)."""

STEADY_STRESS_RTOL = 5e-3
"""Issue 2: simulated mean-field friction stress vs the quadrature of 001/Eq. 28."""

FORCE_BALANCE_RTOL = 1e-9
"""Issue 2: |K (X_L - X) - F| / F at every stored sample."""

MEAN_AGE_RTOL = 2e-2
"""Issue 2: steady mean contact age vs D0 / V."""

LANDING_RTOL = 1e-4
"""RK4 cluster integration of an isolated block vs the closed-form damped landing."""

HAZARD_RTOL = 1e-9
"""Tabulated cumulative hazard vs closed forms (Persson, Dawson) and adaptive quadrature."""

Z_MAX = 4.0
"""Monte Carlo agreement: |estimate - expected| < Z_MAX standard errors (two-sided p ~ 6e-5)."""

EXACT_SOLUTION_RTOL = 1e-8
"""Issue 3: aging and slip laws at constant velocity vs their exact solutions."""

NAIVE_RSF_ATOL = 1e-7
"""Spring-slider (log coordinates, LSODA per segment) vs the naive odeint in (mu, theta)."""
