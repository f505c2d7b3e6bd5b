"""The drive's phases, the values of the controller's ``phase`` output: ``PREMAG`` (pre-magnetization:
the current loop builds the flux at rest) and ``RUN`` (the control law).  A module of its own so that
the drive (:mod:`satmotor.control.drive_config`, which re-exports them) and the metrics
(:mod:`satmotor.metrics`, judging the run phase only) both take them without the one importing the
other.  The C core's are ``SM_PREMAG``, ``SM_RUN`` (``fmu/native/core/sm_drive.h``)."""

PREMAG, RUN = 0, 1
