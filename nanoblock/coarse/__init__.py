"""Coarse-graining: from simulated nanoblock interfaces to rate-and-state parameters.

One idea per module; every result is an ``xarray.Dataset`` whose variables come in
(value, ``_stderr``) pairs with ``units`` and ``long_name``:

* :mod:`~nanoblock.coarse.runs`: varying scenarios key by key, running them (in process or
  on Dask), scaled-down copies, sweep scenario files, quiet seeds for soft springs;
* :mod:`~nanoblock.coarse.estimates`: batch means, weighted lines, stacking results;
* :mod:`~nanoblock.coarse.steady`: mu_ss(V) over decades and the direct-effect slope
  against 001/Eq. 28;
* :mod:`~nanoblock.coarse.transients`: A from the velocity-step spike (001/Eq. 12), and
  mu0, A, B, Dc from rate-and-state fits of simulated runs, against 001/Eq. 16;
* :mod:`~nanoblock.coarse.distributions`: P(sigma), Q(rho~) and contact ages against
  001/Eqs. 27 and 3;
* :mod:`~nanoblock.coarse.activation`: v_act from the temperature dependence of the
  direct effect (001/Eqs. 19, 33);
* :mod:`~nanoblock.coarse.stickslip`: the stick-slip onset (K/W)_c and its pulsation
  from a stiffness sweep (001/Eqs. 9-10).
"""
