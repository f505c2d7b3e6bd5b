"""FMI 2.0 co-simulation slave: the backstepping speed and flux controller (glue around
satmotor.interface.ControllerUnit).  One sample per doStep; dt must equal Ts.

Variables, units and defaults: satmotor.interface (CONTROLLER_*).  Control law: satmotor.backstepping,
drive logic: satmotor.drive.
"""

from satmotor_fmu_glue import UnitSlave, pin_namespace

from satmotor.interface import CONTROLLER_INPUTS, CONTROLLER_OUTPUTS, CONTROLLER_PARAMETERS, ControllerUnit


class BacksteppingController(UnitSlave):
    author = "satmotor"
    description = ("Backstepping speed and rotor-flux controller for the saturated induction motor "
                   "(seed eq 67, corrected), with pre-magnetization, reference shaping, adaptive load "
                   "estimate and the constant-m and IFOC PI baselines")
    VARIABLES = CONTROLLER_INPUTS + CONTROLLER_OUTPUTS + CONTROLLER_PARAMETERS
    UNIT = ControllerUnit
    FINGERPRINT = "@SATMOTOR_FINGERPRINT@"


pin_namespace(globals(), locals())  # see satmotor_fmu_glue.pin_namespace
