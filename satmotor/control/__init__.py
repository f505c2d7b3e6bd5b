"""The control side: the paper's backstepping law and the drive around it.

* :mod:`~satmotor.control.fo_model` -- the rotor-flux-oriented control model.
* :mod:`~satmotor.control.backstepping` -- the backstepping speed and flux law (the paper's eq. 67).
* :mod:`~satmotor.control.ifoc` -- the indirect field-oriented baseline controller.
* :mod:`~satmotor.control.drive` -- the drive: pre-magnetization, current limit, integral action
  (its settings and output record in :mod:`~satmotor.control.drive_config`, the start from standstill
  in :mod:`~satmotor.control.startup`),
  with :mod:`~satmotor.control.references` (shaped set-points), :mod:`~satmotor.estimation.observer`
  (the open-loop flux observer), :mod:`~satmotor.control.measurements` (the magnetizing state
  from measured currents and fluxes) and :mod:`~satmotor.control.delay` (delay compensation).
"""
