"""FMI 2.0 co-simulation slave: the backstepping speed and flux controller (glue around
satmotor.interface.ControllerUnit).  A doStep of n Ts runs n samples (ControllerUnit.samples: to a few
ulps; a remainder that ends at the host's stop time runs none); any other step is discarded.

Variables, units and defaults: satmotor.interface (CONTROLLER_*).  Control law: satmotor.control.backstepping,
drive logic: satmotor.control.drive.
"""

from satmotor_fmu_glue import UnitSlave, pin_namespace

from satmotor.interface import (
    AUTHOR,
    CONTROLLER_DESCRIPTION,
    CONTROLLER_INPUTS,
    CONTROLLER_OUTPUTS,
    CONTROLLER_PARAMETERS,
    ControllerUnit,
)


class BacksteppingController(UnitSlave):
    author = AUTHOR
    description = CONTROLLER_DESCRIPTION
    VARIABLES = CONTROLLER_INPUTS + CONTROLLER_OUTPUTS + CONTROLLER_PARAMETERS
    UNIT = ControllerUnit
    FINGERPRINT = "@SATMOTOR_FINGERPRINT@"
    _stop_time = float("inf")  # the host's stop time [s] (fmi2SetupExperiment), none given: inf

    def setup_experiment(self, start_time, stop_time, tolerance):
        self._stop_time = float("inf") if stop_time is None else float(stop_time)

    def do_step(self, current_time, step_size):
        if self._unit is not None:  # the unit may have been rebuilt by setFMUState
            self._unit.stop_time = self._stop_time
        return super().do_step(current_time, step_size)


pin_namespace(globals(), locals())  # see satmotor_fmu_glue.pin_namespace
