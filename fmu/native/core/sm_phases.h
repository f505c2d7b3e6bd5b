/* satmotor/machine/phases.py in C99: phase and alpha/beta quantities of a three-phase machine with a
 * floating star point (amplitude-invariant Clarke transform), shared by the inverter (sm_inverter.c),
 * the pwm stage on the capacitor link (sm_pwm_link.c) and the controller's dead-time compensation.  The
 * same floats as the Python; no state. */
#ifndef SM_PHASES_H
#define SM_PHASES_H

/* phases.phase_currents: the phase currents c[3] [A] of an alpha/beta current [A] (no zero sequence) */
void sm_phase_currents(double i_alpha, double i_beta, double c[3]);

/* phases.alpha_beta: the alpha/beta voltage [V] of phase voltages [V] (zero sequence removed) */
void sm_alpha_beta(double va, double vb, double vc, double *a, double *b);

#endif
