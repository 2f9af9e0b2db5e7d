"""The parameter files repeat some of the rig's numbers as the values a deployment starts with;
they must say what ``irs_models.constants`` says (the one place the code takes them from).
"""
import math
from pathlib import Path

import pytest
import yaml

from irs_models import constants as C

ROOT = Path(__file__).resolve().parents[1]


def params(package, name, node):
    doc = yaml.safe_load((ROOT / package / 'config' / name).read_text())
    return doc[node]['ros__parameters']


def test_parameter_files_agree_with_the_constants():
    rig = params('irs_vehicle_sim', 'rig.yaml', 'vehicle_sim')
    assert rig['actuator_front']['limit'] == rig['actuator_rear']['limit'] == C.STEER_LIMIT
    assert rig['ds'] == C.SENSOR_DISTANCE
    ctl = params('irs_control', 'lateral_controller.yaml', 'lateral_controller')
    assert ctl['steer_limit'] == C.STEER_LIMIT
    assert (ctl['speed'], ctl['ds']) == (C.IDENTIFICATION_SPEED, C.SENSOR_DISTANCE)
    assert ctl['actuator_pole'] == C.PAPER_ACTUATOR_POLE
    safety = params('irs_treadmill', 'treadmill.yaml', 'treadmill_regulator')['safety']
    assert (safety['belt_half_length'], safety['belt_half_width']) == \
        (C.BELT_HALF_LENGTH, C.BELT_HALF_WIDTH)


def test_the_constants_are_the_rig():
    ft = 0.3048
    assert (2 * C.BELT_HALF_LENGTH, 2 * C.BELT_HALF_WIDTH) == pytest.approx((8 * ft, 4 * ft))
    assert abs(C.STEER_LIMIT - math.radians(C.STEER_LIMIT_DEG)) < 1e-5
    assert C.PAPER_PLANT_GAIN == pytest.approx(363.394, abs=1e-3)
