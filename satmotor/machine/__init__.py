"""The machine: the saturated induction motor as the plant integrates it.

* :mod:`~satmotor.machine.magnetics` -- the magnetizing-curve families (arctan, exponential,
  polynomial, linear) and their inverse; :mod:`~satmotor.machine.table_curve` -- a measured curve.
* :mod:`~satmotor.machine.params` -- motor parameters (frozen dataclasses) and the default motor.
* :mod:`~satmotor.machine.plant` -- the stationary-frame plant model; :mod:`~satmotor.machine.integrate`
  -- its fixed-step RK4.
* :mod:`~satmotor.machine.forms` -- the T, Gamma and inverse-Gamma forms and the no-load /
  locked-rotor tests turned into motor parameters; :mod:`~satmotor.machine.library` -- named motors
  (nameplate, source, controller settings), ``motor: {preset: ...}`` in a scenario.

The inverter and the DC link the plant integrates with the motor: :mod:`satmotor.converter`.
"""
