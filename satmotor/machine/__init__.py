"""The machine: the saturated induction motor as the plant integrates it.

* :mod:`~satmotor.machine.magnetics` -- the magnetizing-curve families (arctan, exponential,
  polynomial, linear) and their inverse; :mod:`~satmotor.machine.table_curve` -- a measured curve.
* :mod:`~satmotor.machine.params` -- motor parameters (frozen dataclasses) and the default motor.
* :mod:`~satmotor.machine.plant` -- the stationary-frame plant model; :mod:`~satmotor.machine.integrate`
  -- its fixed-step RK4.
"""
