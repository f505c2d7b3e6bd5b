"""The power converter between the supply and the machine's terminals, as the plant integrates it.

* :mod:`~satmotor.converter.inverter` -- the plant's inverter: the average-value model or the
  carrier-comparison PWM inverter with dead time and device drops.
* :mod:`~satmotor.converter.dc_link` -- the optional DC link (capacitor, dc source or six-pulse
  rectifier, brake chopper, over-voltage fault), integrated with the motor's states.
* :mod:`~satmotor.converter.pwm_link` -- the switched PWM stage on the capacitor link.
"""
