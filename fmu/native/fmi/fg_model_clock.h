/* fg_model_clock.h - the one function a model implements to be built as an FMI 3.0 Scheduled Execution
 * FMU (fmi3_se_glue.c): its sample period.  The glue declares one periodic input clock of constant
 * interval (the build passes -DFG_CLOCK_VR=<its value reference> -DFG_CLOCK_INTERVAL=<the interval [s],
 * intervalDecimal of modelDescription.xml>) and runs each activation as one step of that interval,
 * fg_model_do_step(inst, data, activationTime, FG_CLOCK_INTERVAL). */
#ifndef FG_MODEL_CLOCK_H
#define FG_MODEL_CLOCK_H

#include "fg_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* the model's sample period [s] with its parameters as set (called at the end of initialization,
 * after fg_model_exit_initialization succeeded): a period other than the clock's constant interval
 * is refused there, naming both */
double fg_model_clock_period(const void *data);

#ifdef __cplusplus
}
#endif
#endif
