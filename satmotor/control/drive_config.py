"""The drive's settings and its output record: :class:`DriveConfig` (with the checks of every setting,
the String ones against their choices, the tuples ``satmotor.interface`` gives its FMU parameters) and
:class:`DriveOutput` (one sample), the phases ``PREMAG`` and ``RUN``.  The drive itself:
:mod:`satmotor.control.drive`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from satmotor.drive_phase import PREMAG, RUN  # noqa: F401 (re-exported: the drive's phases)
from satmotor.errors import ParameterError, require_choice, require_number

FLUX_SOURCES = ("measured", "observer")
OBSERVERS = ("closed_loop", "current_model")
SPEED_SOURCES = ("measured", "estimated")
FLUX_MODES = ("nominal", "loss_minimizing")
HOST_DELAY_MAX = 3  # [samples] most coupling delay a host may add (a Jacobi master adds 1)


@dataclass(frozen=True)
class DriveConfig:
    """Settings of the drive around the control law (SI units).

    ref_bandwidth [rad/s] of both reference shapers (10-90 % rise 4.22/ref_bandwidth);
    I_max [A] current limit (pre-magnetization current, flux set-points, the law's virtual
    controls); premag_fraction [1] of the flux set-point at which the law takes over;
    premag_min_fraction [1]: the law takes over from this fraction on if the rotor moves by more
    than premag_speed_tol [rad/s] or premag_time_max [s] has passed, never below it;
    premag_boost [1]; premag_gain [Ohm] K_pm of the pre-magnetization current loop;
    flux_source 'measured' (the psi_r inputs, the seed's assumption) or 'observer'
    (from i_s, omega_m and the applied v_s); observer 'closed_loop'
    (:class:`satmotor.estimation.flux_observer.ClosedLoopObserver`, current and voltage models blended) or
    'current_model' (:class:`satmotor.estimation.observer.RotorFluxObserver`, open loop);
    speed_source 'measured' (the omega_m input) or 'estimated' (the closed-loop observer's speed
    estimate; the omega_m input is not read; needs flux_source 'observer', observer 'closed_loop');
    speed_bandwidth [rad/s] of the speed estimate's adaptation; delay_samples 0 or 1
    (:mod:`satmotor.control.delay`); host_delay_samples 0 to HOST_DELAY_MAX: the samples of coupling
    delay the host adds between the controller's output and the plant's input (a Jacobi master: 1),
    compensated with delay_samples by one prediction over both; current_limit_gain [1/s] of the
    measured-current limiter (0: off, the law's model currents alone are bounded;
    :mod:`satmotor.control.current_limit`); field_weakening: the flux set-point psi_ref is the nominal flux,
    lowered where the steady stator voltage would exceed fw_voltage_ratio [1] of V_dc/sqrt(3)
    (:mod:`satmotor.control.field_weakening`); False: psi_ref as it is (the drive before it);
    flux_mode 'nominal' (the set-point above) or 'loss_minimizing' (:mod:`satmotor.control.loss_min`: the
    flux of the least modelled copper and core loss at the present torque and speed, at most the nominal
    or field-weakening set-point, at least flux_floor [Wb], moving at most flux_rate_max [Wb/s = V s/s];
    loss_R_fe [Ohm] the core-loss resistance of its loss model, 0: copper loss only).
    rs_adaptation: the closed-loop observer adapts R_s, and the law uses the estimate; rr_tracking: R_r
    from the temperature R_s_hat implies, in the observer and the law (needs rs_adaptation); both need
    flux_source 'observer', observer 'closed_loop' (:mod:`satmotor.estimation.resistance`).
    """

    ref_bandwidth: float = 40.0
    I_max: float = 30.0
    premag_fraction: float = 0.9
    premag_boost: float = 1.5
    premag_gain: float = 20.0
    premag_time_max: float = 0.4
    premag_min_fraction: float = 0.5
    premag_speed_tol: float = 2.0
    flux_source: str = "measured"
    delay_samples: int = 0
    observer: str = "closed_loop"
    speed_source: str = "measured"
    speed_bandwidth: float = 200.0
    field_weakening: bool = True
    fw_voltage_ratio: float = 0.95
    current_limit_gain: float = 200.0
    host_delay_samples: int = 0
    flux_mode: str = "nominal"
    flux_floor: float = 0.25
    flux_rate_max: float = 5.0
    loss_R_fe: float = 0.0
    rs_adaptation: bool = False
    rr_tracking: bool = False

    def __post_init__(self):
        require_number("ref_bandwidth", self.ref_bandwidth, 0)
        require_number("I_max", self.I_max, 0)
        require_number("premag_fraction", self.premag_fraction, 0, upper=1)
        require_number("premag_min_fraction", self.premag_min_fraction, 0, upper=self.premag_fraction)
        require_number("premag_boost", self.premag_boost, 1, inclusive=True)
        require_number("premag_gain", self.premag_gain, 0)
        require_number("premag_time_max", self.premag_time_max, 0)
        require_number("premag_speed_tol", self.premag_speed_tol, 0)
        require_choice("flux_source", self.flux_source, FLUX_SOURCES)
        if self.delay_samples not in (0, 1) or isinstance(self.delay_samples, bool):
            raise ParameterError("delay_samples", self.delay_samples, "must be 0 or 1")
        require_number("speed_bandwidth", self.speed_bandwidth, 0)
        require_choice("observer", self.observer, OBSERVERS)
        require_choice("speed_source", self.speed_source, SPEED_SOURCES)
        closed_loop = self.flux_source == "observer" and self.observer == "closed_loop"
        if self.speed_source == "estimated" and not closed_loop:
            raise ParameterError("speed_source", self.speed_source, "needs flux_source = observer and "
                                 "observer = closed_loop (the speed estimate is the closed-loop observer's)")
        for name in ("rs_adaptation", "rr_tracking"):
            if not isinstance(getattr(self, name), bool):
                raise ParameterError(name, getattr(self, name), "must be a bool")
        if self.rs_adaptation and not closed_loop:
            raise ParameterError("rs_adaptation", True, "needs flux_source = observer and observer = "
                                 "closed_loop (the estimate is the closed-loop observer's)")
        if self.rr_tracking and not self.rs_adaptation:
            raise ParameterError("rr_tracking", True,
                                 "needs rs_adaptation (the temperature comes from R_s_hat)")
        if not isinstance(self.field_weakening, bool):
            raise ParameterError("field_weakening", self.field_weakening, "must be a bool")
        require_number("fw_voltage_ratio", self.fw_voltage_ratio, 0, upper=1)
        require_number("current_limit_gain", self.current_limit_gain, 0, inclusive=True)
        if (isinstance(self.host_delay_samples, bool) or not isinstance(self.host_delay_samples, int)
                or not 0 <= self.host_delay_samples <= HOST_DELAY_MAX):
            raise ParameterError("host_delay_samples", self.host_delay_samples,
                                 f"must be an integer from 0 to {HOST_DELAY_MAX}")
        require_choice("flux_mode", self.flux_mode, FLUX_MODES)
        require_number("flux_floor", self.flux_floor, 0)
        require_number("flux_rate_max", self.flux_rate_max, 0)
        require_number("loss_R_fe", self.loss_R_fe, 0, inclusive=True)


class DriveOutput(NamedTuple):
    """One sample of a drive (SI units); errors are 0 during pre-magnetization.  With a delay,
    v_s_alpha/beta are the voltages applied now (computed one sample earlier); the other fields
    belong to this sample's computation (v_sd, v_sq: the command applied from the next sample)."""

    v_s_alpha: float  # [V]
    v_s_beta: float  # [V]
    v_sd: float  # [V] flux frame
    v_sq: float  # [V]
    e1: float  # [Wb]
    e2: float  # [Wb/s]
    z1: float  # [rad/s]
    z2: float  # [rad/s^2]
    V: float  # Lyapunov function
    W: float  # det Lambda (0 where not defined)
    T_load_est: float  # [N m] load used by the law (estimate in the estimated mode)
    omega_ref_shaped: float  # [rad/s] shaped speed reference (pre-magnetization: the shaper at rest, 0)
    psi_ref_shaped: float  # [Wb] shaped flux reference (pre-magnetization: the shaper at rest, 0)
    phase: int  # PREMAG or RUN
    voltage_limited: bool
    singular_limited: bool
    current_limited: bool
    psi_r_hat_alpha: float  # [Wb] rotor flux the drive used (estimate, or the measurement)
    psi_r_hat_beta: float  # [Wb]
