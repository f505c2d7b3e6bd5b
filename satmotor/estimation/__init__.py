"""What the controller estimates of the motor it cannot measure.

* :mod:`~satmotor.estimation.observer` -- the open-loop rotor-flux observer (the current model).
* :mod:`~satmotor.estimation.flux_observer` -- the closed-loop flux observer (current and voltage
  models blended) and the speed estimate of sensorless operation.
* :mod:`~satmotor.estimation.resistance` -- the stator-resistance adaptation and the rotor resistance
  from the temperature it implies.
"""
