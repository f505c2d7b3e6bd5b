"""Identification from measurements: the magnetizing curve from a no-load test.

* :mod:`~satmotor.identify.noload` -- a no-load test (V_ll_rms, I_rms, f[, P_in]) turned into
  magnetizing points (peak i_mu [A], peak psi_m [Wb]); the no-load loss split into core loss (R_fe)
  and friction.
* :mod:`~satmotor.identify.locked_rotor` -- a locked-rotor test: rotor resistance and the leakages.
* :mod:`~satmotor.identify.curve_fit` -- every curve family fitted to those points (least squares).
* :mod:`~satmotor.identify.uncertainty` -- the readings' uncertainty carried into each point's covariance
  (the weights of the fits).
"""
