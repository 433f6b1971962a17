import math

import pytest

from robots import RobotConfigError, load_catalogue, servo_model
from robots.servo import parse_catalogue

REQUIRED = ("STS3215_7V4", "STS3215_12V", "XL430_W250", "XL330_M288", "AX_12A")


def test_catalogue_has_the_required_models() -> None:
    cat = load_catalogue()
    for name in REQUIRED:
        assert name in cat


@pytest.mark.parametrize(
    ("name", "stall_nm", "rpm", "mass_kg", "protocol"),
    [
        ("XL430_W250", 1.4, 57, 0.0572, "dynamixel2"),
        ("XL330_M288", 0.52, 103, 0.018, "dynamixel2"),
        ("AX_12A", 1.5, 59, 0.0546, "dynamixel1"),
        ("STS3215_12V", 30 * 0.0980665, 60 / (6 * 0.222), 0.055, "feetech_sts"),
    ],
)
def test_published_figures(
    name: str, stall_nm: float, rpm: float, mass_kg: float, protocol: str
) -> None:
    s = servo_model(name)
    assert s.stall_torque_nm == pytest.approx(stall_nm, rel=2e-3)
    assert s.no_load_speed_rad_s == pytest.approx(rpm * 2 * math.pi / 60, rel=2e-3)
    assert s.mass_kg == pytest.approx(mass_kg)
    assert s.protocol == protocol


def test_torque_speed_envelope_is_the_dc_motor_line() -> None:
    s = servo_model("XL430_W250")
    assert s.torque_limit_nm(0.0) == pytest.approx(1.4)
    assert s.torque_limit_nm(s.no_load_speed_rad_s / 2) == pytest.approx(0.7)
    assert s.torque_limit_nm(-s.no_load_speed_rad_s / 2, margin=0.8) == pytest.approx(0.56)
    assert s.torque_limit_nm(2 * s.no_load_speed_rad_s) == 0.0


def test_ticks_per_rad() -> None:
    assert servo_model("XL430_W250").ticks_per_rad == pytest.approx(4096 / (2 * math.pi))
    assert servo_model("AX_12A").ticks_per_rad == pytest.approx(1023 / math.radians(300), rel=2e-3)


def test_unknown_model_names_the_known_ones() -> None:
    with pytest.raises(RobotConfigError, match="XL430_W250"):
        servo_model("HS_999_NOT_A_SERVO")


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ("stall_torque_nm = -1.0", "stall_torque_nm"),
        ('protocol = "can"', "protocol"),
        ("position_max_tick = 0", "position_max_tick"),
        ("color = 1", "color"),
        ("armature_kg_m2 = 0.0", "armature_kg_m2"),
        ("armature_kg_m2 = 50.0", "armature_kg_m2"),
    ],
)
def test_bad_catalogue_entries_name_the_field(patch: str, field: str) -> None:
    base = {
        "vendor": '"X"',
        "protocol": '"dynamixel2"',
        "model_number": "1",
        "nominal_voltage_v": "12.0",
        "voltage_min_v": "9.0",
        "voltage_max_v": "12.6",
        "stall_torque_nm": "1.0",
        "no_load_speed_rad_s": "5.0",
        "ticks_per_rev": "4096",
        "position_min_tick": "0",
        "position_max_tick": "4095",
        "default_baud": "57600",
        "mass_kg": "0.05",
        "max_temperature_c": "70.0",
    }
    key, value = (s.strip() for s in patch.split("=", 1))
    base[key] = value
    text = "[S]\n" + "\n".join(f"{k} = {v}" for k, v in base.items())
    with pytest.raises(RobotConfigError) as info:
        parse_catalogue(text, "servos.toml")
    assert field in str(info.value) and "servos.toml" in str(info.value)


@pytest.mark.parametrize(
    ("name", "armature_kg_m2"),
    # Duclusaud & Passault 2025 (BAM), identified model m1 (robots/servos.toml)
    [("STS3215_7V4", 0.0284), ("XL330_M288", 0.0018), ("MX_64_P2", 0.0120), ("XL_320", 0.0011)],
)
def test_identified_rotor_inertias(name: str, armature_kg_m2: float) -> None:
    assert servo_model(name).armature_kg_m2 == pytest.approx(armature_kg_m2)


def test_rotor_inertia_is_optional_and_unknown_where_unpublished() -> None:
    # no identification of the 12 V STS3215 or of the XL430 is published: not guessed
    assert servo_model("STS3215_12V").armature_kg_m2 is None
    assert servo_model("XL430_W250").armature_kg_m2 is None
