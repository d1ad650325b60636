"""The shipped rotator profiles: one frozen :class:`RotatorCaps` per seed machine.

Each profile is also a simulator configuration: ``urc.hardware.sim.physics_for(name)``
holds the matching mechanical truth (motor, gears, friction, sensor physics).
"""

from __future__ import annotations

from .caps import AxisCaps, RotatorCaps, SensorCaps
from .errors import ConfigError

DEFAULT_PROFILE = "tartu-urc"

_ENCODER_10PPD = SensorCaps(kind="encoder", resolution_deg=0.1, absolute=False)
_AS5600 = SensorCaps(kind="as5600", resolution_deg=360.0 / 4096, absolute=True, modulo_deg=360.0)

# creep_lead_deg: found on the simulator with a slow ramp (0.3 deg/s az, 0.05 deg/s el)
# as the lead that centres the error swing; where absent, one sensor count does.
PROFILES: dict[str, RotatorCaps] = {
    # Tartu University STM32 controller: 400 deg azimuth, 0-180 elevation, 360 deg/min,
    # 10 pulses/degree incremental encoders, a brake that needs voltage to release.
    "tartu-urc": RotatorCaps(
        name="tartu-urc",
        description="Tartu URC (STM32): encoders 10 p/deg, brake, 400 deg az, 0-180 el",
        az=AxisCaps(name="az", min_deg=0.0, max_deg=400.0, park_deg=0.0,
                    max_rate_deg_per_s=6.0, min_rate_deg_per_s=0.6, accel_deg_per_s2=12.0,
                    sensor=_ENCODER_10PPD, tolerance_deg=0.1, restart_deg=0.2, creep_lead_deg=0.08,
                    brake=True, brake_release_s=0.15, brake_engage_s=0.1),
        el=AxisCaps(name="el", min_deg=0.0, max_deg=180.0, park_deg=90.0,
                    max_rate_deg_per_s=6.0, min_rate_deg_per_s=0.6, accel_deg_per_s2=12.0,
                    sensor=_ENCODER_10PPD, tolerance_deg=0.1, restart_deg=0.2, creep_lead_deg=0.08,
                    brake=True, brake_release_s=0.15, brake_engage_s=0.1),
        command_sets=("urc", "rotctld"),
    ),
    # SARCNET mini rotator (Arduino): 0.6 rpm motors, tilt-compensated magnetometer +
    # accelerometer, no end-stop switches, azimuth windup tracked in software. Elevation
    # 0-180: the document's demo mode flies over the top (0/180); below 0 only as a
    # reading (its set-up points the loose sensor 45 deg down and reads about -45).
    "sarcnet-mini": RotatorCaps(
        name="sarcnet-mini",
        description="SARCNET mini (Arduino): 0.6 rpm, magnetometer/accelerometer sensor",
        az=AxisCaps(name="az", min_deg=-90.0, max_deg=450.0, park_deg=0.0,
                    max_rate_deg_per_s=3.6, min_rate_deg_per_s=0.4, accel_deg_per_s2=6.0,
                    sensor=SensorCaps(kind="magnetometer", resolution_deg=0.1, absolute=True,
                                      modulo_deg=360.0, noise_deg=0.15, heading_on_boom=True),
                    tolerance_deg=0.3, restart_deg=0.8, creep_lead_deg=0.15, backlash_deg=0.5),
        el=AxisCaps(name="el", min_deg=0.0, max_deg=180.0, park_deg=0.0,
                    max_rate_deg_per_s=3.6, min_rate_deg_per_s=0.4, accel_deg_per_s2=6.0,
                    sensor=SensorCaps(kind="magnetometer", resolution_deg=0.1, absolute=True,
                                      noise_deg=0.1),
                    tolerance_deg=0.3, restart_deg=0.8, creep_lead_deg=0.15, backlash_deg=0.5),
        command_sets=("sarcnet", "easycomm", "rotctld"),
    ),
    # AlfaSpid BIG-RAS (ESP32): pulse feedback, limit switches, minimum-speed ramps,
    # overturn beyond 360 deg.
    "bigras": RotatorCaps(
        name="bigras",
        description="AlfaSpid BIG-RAS (ESP32): pulse feedback 2 p/deg, limit switches, overturn",
        az=AxisCaps(name="az", min_deg=0.0, max_deg=450.0, park_deg=0.0,
                    max_rate_deg_per_s=4.0, min_rate_deg_per_s=0.8, accel_deg_per_s2=4.0,
                    sensor=SensorCaps(kind="pulse", resolution_deg=0.5, absolute=False),
                    tolerance_deg=0.5, restart_deg=1.0, limit_switches=True, creep_lead_deg=0.6),
        el=AxisCaps(name="el", min_deg=0.0, max_deg=90.0, park_deg=0.0,
                    max_rate_deg_per_s=2.0, min_rate_deg_per_s=0.5, accel_deg_per_s2=3.0,
                    sensor=SensorCaps(kind="pulse", resolution_deg=0.5, absolute=False),
                    tolerance_deg=0.5, restart_deg=1.0, limit_switches=True, creep_lead_deg=0.6),
        command_sets=("gs232a", "gs232b", "spid", "rotctld", "pstrotator"),
    ),
    # G4JNT PIC controller: potentiometer read ratiometrically through a 10-bit ADC,
    # relay-switched AC motor with slow (pulsed) and fast motion. Azimuth limits are the
    # pot angle theta from the end-stop reference, the document's "-10 to 370 deg with
    # overlap"; a bearing is theta + Z (the reference's bearing) modulo 360, so every
    # bearing has a theta inside the travel and those within 10 deg of the reference two.
    # Resolution: the coarsest ADC count inside that travel on the document's Table 1
    # pot (M = -15897: 397.4 deg over P 0..4096; dN/dx >= 527 counts: 0.75 deg).
    "g4jnt": RotatorCaps(
        name="g4jnt",
        description="G4JNT PIC: 10-bit ratiometric pot, -10..370 deg, relay AC motor, slow/fast",
        az=AxisCaps(name="az", min_deg=-10.0, max_deg=370.0, park_deg=0.0,
                    max_rate_deg_per_s=6.0, min_rate_deg_per_s=1.5, accel_deg_per_s2=30.0,
                    sensor=SensorCaps(kind="pot", resolution_deg=0.78, absolute=True,
                                      noise_deg=0.2),
                    drive="relay", drive_levels=(0.25, 1.0),
                    tolerance_deg=0.9, restart_deg=1.8, overshoot_deg=0.3, creep_lead_deg=0.3),
        el=AxisCaps(name="el", min_deg=0.0, max_deg=90.0, park_deg=0.0,
                    max_rate_deg_per_s=3.0, min_rate_deg_per_s=0.75, accel_deg_per_s2=30.0,
                    sensor=SensorCaps(kind="pot", resolution_deg=0.25, absolute=True,
                                      noise_deg=0.06),
                    drive="relay", drive_levels=(0.25, 1.0),
                    tolerance_deg=0.3, restart_deg=0.6, overshoot_deg=0.15, creep_lead_deg=0.1),
        command_sets=("g4jnt", "rotctld"),
    ),
    # Berkeley automatic rotor (ESP32): fast geared DC motors, AS5600 absolute encoders,
    # noticeable play in the gears. Speeds: its worm gearing gives ~240 deg/s at full duty
    # (~400 rpm motor, 10:1 worm, 1.5 s a turn) but it stalls below ~15 % duty and is too
    # fast above ~18 % (PWM 37-40 of 255; ~36-43 deg/s usable, bang-bang in a 4 deg band).
    # urc slews at 40 deg/s (inside that band) and creeps down to 4 deg/s (a tenth of it,
    # as 3 was of 30: at 3 the tracking error grew, true el 0.033 -> 0.039 deg avg in
    # bench/berkeley_accuracy.py; at 4 it is 0.032, at 5 0.039 again); the ramp is
    # 30 deg/s^2: at 60 deg/s^2 the axis lags its braking reference and the hold chatters
    # in the 1.5 deg gear play and a goto to az 0 stops 1.3 deg short (limit guard;
    # tests/rotator/test_motion.py). Not the 240 deg/s top speed: urc's slew speed is also
    # its full-duty speed (duty = rate / max_rate), and flown at 240 deg/s (accel 30) the
    # axes latch runaway faults (el +3.3 deg the wrong way, az +3.4 deg with the motor off)
    # and 8 berkeley goto/track tests in test_motion.py end up to 48 deg off. Elevation: "a
    # ~270 degree range" (counterweight and encoder mount), zero level and forward; the
    # document does not say where the range ends, so it is taken centred on the zenith, -45..225.
    "berkeley": RotatorCaps(
        name="berkeley",
        description="Berkeley (ESP32): fast geared motors, AS5600 12-bit absolute, gear play",
        az=AxisCaps(name="az", min_deg=0.0, max_deg=360.0, park_deg=0.0,
                    max_rate_deg_per_s=40.0, min_rate_deg_per_s=4.0, accel_deg_per_s2=30.0,
                    sensor=_AS5600, tolerance_deg=0.09, restart_deg=0.2, backlash_deg=1.5,
                    creep_lead_deg=0.03),
        el=AxisCaps(name="el", min_deg=-45.0, max_deg=225.0, park_deg=0.0,
                    max_rate_deg_per_s=40.0, min_rate_deg_per_s=4.0, accel_deg_per_s2=30.0,
                    sensor=_AS5600, tolerance_deg=0.09, restart_deg=0.2, backlash_deg=1.5,
                    creep_lead_deg=0.03),
        command_sets=("rotctld",),
    ),
    # Yaesu G-5500 class: 450 deg azimuth, 0-180 elevation, pot feedback, on/off drive.
    "g5500": RotatorCaps(
        name="g5500",
        description="Yaesu G-5500 class: 450 deg az, 0-180 el, pot feedback, on/off drive",
        az=AxisCaps(name="az", min_deg=0.0, max_deg=450.0, park_deg=0.0,
                    max_rate_deg_per_s=6.2, min_rate_deg_per_s=6.2, accel_deg_per_s2=40.0,
                    sensor=SensorCaps(kind="pot", resolution_deg=450.0 / 1024, absolute=True,
                                      noise_deg=0.1),
                    drive="relay", drive_levels=(1.0,),
                    tolerance_deg=0.45, restart_deg=1.0, overshoot_deg=0.4),
        el=AxisCaps(name="el", min_deg=0.0, max_deg=180.0, park_deg=0.0,
                    max_rate_deg_per_s=2.7, min_rate_deg_per_s=2.7, accel_deg_per_s2=30.0,
                    sensor=SensorCaps(kind="pot", resolution_deg=180.0 / 1024, absolute=True,
                                      noise_deg=0.05),
                    drive="relay", drive_levels=(1.0,),
                    tolerance_deg=0.2, restart_deg=0.5, overshoot_deg=0.15, creep_lead_deg=0.35),
        command_sets=("gs232a", "gs232b", "rotctld"),
    ),
    # SatNOGS rotator v3 as its firmware drives it (stepper_motor_controller.ino:26-37, the
    # SatNOGS firmware at pschneiders/satnogs-rotator-firmware 02bc016): NEMA17 steppers at
    # 1/8 microstep (1600 steps a turn) through 54:1 worm gears, 240 steps/deg; 3200
    # steps/s top (13.3 deg/s) and 1600 steps/s^2 (6.7 deg/s^2); az 0..360 and el 0..180
    # from the homing endstops (its seek, ino:105-106), where it parks (globals.h:59). The
    # step count is its position (incremental: homing re-references it). min_rate: a
    # stepper has no stall speed; the slowest speed urc asks is a tenth of the top.
    # limit_switches: its homing endstop, one per axis at the low end (gpio: limit_min).
    "satnogs-v3": RotatorCaps(
        name="satnogs-v3",
        description="SatNOGS rotator v3: steppers, 54:1 worms, homing endstops, 0-360 az, 0-180 el",
        az=AxisCaps(name="az", min_deg=0.0, max_deg=360.0, park_deg=0.0,
                    max_rate_deg_per_s=40.0 / 3.0, min_rate_deg_per_s=4.0 / 3.0, accel_deg_per_s2=20.0 / 3.0,
                    sensor=SensorCaps(kind="encoder", resolution_deg=1.0 / 240.0, absolute=False),
                    tolerance_deg=0.05, restart_deg=0.1, limit_switches=True),
        el=AxisCaps(name="el", min_deg=0.0, max_deg=180.0, park_deg=0.0,
                    max_rate_deg_per_s=40.0 / 3.0, min_rate_deg_per_s=4.0 / 3.0, accel_deg_per_s2=20.0 / 3.0,
                    sensor=SensorCaps(kind="encoder", resolution_deg=1.0 / 240.0, absolute=False),
                    tolerance_deg=0.05, restart_deg=0.1, limit_switches=True),
        command_sets=("easycomm2", "rotctld"),
    ),
}


def get_profile(name: str) -> RotatorCaps:
    try:
        return PROFILES[name]
    except KeyError:
        raise ConfigError(
            f"unknown profile {name!r}; expected one of {', '.join(sorted(PROFILES))}",
            key="profile", expected=" | ".join(sorted(PROFILES)), found=name) from None
