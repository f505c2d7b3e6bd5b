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

Values off by a unit or by orders of magnitude, each note naming the field, the value and the likely
mistake: a temperature [K] below :data:`T_LOW` (Celsius written for Kelvin), a speed (``omega_ref``'s
peak, ``plant.omega_m0``) within :data:`RPM_CLOSE` of the rated speed in rpm (rpm written for rad/s) or
beyond :data:`FAR_SPEED` times the rated speed, and an inertia or a resistance (``J``, ``R_s``,
``R_r``) more than :data:`FAR_MOTOR` times above or below the named motor's (the preset's, else the
default motor's).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from orchestration.scenario.problems import Note

FAR = 10.0  # [1] a value this many times beyond its reference is noted
#: [1] a speed set-point this many times beyond the speed at which the flux set-point's back EMF
#: alone takes the whole voltage (V_max = n_p |omega_m| |psi_r|) is noted: the speed cannot follow
FAR_VOLTAGE = 2.0
FAR_SPEED = 3.0  # [1] a speed this many times beyond the rated speed is noted
RPM_CLOSE = 0.05  # [1] a speed [rad/s] this close (relative) to the rated speed's rpm value is noted
T_LOW = 200.0  # [K] a temperature below this is noted (about -73 degC: Celsius written for Kelvin?)
FAR_MOTOR = 100.0  # [1] an inertia or a resistance this many times off the named motor's is noted
MOTOR_SCALES = ("J", "R_s", "R_r")  # the motor parameters compared with the named motor's


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


def _reference_motor(sc):
    """``(name, {parameter: value})`` of the motor the scenario names (its preset), else the default's."""
    from satmotor.interface import MOTOR_PARAMETERS
    from satmotor.machine.library import MOTORS

    if getattr(sc, "preset", "") in MOTORS:
        return f"the {sc.preset} motor's", dict(MOTORS[sc.preset].values)
    return "the default motor's", {v.name: v.start for v in MOTOR_PARAMETERS}


def _given(sc, fields):
    """``[(field, name, value)]`` of the values the scenario writes (each field once): ``fields`` as for
    :func:`orchestration.scenario.feasibility.physics_check`, default ``unit.NAME``."""
    out, said = [], set()
    for unit, values in (("plant", sc.plant), ("controller", sc.controller)):
        for name, value in values.items():
            where = (fields or {}).get(unit, {}).get(name, f"{unit}.{name}")
            if where not in said and isinstance(value, (int, float)) and not isinstance(value, bool):
                said.add(where)
                out.append((where, name, float(value)))
    return out


def _times(ratio):
    """``(how many times, the likely mistake)`` of a ratio >= 1: near a power of ten (within 12 %), a
    unit prefix or a misplaced decimal point."""
    k = round(math.log10(ratio))
    near = k and abs(math.log10(ratio) - k) < 0.05
    return f"{ratio:.4g}", ("a unit prefix or a misplaced decimal point?" if near else "a typo?")


def _speed_note(file, where, value, rated, what):
    """The note of a speed [rad/s] that looks like rpm or is far beyond the rated speed, or None."""
    v = abs(value)
    if abs(v - rated.n_n) <= RPM_CLOSE * rated.n_n:
        return Note(file, where, value, (
            f"{what} = {v:.4g} rad/s is close to the motor's rated speed in rpm, {rated.n_n:g} rpm: rpm "
            f"written for rad/s? ({v:.4g} rpm = {v * math.pi / 30:.4g} rad/s; the rated speed is "
            f"{rated.omega_n:.4g} rad/s)"))
    if v > FAR_SPEED * rated.omega_n:
        return Note(file, where, value, (
            f"{what} = {v:.4g} rad/s is {v / rated.omega_n:.3g} x the motor's rated speed "
            f"{rated.omega_n:.4g} rad/s ({rated.n_n:g} rpm): far outside its range (rpm for rad/s, or a "
            "typo?)"))
    return None


def unit_notes(sc, file, fields=None):
    """Notes about the values of scenario ``sc`` off by a unit or by orders of magnitude (module
    docstring); ``fields`` as for :func:`_given`."""
    from satmotor.interface import PLANT_PARAMETERS

    kelvin = {v.name for v in PLANT_PARAMETERS if v.unit == "K"}
    units = {v.name: v.unit for v in PLANT_PARAMETERS}
    named, reference = _reference_motor(sc)
    rated = _Plate.of(sc)
    notes = []
    for where, name, value in _given(sc, fields):
        if name in kelvin and value < T_LOW:
            notes.append(Note(file, where, value, (
                f"{name} = {value:g} K is below {T_LOW:g} K ({value - 273.15:.4g} degC): Celsius written for "
                f"Kelvin? ({value:g} degC = {value + 273.15:g} K)")))
        elif name == "omega_m0":
            note = _speed_note(file, where, value, rated, "the initial speed |omega_m0|")
            notes += [note] if note else []
        elif name in MOTOR_SCALES and reference.get(name, 0) > 0 and value > 0:
            ratio = value / reference[name]
            if max(ratio, 1.0 / ratio) > FAR_MOTOR:
                times, why = _times(max(ratio, 1.0 / ratio))
                unit = units.get(name, "")
                notes.append(Note(file, where, value, (
                    f"{name} = {value:g} {unit} is {'1/' if ratio < 1 else ''}{times} x {named} "
                    f"{reference[name]:g} {unit}: far outside its range ({why})")))
    return notes


def plausibility_notes(sc, plant, ctrl, file, fields=None):
    """Notes about the inputs of scenario ``sc`` far beyond the motor (its plant and controller
    units, built from the scenario, None when refused: then nothing is said about them).  ``fields``:
    the field path of each override (:func:`orchestration.scenario.feasibility.physics_check`)."""
    rated = _Plate.of(sc)
    notes = unit_notes(sc, file, fields)
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
        far = _speed_note(file, "profiles.omega_ref", peak, rated, "the speed set-point's peak |omega_ref|")
        if far is not None:
            notes.append(far)
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
