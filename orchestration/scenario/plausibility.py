"""Inputs far outside the motor's physical range: said (notes), never refused.

A scenario may ask for anything the FMUs accept; some values are then most likely a typo or a unit
mistake (a DC link of 1e12 V, a speed set-point a hundred times the rated speed).  The run is
allowed (a note is not a problem), but it does not pass silently: :func:`plausibility_notes` gives one
:class:`~orchestration.scenario.problems.Note` per such input, said by ``validate``, ``run`` and
``batch`` with the other notes.  The references are the motor's name plate (the preset's,
:attr:`satmotor.machine.library.NamedMotor.nameplate`, for ``motor: {preset: NAME}``, else the default
motor's, :class:`satmotor.machine.params.RatedData`) and, for the speed, what the scenario's own voltage
limit allows at its own flux set-point (with the controller's field weakening on, the default, at the
least flux it sets, :data:`satmotor.control.field_weakening.FLOOR` times ``psi_ref``); a value
:data:`FAR` times beyond them is noted.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from orchestration.scenario.problems import Note

FAR = 10.0  # [1] a value this many times beyond its reference is noted
#: [1] a speed set-point this many times beyond the speed at which the flux set-point's back EMF
#: alone takes the whole voltage (V_max = n_p |omega_m| |psi_r|) is noted: the speed cannot follow
FAR_VOLTAGE = 2.0


class _Plate(NamedTuple):
    """The name-plate figures the notes compare with: V_n [V] line-to-line rms, n_n [rpm], T_n [N m]."""

    V_n: float
    n_n: float
    T_n: float

    @property
    def omega_n(self):
        """Rated mechanical speed [rad/s]."""
        return self.n_n * math.pi / 30.0

    @classmethod
    def of(cls, sc):
        """The plate of the scenario's preset motor, else of the default motor."""
        from satmotor.machine.library import MOTORS
        from satmotor.machine.params import RatedData

        plate = MOTORS[sc.preset].nameplate if getattr(sc, "preset", "") in MOTORS else RatedData()
        return cls(plate.V_n, plate.n_n, plate.T_n)


def plausibility_notes(sc, plant, ctrl, file):
    """Notes about the inputs of scenario ``sc`` far beyond the motor (its plant and controller
    units, built from the scenario, None when refused: then nothing is said about them)."""
    rated = _Plate.of(sc)
    notes = []
    if ctrl is not None:
        V_dc = ctrl.drive.V_max * math.sqrt(3.0)
        V_link = rated.V_n * math.sqrt(2.0)  # [V] the DC link the name plate needs: line-to-line peak
        if V_dc > FAR * V_link:
            notes.append(Note(file, "controller.V_dc", V_dc, (
                f"V_dc = {V_dc:.4g} V is {V_dc / V_link:.3g} x the {V_link:.4g} V DC link the motor's name "
                f"plate ({rated.V_n:g} V line to line) needs: far outside its physical range (a unit "
                "mistake?)")))
    inv = getattr(plant, "inverter", None)
    if inv is not None and ctrl is not None:  # a switching plant: its link and the controller's limit
        V_ctrl = ctrl.drive.V_max * math.sqrt(3.0)
        if inv.link_voltage() != V_ctrl:
            notes.append(Note(file, "plant.V_dc", inv.link_voltage(), (
                f"the plant's pwm inverter switches V_dc = {inv.link_voltage():.4g} V, the controller's "
                f"voltage limit assumes V_dc = {V_ctrl:.4g} V (set both to the link's voltage)")))
    profiles, stop = sc.profiles, sc.stop_time
    if stop is None:
        return notes
    omega, psi, load = profiles.get("omega_ref"), profiles.get("psi_ref"), profiles.get("T_load")
    if omega is not None:
        peak = max(abs(v) for v in omega.bounds(0.0, stop))
        if peak > FAR * rated.omega_n:
            notes.append(Note(file, "profiles.omega_ref", peak, (
                f"the speed set-point's peak |omega_ref| = {peak:.4g} rad/s is {peak / rated.omega_n:.3g} x "
                f"the motor's rated speed {rated.omega_n:.4g} rad/s ({rated.n_n:g} rpm): far outside its "
                "range")))
        elif plant is not None and ctrl is not None and psi is not None:
            from satmotor.control.field_weakening import FLOOR

            psi_lo = psi.bounds(0.0, stop)[0]
            weakened = ctrl.drive.dcfg.field_weakening  # the drive lowers the flux down to FLOOR psi_ref
            if weakened:
                psi_lo *= FLOOR
            if psi_lo > 0:
                omega_v = ctrl.drive.V_max / (plant.params.n_p * psi_lo)  # [rad/s] mechanical
                if peak > FAR_VOLTAGE * omega_v:
                    notes.append(Note(file, "profiles.omega_ref", peak, (
                        f"the speed set-point's peak |omega_ref| = {peak:.4g} rad/s is "
                        f"{peak / omega_v:.3g} x {omega_v:.4g} rad/s, the speed at which the "
                        f"{'least weakened flux' if weakened else 'flux set-point'}'s back EMF alone "
                        f"(n_p |omega_m| |psi_r|, |psi_r| >= {psi_lo:.4g} Wb) "
                        f"takes the whole voltage V_dc/sqrt(3) = {ctrl.drive.V_max:.4g} V: the speed "
                        "cannot follow it")))
    if load is not None:
        peak = max(abs(v) for v in load.bounds(0.0, stop))
        if peak > FAR * rated.T_n:
            notes.append(Note(file, "profiles.T_load", peak, (
                f"the load's peak |T_load| = {peak:.4g} N m is {peak / rated.T_n:.3g} x the motor's rated "
                f"torque {rated.T_n:.4g} N m: far outside its physical range")))
    return notes
